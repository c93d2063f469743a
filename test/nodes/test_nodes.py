"""Both nodes and a test client in one process: the paper's example and bad input."""

import os
import threading
import time

from diagnostic_msgs.msg import DiagnosticStatus
from node_status import assert_planned
import numpy as np
import pytest
from rclpy.serialization import serialize_message
from splines445_ros.nodes import arm_sim_node, planner_node, raw_messages, ros_conversions
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.ros_conversions import duration_to_seconds, sampled_trajectory_from_msg
from splines445_ros.planning import plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.sim.playback import SampledTrajectory
from splines445_ros.tools.in_process import InProcessSystem, overrides, stamp_ns, waypoint_message
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

CONFIG = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'planar_arm.yaml')
W = pe.joint_waypoints()
BOUNDARY = (pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION,
            pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION)
JERK_LIMIT = 200.0  # config/planar_arm.yaml


@pytest.fixture
def system():
    # The params file simulates the arm's dynamics; these tests check exact playback.
    with InProcessSystem(arm_parameters={'initial_positions': W[0].tolist(),
                                         'simulation': 'kinematic'},
                         params_file=CONFIG) as s:
        yield s


def trajectory_arrays(msg):
    times = np.array([duration_to_seconds(p.time_from_start) for p in msg.points])
    pos = np.array([p.positions for p in msg.points])
    vel = np.array([p.velocities for p in msg.points])
    acc = np.array([p.accelerations for p in msg.points])
    return times, pos, vel, acc


@pytest.mark.parametrize('method', ['434', '445'])
def test_paper_example_through_both_nodes(system, method):
    assert system.set_planner_parameters({'method': method})[0].successful
    n_arm_status = len(system.arm_status)
    status, msg = system.request(waypoint_message(pe.JOINT_NAMES, W, *BOUNDARY))
    assert_planned(status)
    assert list(msg.joint_names) == list(pe.JOINT_NAMES)
    times, pos, vel, acc = trajectory_arrays(msg)
    period = 0.01
    reference = plan(W, method, 'uniform', max_velocity=pe.MAX_VELOCITY,
                     max_acceleration=pe.MAX_ACCELERATION, max_jerk=[JERK_LIMIT] * 3,
                     start_velocity=BOUNDARY[0], start_acceleration=BOUNDARY[1],
                     end_velocity=BOUNDARY[2], end_acceleration=BOUNDARY[3])
    assert times[0] == 0.0 and np.all(np.diff(times) > 0.0)
    # A point every period, but those within half a period of a waypoint's
    # time, and one exactly at every waypoint.
    passed = reference.waypoint_times
    regular = [t for t in np.arange(0.0, reference.duration, period)
               if np.min(np.abs(t - passed)) >= 0.5 * period - 1e-12]
    np.testing.assert_allclose(times, np.sort(np.concatenate([regular, passed])), atol=1e-8)
    for t, q in zip(passed, W):
        np.testing.assert_allclose(pos[np.argmin(np.abs(times - t))], q, atol=1e-12)
    np.testing.assert_array_equal(pos[-1], W[-1])
    np.testing.assert_allclose(vel[0], pe.BOUNDARY_VELOCITY, atol=1e-9)
    np.testing.assert_allclose(acc[0], pe.BOUNDARY_ACCELERATION, atol=1e-9)
    np.testing.assert_allclose(vel[-1], pe.BOUNDARY_VELOCITY, atol=1e-9)
    np.testing.assert_allclose(acc[-1], pe.BOUNDARY_ACCELERATION, atol=1e-9)
    # Limits of config/planar_arm.yaml hold on every published sample.
    assert np.all(np.abs(vel) <= pe.MAX_VELOCITY * (1 + 1e-9))
    assert np.all(np.abs(acc) <= pe.MAX_ACCELERATION * (1 + 1e-9))
    # Continuity: between samples the acceleration can change by at most jerk * dt.
    assert np.all(np.abs(np.diff(acc, axis=0)) <= JERK_LIMIT * np.diff(times)[:, None] + 1e-9)
    assert np.all(np.abs(np.diff(vel, axis=0)) <= 10.0 * np.diff(times)[:, None] + 1e-9)
    # The published curve passes through every waypoint at the planned knot times.
    assert times[-1] == pytest.approx(reference.duration, abs=1e-9)
    played = sampled_trajectory_from_msg(msg, pe.JOINT_NAMES)
    for t, q in zip(reference.breakpoints, W):
        np.testing.assert_allclose(played.state_at(t)[0], q, atol=1e-6)
    values = status_values(status)
    assert values['method'] == method
    assert float(values['duration']) == pytest.approx(reference.duration, rel=1e-8)
    # The arm plays it and ends at the last waypoint, the tool at (1, 0) with yaw 0.
    played, final = system.wait_until_played(n_arm_status, times[-1])
    assert len(played) > 10 and max(np.abs(s.velocity).max() for s in played) > 0.5
    # It ends moving (the paper's end velocity), which the arm says it stops at once.
    accepted = next(s for s in system.arm_status[n_arm_status:] if 'accepted' in s.message)
    assert accepted.level == DiagnosticStatus.WARN, accepted.message
    assert 'non-zero velocity' in accepted.message
    np.testing.assert_allclose(final.position, W[-1], atol=1e-9)
    np.testing.assert_array_equal(final.velocity, 0.0)
    assert system.spin_until(lambda: system.tool_poses
                             and stamp_ns(system.tool_poses[-1]) >= stamp_ns(final), 10.0)
    pose = system.tool_poses[-1].pose
    assert (pose.position.x, pose.position.y) == pytest.approx((1.0, 0.0), abs=1e-9)
    assert pose.orientation.z == pytest.approx(0.0, abs=1e-9)


def bad_requests():
    nan = waypoint_message(pe.JOINT_NAMES, W)
    nan.points[3].positions[1] = float('nan')
    short = waypoint_message(pe.JOINT_NAMES, W[:1])
    empty = JointTrajectory()
    unknown = waypoint_message(['joint1', 'elbow', 'joint3'], W)
    duplicate = waypoint_message(['joint1', 'joint1', 'joint3'], W)
    missing = waypoint_message(['joint1', 'joint2'], W[:, :2])
    ragged = waypoint_message(pe.JOINT_NAMES, W)
    ragged.points[5].positions = [0.0, 1.0]
    too_fast = waypoint_message(pe.JOINT_NAMES, W, start_velocity=[3.0, 0.0, 0.0])
    bad_boundary = waypoint_message(pe.JOINT_NAMES, W, end_acceleration=[1.0])
    # 100,000 names, a duplicate among them: refused by their count, before they are read
    # (counting duplicates pairwise took seconds on 10,000), with a short message.
    crowd = JointTrajectory()
    crowd.joint_names = [f'j{k % 99_999}' for k in range(100_000)]
    # A time_from_start that joint_trajectory_controller would refuse (helper-88: a
    # negative one was planned, nanosec 1e9 said "not strictly increasing").
    negative = waypoint_message(pe.JOINT_NAMES, W, times=np.arange(len(W)) - 5.0)
    nanos = waypoint_message(pe.JOINT_NAMES, W, times=np.arange(len(W)) * 1.0)
    nanos.points[2].time_from_start.nanosec = 1_000_000_000
    effort = waypoint_message(pe.JOINT_NAMES, W)
    effort.points[4].effort = [1.0, 2.0, 3.0]
    return [
        ('efforts', effort, 'point 4 has effort values: waypoints are planned from positions'),
        ('negative time', negative, 'point 0: time_from_start is -5 s: it must not be negative'),
        ('nanosec 1e9', nanos, 'point 2: time_from_start.nanosec is 1000000000: it must be'),
        ('NaN position', nan, 'waypoints[3, 1] is nan'),
        ('one point', short, 'at least 2 waypoints'),
        ('empty message', empty, 'joint_names of the message is empty'),
        ('unknown joint', unknown, "unknown joints ['elbow']"),
        ('duplicate joint', duplicate, 'duplicate joint names'),
        ('missing joint', missing, "missing joints ['joint3']"),
        ('too many joints', crowd, 'the message names 100000 joints; this node controls 3'),
        ('ragged point', ragged, 'point 5 has 2 positions for 3 joints'),
        ('infeasible boundary', too_fast, 'infeasible'),
        ('short boundary', bad_boundary, 'point 11 has 1 accelerations for 3 joints'),
    ]


def test_bad_requests_get_an_error_and_the_next_good_one_is_served(system):
    cases = bad_requests()
    for name, msg, expected in cases:
        status, traj = system.request(msg)
        assert status.level == DiagnosticStatus.ERROR, name
        assert expected in status.message, (name, status.message)
        assert len(status.message) < 1000, name
        assert traj is None
    status, traj = system.request(waypoint_message(pe.JOINT_NAMES, W))
    assert_planned(status)
    assert status_values(status)['request'] == str(len(cases) + 1)
    assert traj is not None


def test_fixed_timing_takes_durations_from_time_from_start(system):
    assert system.set_planner_parameters({'timing': 'fixed'})[0].successful
    times = 0.5 + np.arange(len(W)) * 0.6
    status, msg = system.request(waypoint_message(pe.JOINT_NAMES, W, times=times))
    assert_planned(status)
    assert trajectory_arrays(msg)[0][-1] == pytest.approx(times[-1] - times[0], abs=1e-9)
    no_times, _ = system.request(waypoint_message(pe.JOINT_NAMES, W))
    assert no_times.level == DiagnosticStatus.ERROR
    assert 'time_from_start' in no_times.message
    fast, _ = system.request(waypoint_message(pe.JOINT_NAMES, W, times=times * 0.1))
    assert fast.level == DiagnosticStatus.ERROR and 'exceed' in fast.message


BAD_PLANNER_PARAMETERS = [
    ({'max_velocity': [2.0, -1.0, 2.0]}, 'max_velocity[1]'),
    ({'max_acceleration': [10.0, 10.0]}, 'one value per joint'),
    ({'max_jerk': [float('nan'), 1.0, 1.0]}, 'max_jerk[0]'),
    ({'method': '345'}, 'method must be one of'),
    ({'timing': 'fast'}, 'timing must be one of'),
    ({'sample_period': 0.0}, 'sample_period'),
    ({'joint_names': ['a', 'a', 'b']}, 'duplicates'),
    ({'joint_names': ['a', 'b']}, 'one value per joint (2)'),
]


def test_invalid_planner_parameters_are_rejected_with_a_reason(system):
    before = system.planner.parameters.config
    for values, reason in BAD_PLANNER_PARAMETERS:
        result = system.set_planner_parameters(values)[0]
        assert not result.successful, values
        assert reason in result.reason, (values, result.reason)
        assert system.planner.parameters.config == before
        for name in values:
            kept = system.planner.get_parameter(name).value
            assert tuple(kept) if isinstance(kept, list) else kept == getattr(before, name)
    # A consistent change of several parameters at once is accepted and used.
    result = system.planner.set_parameters_atomically(overrides(
        {'joint_names': ['joint1', 'joint2', 'joint3'], 'method': '434',
         'max_jerk': [0.0, 0.0, 0.0]}))
    assert result.successful
    status, _ = system.request(waypoint_message(pe.JOINT_NAMES, W))
    assert status_values(status)['method'] == '434'
    assert status_values(status)['limit_jerk'] == 'inf, inf, inf'


def test_params_file_is_loaded(system):
    assert list(system.planner.get_parameter('max_jerk').value) == [JERK_LIMIT] * 3
    assert list(system.arm.get_parameter('link_lengths').value) == [1.1, 0.9]
    assert list(system.arm.get_parameter('torque_limits').value) == [1000.0, 400.0, 30.0]


def test_invalid_arm_parameters_are_rejected(system):
    for values, reason in [({'publish_rate': 0.0}, 'publish_rate'),
                           ({'publish_rate': 2.2e-311}, 'publish_rate'),  # found by fuzzing
                           ({'link_lengths': [1.0, -0.5]}, 'link_lengths'),
                           ({'joint_names': ['a', 'b']}, '3 non-empty names')]:
        result = system.arm.set_parameters(overrides(values))[0]
        assert not result.successful and reason in result.reason
    # The arm keeps publishing after the rejected updates.
    n = len(system.joint_states)
    assert system.spin_until(lambda: len(system.joint_states) > n + 2, 5.0)


def raw_trajectory(names, times, positions):
    msg = JointTrajectory()
    msg.joint_names = list(names)
    for t, q in zip(times, positions):
        point = JointTrajectoryPoint(positions=[float(v) for v in q])
        point.time_from_start.sec = int(t)
        point.time_from_start.nanosec = int(round((t - int(t)) * 1e9))
        msg.points.append(point)
    return msg


def with_point_fields(effort=None, accelerations=None, nanosec=None):
    """Return a one-point trajectory to W[1] with fields the arm would ignore or misread."""
    msg = raw_trajectory(pe.JOINT_NAMES, [0.5], [W[1]])
    point = msg.points[0]
    if effort is not None:
        point.effort = effort
    if accelerations is not None:
        point.accelerations = accelerations
    if nanosec is not None:
        point.time_from_start.sec, point.time_from_start.nanosec = 0, nanosec
    return msg


def test_arm_rejects_bad_trajectories_and_keeps_its_state(system):
    system.spin_until(lambda: len(system.joint_states) >= 2, 5.0)
    held = np.array(system.joint_states[-1].position)
    bad = [
        (raw_trajectory(['joint1', 'jointX', 'joint3'], [1.0], [W[1]]), 'unknown joints'),
        (raw_trajectory(pe.JOINT_NAMES, [0.5, 0.5], [W[1], W[2]]), 'increase strictly'),
        (raw_trajectory(pe.JOINT_NAMES, [0.5, 0.2], [W[1], W[2]]), 'increase strictly'),
        (raw_trajectory(pe.JOINT_NAMES, [], []), 'no points'),
        (raw_trajectory(pe.JOINT_NAMES, [0.5], [[np.nan, 0.0, 0.0]]), 'non-finite'),
        (with_point_fields(effort=[1.0, 2.0, 3.0]), 'has efforts'),
        (with_point_fields(accelerations=[0.0, 0.0, 0.0]), 'accelerations without velocities'),
        (with_point_fields(nanosec=1_999_999_999), 'is not below 1e9'),
        (raw_trajectory([f'j{k % 99_999}' for k in range(100_000)], [], []),
         'the message names 100000 joints; this node controls 3'),
    ]
    for msg, reason in bad:
        n = len(system.arm_status)
        system.trajectory_publisher.publish(msg)
        assert system.spin_until(lambda: len(system.arm_status) > n, 5.0)
        status = system.arm_status[n]
        assert status.level == DiagnosticStatus.ERROR and reason in status.message
        assert len(status.message) < 1000
        # Another robot's joints: the built-in arm says what simulates one (helper-74).
        assert ('set model_file' in status.message) == ('this node controls' in reason
                                                        or 'unknown joints' in reason)
    n = len(system.joint_states)
    system.spin_until(lambda: len(system.joint_states) > n + 3, 5.0)
    np.testing.assert_array_equal(system.joint_states[-1].position, held)
    # A good one afterwards moves the arm (a single point, reached in 0.2 s).
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, [0.2], [W[3]]))
    assert system.spin_until(
        lambda: np.allclose(system.joint_states[-1].position, W[3], atol=1e-12), 5.0)


def test_a_late_trajectory_goes_from_where_the_arm_is_to_its_first_point(system):
    """
    Stamped 0.5 s ago, its one point at 1 s: the arm moves there in what is left, no jump.

    As joint_trajectory_controller interpolates from the state it had when it
    first sampled the new trajectory (helper-61: the arm started it 0.5 s
    along a line from its stamp, half the way at once).
    """
    system.spin_until(lambda: len(system.joint_states) >= 2, 5.0)
    held = np.array(system.joint_states[-1].position)
    msg = raw_trajectory(pe.JOINT_NAMES, [1.0], [W[3]])
    sent = system.client.get_clock().now().nanoseconds
    stamp = sent - int(0.5e9)
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp, 10**9)
    system.trajectory_publisher.publish(msg)
    assert system.spin_until(
        lambda: np.allclose(system.joint_states[-1].position, W[3], atol=1e-12), 5.0)
    states = [m for m in system.joint_states if stamp_ns(m) >= sent - int(0.1e9)]
    times = 1e-9 * np.array([stamp_ns(m) for m in states])
    positions = np.array([m.position for m in states])
    # At most the straight line's speed from the arrival (within 0.1 s of sent) to
    # stamp + 1 s; a jump half the way in one 20 ms tick would be 25 times that.
    speed = np.max(np.abs(W[3] - held)) / (1e-9 * (stamp - sent) + 1.0 - 0.1)
    steps = np.max(np.abs(np.diff(positions, axis=0)), axis=1) / np.diff(times)
    assert np.max(steps) <= speed * (1 + 1e-6), (np.max(steps), speed)
    arrived = times[np.argmax(np.all(np.abs(positions - W[3]) <= 1e-12, axis=1))]
    assert arrived == pytest.approx(1e-9 * stamp + 1.0, abs=0.05)


def test_an_unexpected_error_in_the_arms_playback_drops_the_trajectory_not_the_node(
        system, monkeypatch):
    """An exception in the timer went out of the executor (a fuzzed state, a fresh clone)."""
    system.spin_until(lambda: len(system.joint_states) >= 2, 5.0)
    held = np.array(system.joint_states[-1].position)

    def broken(*args, **kwargs):
        raise ValueError('broken for the test')
    real = SampledTrajectory.with_start_state
    monkeypatch.setattr(SampledTrajectory, 'with_start_state', broken)
    n = len(system.arm_status)
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, [0.3], [W[3]]))
    assert system.spin_until(lambda: any('internal error' in m.message
                                         for m in system.arm_status[n:]), 5.0)
    error = next(m for m in system.arm_status[n:] if 'internal error' in m.message)
    assert error.level == DiagnosticStatus.ERROR and 'broken for the test' in error.message
    k = len(system.joint_states)
    assert system.spin_until(lambda: len(system.joint_states) > k + 3, 5.0)
    np.testing.assert_array_equal(system.joint_states[-1].position, held)
    monkeypatch.setattr(SampledTrajectory, 'with_start_state', real)
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, [0.2], [W[3]]))
    assert system.spin_until(
        lambda: np.allclose(system.joint_states[-1].position, W[3], atol=1e-12), 5.0)


def test_the_arm_counts_a_trajectorys_points_before_reading_them(monkeypatch):
    """More than MAX_TRAJECTORY_POINTS is refused at once: the size is what stops it."""
    msg = raw_trajectory(pe.JOINT_NAMES, [0.1, 0.2, 0.3], [W[1], W[2], W[3]])
    monkeypatch.setattr(ros_conversions, 'MAX_TRAJECTORY_POINTS', 2)
    with pytest.raises(ValueError, match='3 points: more than 2'):
        ros_conversions.sampled_trajectory_from_msg(msg, pe.JOINT_NAMES)
    monkeypatch.setattr(ros_conversions, 'MAX_TRAJECTORY_POINTS', 3)
    assert ros_conversions.sampled_trajectory_from_msg(msg, pe.JOINT_NAMES).times.size == 3


def counted_reads(monkeypatch):
    """Return the list of the sizes of the messages the nodes read from now on."""
    reads = []
    real_read = raw_messages.read

    def counted(data, msg_type):
        reads.append(len(data))
        return real_read(data, msg_type)
    monkeypatch.setattr(raw_messages, 'read', counted)
    return reads


def test_the_arm_refuses_a_trajectory_larger_than_any_accepted_before_reading_it(
        system, monkeypatch):
    """Bounded by its bytes: rclpy never builds the points (1 million took 13 s to read)."""
    monkeypatch.setattr(ros_conversions, 'MAX_TRAJECTORY_POINTS', 20)
    assert system.spin_until(lambda: system.joint_states, 5.0)
    reads = counted_reads(monkeypatch)
    times = 0.1 + 0.01 * np.arange(3000)    # beyond the bound of 20 points
    n = len(system.arm_status)
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, times, [W[3]] * 3000))
    assert system.spin_until(lambda: len(system.arm_status) > n, 5.0)
    refused = system.arm_status[n]
    assert refused.level == DiagnosticStatus.ERROR
    assert 'trajectory rejected unread: the message has' in refused.message, refused.message
    assert reads == []
    # The next one, within the bound, is read and played.
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, [0.2], [W[3]]))
    assert system.spin_until(
        lambda: np.allclose(system.joint_states[-1].position, W[3], atol=1e-12), 5.0)
    assert len(reads) == 1


def test_the_planner_refuses_a_request_larger_than_any_accepted_before_reading_it(
        system, monkeypatch):
    """
    Bounded on receipt (as for 64 joints) and by its own joints on the worker, then read.

    Both refusals are requests: counted, refused with their numbers; the next is served.
    """
    monkeypatch.setattr(planner_node, 'MAX_REQUEST_WAYPOINTS', 20)
    reads = counted_reads(monkeypatch)
    first = system.planner._request_count
    # Beyond what 20 points of the 3 joints take, within 20 points of 64 joints: refused by
    # the worker; beyond that too: refused on receipt.  Neither is read.
    for points in (1500, 5000):
        times = 0.1 * np.arange(1, points + 1)
        status, traj = system.request(waypoint_message(pe.JOINT_NAMES, np.tile(W[1], (points, 1)),
                                                       times=times))
        assert status.level == DiagnosticStatus.ERROR and traj is None
        assert 'rejected unread (waypoints): the message has' in status.message, status.message
    assert reads == []
    status, traj = system.request(waypoint_message(pe.JOINT_NAMES, W))
    assert_planned(status)
    assert status_values(status)['request'] == str(first + 3)


def test_a_large_trajectory_is_read_off_the_executor_and_taken_in_order(system, monkeypatch):
    """
    Read on the reader thread, and a small one sent after it waits its turn.

    The large one (made slow to read here) replaced by the small one: the arm
    ends where the small one goes, whichever was quicker to read.
    """
    assert system.spin_until(lambda: system.joint_states, 5.0)
    monkeypatch.setattr(arm_sim_node, 'READ_ON_EXECUTOR_BYTES', 5000)
    threads = []
    real_read = raw_messages.read

    def slow(data, msg_type):
        threads.append((len(data), threading.current_thread().name))
        if len(data) > 5000:
            time.sleep(0.3)
        return real_read(data, msg_type)
    monkeypatch.setattr(raw_messages, 'read', slow)
    n = len(system.arm_status)
    times = 0.5 + 0.01 * np.arange(300)
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, times, [W[2]] * 300))
    # (The topic keeps one message: the next is sent once the arm has this one.)
    assert system.spin_until(lambda: threads, 5.0)
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, [0.2], [W[4]]))
    assert system.spin_until(
        lambda: sum('trajectory accepted' in m.message for m in system.arm_status[n:]) == 2,
        5.0)
    accepted = [m.message for m in system.arm_status[n:] if 'trajectory accepted' in m.message]
    assert accepted[0].startswith('trajectory accepted: 300 points'), accepted
    assert accepted[1].startswith('trajectory accepted: 1 points'), accepted
    assert [name for _, name in threads] == ['trajectory reader'] * 2
    assert system.spin_until(
        lambda: np.allclose(system.joint_states[-1].position, W[4], atol=1e-12), 5.0)
    # With nothing pending, a small one is read on the executor again.
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, [0.2], [W[3]]))
    assert system.spin_until(
        lambda: np.allclose(system.joint_states[-1].position, W[3], atol=1e-12), 5.0)
    assert threads[-1][1] != 'trajectory reader'


def test_a_trajectory_read_across_a_parameter_change_is_refused(system, monkeypatch):
    """Received under the parameters before, it is not taken under others (helper-84)."""
    assert system.spin_until(lambda: system.joint_states, 5.0)
    monkeypatch.setattr(arm_sim_node, 'READ_ON_EXECUTOR_BYTES', 5000)
    started = []
    real_read = raw_messages.read

    def slow(data, msg_type):
        started.append(len(data))
        time.sleep(0.5)
        return real_read(data, msg_type)
    monkeypatch.setattr(raw_messages, 'read', slow)
    before = np.array(system.joint_states[-1].position)
    n = len(system.arm_status)
    times = 0.5 + 0.01 * np.arange(300)
    system.trajectory_publisher.publish(raw_trajectory(pe.JOINT_NAMES, times, [W[2]] * 300))
    assert system.spin_until(lambda: started, 5.0)
    assert system.arm.set_parameters(overrides({'publish_rate': 40.0}))[0].successful
    assert system.spin_until(lambda: len(system.arm_status) > n, 5.0)
    refused = system.arm_status[n]
    assert refused.level == DiagnosticStatus.ERROR
    assert 'the parameters changed while it was being read' in refused.message
    system.spin_for(0.6)
    np.testing.assert_array_equal(system.joint_states[-1].position, before)


def test_destroying_the_arm_drops_the_reads_not_begun():
    """Its reader stops after the read it is in, not after every queued one (helper-84)."""
    from splines445_ros.tools.in_process import LocalRos
    reads = []
    with LocalRos() as ros:
        arm = ArmSimNode(context=ros.context, parameter_overrides=overrides(
            {'simulation': 'kinematic', 'initial_positions': W[0].tolist()}))
        real_read = raw_messages.read
        gate = threading.Event()

        def held(data, msg_type):
            reads.append(len(data))
            gate.wait(5.0)
            return real_read(data, msg_type)
        try:
            raw_messages.read = held
            data = serialize_message(raw_trajectory(pe.JOINT_NAMES, [0.2], [W[1]]))
            for _ in range(5):
                arm._reads_pending += 1
                arm._reads.put((data, arm.effective.joint_names, arm._generation, None))
            while not reads:
                time.sleep(0.01)
            gate.set()
            arm.destroy_node()
        finally:
            raw_messages.read = real_read
        assert not arm._reader.is_alive()
        assert len(reads) == 1


def test_a_topic_request_away_from_the_arm_at_rest_is_played_with_a_warn(system):
    """As joint_trajectory_controller plays it, but said (helper-74: a UR5 swung 1.9 rad)."""
    assert system.spin_until(lambda: system.joint_states, 5.0)
    away = W.copy()
    away[0, 1] += 0.3
    status, traj = system.request(waypoint_message(pe.JOINT_NAMES, away[:3]))
    assert status.level == DiagnosticStatus.WARN, status.message
    assert traj is not None     # published all the same
    assert ("it starts 0.3 from the arm's position on joint_states (joint2), more than "
            'goal_position_tolerance (0.01): the arm jumps there') in status.message
    assert system.spin_until(lambda: np.allclose(system.joint_states[-1].position, away[2],
                                                 atol=1e-9), 10.0)
    # From where the arm is: no warning.
    status, traj = system.request(waypoint_message(pe.JOINT_NAMES, away[2::-1]))
    assert status.level == DiagnosticStatus.OK, status.message
    # Sent while that one runs, from its start: the arm is half way along it by then
    # (helper-75: not checked while a trajectory ran or waited).
    assert system.spin_until(
        lambda: np.max(np.abs(np.array(system.joint_states[-1].position) - away[2])) > 0.1,
        10.0)
    status, traj = system.request(waypoint_message(pe.JOINT_NAMES, away[2::-1]))
    assert status.level == DiagnosticStatus.WARN, status.message
    assert 'from where the trajectory it replaces has the arm then' in status.message


def test_a_topic_request_is_checked_against_the_arm_at_its_stamp(system, monkeypatch):
    """A slow message build moves the stamp, and the check with it (helper-77)."""
    assert system.spin_until(lambda: system.joint_states, 5.0)
    status, first = system.request(waypoint_message(pe.JOINT_NAMES, W))
    assert status.level == DiagnosticStatus.OK, status.message
    running = system.planner._active
    assert system.spin_until(  # running (a waiting one would be dropped for the next)
        lambda: system.client.get_clock().now().nanoseconds > running.start_ns + 2e8, 5.0)
    real = planner_node.trajectory_to_msg

    def slow(*args, **kwargs):
        time.sleep(0.3)
        return real(*args, **kwargs)
    monkeypatch.setattr(planner_node, 'trajectory_to_msg', slow)
    # Where the running trajectory has the arm start_delay from now: where a request
    # built at once would start, not one built 0.3 s later, when the arm is further on.
    delay = system.planner.parameters.config.start_delay
    at = 1e-9 * (system.client.get_clock().now().nanoseconds - running.start_ns) + delay
    assert at + 0.3 < running.traj.duration
    there = running.traj.evaluate([at], 0)[0]
    status, _ = system.request(waypoint_message(pe.JOINT_NAMES, [there, W[-1]]))
    assert status.level == DiagnosticStatus.WARN, status.message
    assert 'from where the trajectory it replaces has the arm then' in status.message
