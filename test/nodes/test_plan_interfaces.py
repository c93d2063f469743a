"""
planner_node's ~/plan service and ~/follow_waypoints action, both nodes in one process.

The arm is simulated kinematically, so its ``joint_states`` are the commanded
state: a stop or a preemption that jumped would show as a step larger than
the limits allow.  Expected values come from ``plan()`` called here with the
same limits, from the limits themselves, and from the planar arm's forward
kinematics written out in the test.
"""

import math
import os
import re
import threading
import time

from action_msgs.msg import GoalStatus
from action_msgs.srv import CancelGoal
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Pose
from node_status import assert_planned
import numpy as np
import pytest
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.time import Time
from sensor_msgs.msg import JointState
from splines445_interfaces.action import FollowWaypoints
from splines445_interfaces.srv import Plan
from splines445_ros.nodes import follow_waypoints, planner_node, topics
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.ros_conversions import duration_to_seconds, hold_message
from splines445_ros.planning import plan
from splines445_ros.service.interface_requests import MAX_REQUEST_WAYPOINTS
from splines445_ros.tools.in_process import (IN_PROCESS_START_DELAY, InProcessSystem, stamp_ns,
                                             waypoint_message)
from visualization_msgs.msg import Marker, MarkerArray

CONFIG = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'planar_arm.yaml')
NAMES = ('joint1', 'joint2', 'joint3')
V, A, J = 2.0, 10.0, 200.0  # config/planar_arm.yaml
LINKS = (1.1, 0.9)
W = np.array([[0.0, 0.0, 0.0], [0.5, 1.0, -0.5], [1.0, 0.5, 0.0]])
LONG = np.array([[0.0, 0.0, 0.0], [1.5, 2.0, -1.5], [3.0, 0.0, 1.5], [0.0, -1.0, 0.0]])
HUGE = np.array([[0.0, 0.0, 0.0], [1e300, 0.0, 0.0]])   # finite, but no plan: it overflows


@pytest.fixture
def system():
    # A lead time with room for the arm's delivery too: the trajectory is stamped to take
    # over at now + lead, and one that reaches the arm after that (planning and markers
    # on a loaded machine, in this one process) would switch late, with a step.
    parameters = {'kinematics': 'planar_3dof', 'replan_lead_time': 0.5}
    with InProcessSystem(planner_parameters=parameters, params_file=CONFIG,
                         arm_parameters={'simulation': 'kinematic',
                                         'initial_positions': [0.0, 0.0, 0.0]}) as s:
        s.markers = []
        s.client.create_subscription(MarkerArray, '/planner_node/planned_path',
                                     s.markers.append, topics.LATCHED)
        s.plan_client = s.client.create_client(Plan, '/planner_node/plan',
                                               qos_profile=topics.PLAN_QOS)
        s.action_client = ActionClient(s.client, FollowWaypoints,
                                       '/planner_node/follow_waypoints')
        assert s.spin_until(lambda: s.plan_client.service_is_ready()
                            and s.action_client.server_is_ready(), 10.0)
        yield s


def call(system, request, timeout=30.0):
    future = system.plan_client.call_async(request)
    assert system.spin_until(future.done, timeout)
    return future.result()


def plan_request(waypoints=W, names=NAMES, **overrides):
    request = Plan.Request()
    request.waypoints = waypoint_message(names, waypoints)
    for name, value in overrides.items():
        setattr(request.overrides, name, value)
    return request


def send_goal(system, waypoints, feedback=None, names=NAMES):
    goal = FollowWaypoints.Goal()
    goal.waypoints = waypoint_message(names, waypoints)
    sent = system.action_client.send_goal_async(
        goal, feedback_callback=None if feedback is None
        else (lambda m: feedback.append((system.client.get_clock().now().nanoseconds,
                                         m.feedback))))
    assert system.spin_until(sent.done, 10.0)
    return sent.result()


def result_of(system, handle, timeout=30.0):
    future = handle.get_result_async()
    assert system.spin_until(future.done, timeout)
    return future.result()


def reference(waypoints=W, method='445', timing='uniform'):
    return plan(waypoints, method, timing, max_velocity=[V] * 3, max_acceleration=[A] * 3,
                max_jerk=[J] * 3)


def planar_tool(q):
    """Return the planar arm's tool (x, y) at joint angles q, written out here."""
    d1, d2 = LINKS
    return (d1 * math.cos(q[0]) + d2 * math.cos(q[0] + q[1]),
            d1 * math.sin(q[0]) + d2 * math.sin(q[0] + q[1]))


def states_between(system, start_ns, end_ns=None):
    states = [s for s in system.joint_states
              if stamp_ns(s) >= start_ns and (end_ns is None or stamp_ns(s) <= end_ns)]
    times = 1e-9 * np.array([stamp_ns(s) for s in states])
    return times, np.array([s.position for s in states]), np.array([s.velocity for s in states])


def assert_no_jump(times, positions, velocities):
    """Between two joint_states the commanded state moves no more than the limits allow."""
    dt = np.diff(times)[:, None]
    assert np.max(np.abs(velocities)) <= V * (1 + 1e-6)
    dv = np.abs(np.diff(velocities, axis=0)) - A * dt
    dq = np.abs(np.diff(positions, axis=0)) - V * dt
    assert np.max(dv) <= 1e-6, (np.unravel_index(np.argmax(dv), dv.shape), dv.max())
    assert np.max(dq) <= 1e-6, (np.unravel_index(np.argmax(dq), dq.shape), dq.max())


def cancel_goal(system, handle):
    """
    Cancel the goal of ``handle``: its result, after the cancel is answered.

    Also returns the clock and the number of planner statuses just before
    the cancel, as (cancel_ns, n_status, result).
    """
    cancel_ns = system.client.get_clock().now().nanoseconds
    n_status = len(system.planner_status)
    cancel = handle.cancel_goal_async()
    assert system.spin_until(cancel.done, 5.0)
    return cancel_ns, n_status, result_of(system, handle)


def braked_to_rest(system, n_status, timeout=10.0):
    """
    Return when [s] the stop the planner reported after status ``n_status`` ends.

    Its switch time and braking duration come from its status; this waits
    until the arm has published states 0.3 s past that end.
    """
    assert system.spin_until(lambda: any(
        'stopping' in s.message for s in system.planner_status[n_status:]), timeout)
    status = next(s for s in system.planner_status[n_status:] if 'stopping' in s.message)
    braking = re.search(r'braking to rest in ([0-9.]+) s', status.message)
    assert braking is not None, status.message
    end = 1e-9 * int(status_values(status)['switch_time_ns']) + float(braking.group(1))
    assert system.spin_until(lambda: 1e-9 * stamp_ns(system.joint_states[-1]) > end + 0.3,
                             timeout)
    return end


def at(system, position, timeout=10.0):
    """Wait until the arm's latest joint_states are at ``position`` (1e-6); True if so."""
    return system.spin_until(lambda: np.allclose(system.joint_states[-1].position, position,
                                                 rtol=0.0, atol=1e-6), timeout)


def test_plan_service_answers_with_the_plan_and_does_not_move_the_arm(system):
    n_trajectories = len(system.trajectories)
    response = call(system, plan_request())
    expected = reference()
    assert response.success, response.message
    assert response.duration == pytest.approx(expected.duration, rel=1e-9)
    assert list(response.joint_names) == list(NAMES)
    peaks = expected.peaks()
    for field, key in (('peak_velocity', 'velocity'), ('peak_acceleration', 'acceleration'),
                       ('peak_jerk', 'jerk')):
        np.testing.assert_allclose(getattr(response, field), peaks[key], rtol=1e-9)
    assert max(response.peak_velocity) <= V and max(response.peak_jerk) <= J * (1 + 1e-9)
    assert response.binding_limit.split()[0] in NAMES
    values = {kv.key: kv.value for kv in response.values}
    assert float(values['duration']) == pytest.approx(expected.duration, rel=1e-8)
    assert values['interface'] == 'plan service'
    times = [duration_to_seconds(p.time_from_start) for p in response.trajectory.points]
    assert times[-1] == pytest.approx(expected.duration, abs=1e-9)
    np.testing.assert_allclose(response.trajectory.points[-1].positions, W[-1], atol=1e-12)
    # The same text as on ~/status, and nothing for the arm.
    assert any(s.message == response.message for s in system.planner_status)
    system.spin_for(0.3)
    assert len(system.trajectories) == n_trajectories


def test_overrides_hold_for_one_request_and_are_validated_like_parameters(system):
    default = call(system, plan_request())
    fast = call(system, plan_request(method='555', timing='optimal'))
    assert fast.success, fast.message
    expected = reference(W, '555', 'optimal')
    assert fast.duration == pytest.approx(expected.duration, rel=1e-6)
    assert fast.duration < default.duration
    optimal = call(system, plan_request(method='555', timing='optimal',
                                        speed_profile='time_optimal'))
    assert optimal.success, optimal.message
    expected = plan(W, '555', 'optimal', speed_profile='time_optimal', max_velocity=[V] * 3,
                    max_acceleration=[A] * 3, max_jerk=[J] * 3)
    assert optimal.duration == pytest.approx(expected.duration, rel=1e-6)
    assert optimal.duration < fast.duration
    assert system.planner.get_parameter('speed_profile').value == 'smoothed'
    ignored = call(system, plan_request(speed_profile='time_optimal'))
    assert not ignored.success and 'needs method "555"' in ignored.message
    slow = call(system, plan_request(max_velocity=[0.5, 0.5, 0.5]))
    assert slow.success and max(slow.peak_velocity) <= 0.5 * (1 + 1e-9)
    assert slow.duration > default.duration
    assert system.planner.get_parameter('method').value == '445'
    assert system.planner.get_parameter('timing').value == 'uniform'
    bad = call(system, plan_request(method='xyz'))
    refused = system.set_planner_parameters({'method': 'xyz'})[0]
    assert not bad.success and not refused.successful
    reason = refused.reason.split('rejected: ', 1)[1]
    assert reason in bad.message
    assert call(system, plan_request()).duration == default.duration
    # A tool limit has no tool path to hold on joint waypoints: refused, not ignored.
    for name in ('max_tool_speed', 'max_tool_angular_speed', 'max_tool_acceleration',
                 'max_path_deviation'):
        tool = call(system, plan_request(method='555', timing='optimal', **{name: [0.01]}))
        assert not tool.success, name
        assert f'overrides.{name} applies to tool_waypoints requests only' in tool.message
        # 0 is "no limit": nothing to ignore.
        assert call(system, plan_request(**{name: [0.0]})).duration == default.duration
    # With kinematics "model" and joint_names unset the parameters cannot count the
    # joints: the goal checks per-joint overrides against the planned ones itself.
    with pytest.raises(ValueError, match=r'max_velocity has 1 values: it needs one per '
                                         r"planned joint \(2: \['a', 'b'\]\)"):
        follow_waypoints._check_per_joint({'max_velocity': (1.0,)}, ('a', 'b'))
    follow_waypoints._check_per_joint({'max_velocity': (1.0, 2.0), 'method': '555'}, ('a', 'b'))


def test_bad_service_requests_get_an_error_response(system):
    response = call(system, Plan.Request())
    assert not response.success and 'both are empty' in response.message
    both = plan_request()
    both.tool_waypoints.poses = [Pose(), Pose()]
    response = call(system, both)
    assert not response.success and 'not both' in response.message
    unknown = call(system, plan_request(names=('joint1', 'joint2', 'wrist')))
    assert not unknown.success and "'wrist'" in unknown.message
    nan = W.copy()
    nan[1, 1] = math.nan
    response = call(system, plan_request(nan))
    assert not response.success and response.message
    # Too many waypoints: refused before they are planned, and the topic likewise.
    many = np.cumsum(np.full((MAX_REQUEST_WAYPOINTS + 1, 3), 1e-3), axis=0)
    response = call(system, plan_request(many))
    assert not response.success
    assert f'more than the {MAX_REQUEST_WAYPOINTS} a request may carry' in response.message
    n = len(system.planner_status)
    system.waypoint_publisher.publish(waypoint_message(NAMES, many))
    assert system.spin_until(lambda: len(system.planner_status) > n, 10.0)
    assert any('a request may carry' in s.message for s in system.planner_status[n:])
    assert call(system, plan_request()).success


def test_a_hundred_concurrent_calls_are_all_answered(system):
    requests = [plan_request() if k % 3 else plan_request(names=('a', 'b', 'c'))
                for k in range(100)]
    futures = [system.plan_client.call_async(r) for r in requests]
    assert system.spin_until(lambda: all(f.done() for f in futures), 120.0)
    results = [f.result() for f in futures]
    assert [r.success for r in results] == [bool(k % 3) for k in range(100)]
    assert len({r.duration for r in results if r.success}) == 1
    assert call(system, plan_request()).success


def test_a_request_after_a_cancels_waiting_hold_is_planned_from_the_running_goal(system):
    """The arm runs the cancelled goal until the request's stamp; its hold is dropped."""
    handle = send_goal(system, W)
    assert handle.accepted
    assert system.spin_until(system.planner.trajectory_running, 5.0)
    running = system.planner._active
    end_ns = running.start_ns + int(running.traj.duration * 1e9)
    assert system.spin_until(lambda: system.client.get_clock().now().nanoseconds
                             >= end_ns - int(0.3e9), 30.0)
    cancel_ns = system.client.get_clock().now().nanoseconds
    n_status = len(system.planner_status)
    cancel = handle.cancel_goal_async()
    assert system.spin_until(cancel.done, 5.0)
    # The hold of its end published, stamped replan_lead_time on: it waits.
    assert system.spin_until(lambda: any('holding its end' in s.message
                                         for s in system.planner_status[n_status:]), 5.0)
    assert system.planner.active_trajectory() is None
    # From the goal's end, where the arm is when this starts (0.4 s on): before, it was
    # compared with joint_states taken while the arm still moved, a false WARN of
    # 0.37 rad (and a request from there jumped unwarned; helper-77).
    status, _ = system.request(waypoint_message(NAMES, W[::-1]))
    assert status.level == DiagnosticStatus.OK, status.message
    assert at(system, W[0], 10.0)
    assert_no_jump(*states_between(system, cancel_ns - int(0.2e9)))


def test_a_goal_planned_while_a_cancels_hold_takes_over_is_planned_again(system, monkeypatch):
    """
    A goal sent while a cancel's hold waits for its stamp, its planning outlasting the stamp.

    It is planned from the cancelled goal's trajectory, which the hold then
    replaces: it is planned again (from the arm holding), and succeeds (it
    was refused "the running trajectory continues", nothing running;
    helper-79, helper-87).
    """
    first = send_goal(system, W)
    assert first.accepted
    assert system.spin_until(system.planner.trajectory_running, 5.0)
    running = system.planner._active
    assert system.spin_until(lambda: system.client.get_clock().now().nanoseconds
                             >= running.end_ns - int(0.3e9), 30.0)
    n_status = len(system.planner_status)
    cancel = first.cancel_goal_async()
    assert system.spin_until(cancel.done, 5.0)
    assert system.spin_until(lambda: any('holding its end' in s.message
                                         for s in system.planner_status[n_status:]), 5.0)
    node = system.planner
    assert node.active_trajectory() is None and node._hold_ns is not None
    original, calls = node._replan, []

    def held(*args):    # the first planning lasts until the hold has taken over
        calls.append(args[-1])
        if len(calls) == 1:
            time.sleep(max(0.0, 1e-9 * (node._hold_ns - node.get_clock().now().nanoseconds))
                       + 0.1)
        return original(*args)
    monkeypatch.setattr(node, '_replan', held)
    start_ns = system.client.get_clock().now().nanoseconds
    second = send_goal(system, W[::-1])
    assert second.accepted
    result = result_of(system, second)
    assert result.status == GoalStatus.STATUS_SUCCEEDED, result.result.message
    assert calls[0] is not None         # first from the cancelled goal's trajectory
    assert result_of(system, first).status == GoalStatus.STATUS_CANCELED
    assert_no_jump(*states_between(system, start_ns - int(0.2e9)))


def test_a_goal_reports_feedback_and_succeeds_once_the_arm_has_settled(system):
    feedback = []
    handle = send_goal(system, W, feedback)
    assert handle.accepted
    result = result_of(system, handle)
    expected = reference()
    assert result.status == GoalStatus.STATUS_SUCCEEDED, result.result.message
    assert result.result.success
    assert result.result.duration == pytest.approx(expected.duration, rel=1e-9)
    assert np.max(np.abs(result.result.final_error)) <= 0.01
    assert len(feedback) >= 10
    elapsed = [duration_to_seconds(f.time_from_start) for _, f in feedback]
    left = [duration_to_seconds(f.time_left) for _, f in feedback]
    assert all(b >= a for a, b in zip(elapsed, elapsed[1:]))
    assert all(b <= a for a, b in zip(left, left[1:])) and left[-1] == 0.0
    for (_, f), t, rest in zip(feedback, elapsed, left):
        assert list(f.joint_names) == list(NAMES)
        if t < expected.duration:
            assert t + rest == pytest.approx(expected.duration, abs=1e-6)
    # Kinematic arm: it is where the plan says at the joint_states' stamp, which the
    # feedback compares (the arm plays the published 10 ms samples: 4e-5 rad here; against
    # the plan now, the latest joint_states lagged up to a period of motion: median 0.01 rad,
    # helper-76).
    errors = [f.max_tracking_error for _, f in feedback if not math.isnan(f.max_tracking_error)]
    assert errors and np.median(errors) <= 1e-3 and max(errors) <= V * 0.5, errors
    assert at(system, W[-1])  # settled within the goal tolerance: then at the very end


def test_feedback_compares_an_arm_whose_clock_runs_ahead_at_its_stamps(system, monkeypatch):
    """An arm 25 ms ahead (NTP skew) plays on its own clock: its stamps are when to compare."""
    arm_now = system.arm._now_ns
    monkeypatch.setattr(system.arm, '_now_ns', lambda: arm_now() + 25_000_000)
    feedback = []
    handle = send_goal(system, W, feedback)
    assert handle.accepted
    assert result_of(system, handle).status == GoalStatus.STATUS_SUCCEEDED
    errors = [f.max_tracking_error for _, f in feedback if not math.isnan(f.max_tracking_error)]
    # Stamps from the future were compared with the plan now: median 0.018 rad (helper-77).
    assert errors and np.median(errors) <= 1e-3, errors


def test_feedback_shows_the_error_grow_when_joint_states_stop(system, monkeypatch):
    """Stale states are compared with the plan now: at their stamp it read 0 (helper-79)."""
    feedback = []
    handle = send_goal(system, LONG, feedback)
    assert handle.accepted
    assert system.spin_until(lambda: len(feedback) > 10, 10.0)
    monkeypatch.setattr(system.arm.joint_state_publisher, 'publish', lambda msg: None)
    n = len(feedback)
    system.spin_for(1.5)
    late = [f.max_tracking_error for _, f in feedback[n:]]
    assert late and max(late) > 0.1, late


def test_a_cancel_and_a_topic_request_end_the_goal_canceled_in_either_order(system):
    """Replaced before its stop, or its stop replaced: CANCELED, as asked (helper-79)."""
    assert system.spin_until(lambda: system.joint_states, 5.0)
    for wait_for_stop in (False, True):
        start = np.array(system.joint_states[-1].position)
        handle = send_goal(system, np.vstack([start, LONG[1:]]))
        assert handle.accepted
        assert system.spin_until(system.planner.trajectory_running, 5.0)
        system.spin_for(0.5)
        n_status = len(system.planner_status)
        cancel = handle.cancel_goal_async()
        assert system.spin_until(cancel.done, 5.0)
        if wait_for_stop:   # the topic request replaces the braking stop
            assert system.spin_until(lambda: any('braking' in s.message for s in
                                                 system.planner_status[n_status:]), 5.0)
        here = np.array(system.joint_states[-1].position)
        system.waypoint_publisher.publish(waypoint_message(NAMES, [here, here + 0.05]))
        sent_ns = system.client.get_clock().now().nanoseconds
        result = result_of(system, handle)
        assert result.status == GoalStatus.STATUS_CANCELED, result.result.message
        assert 'did not settle' not in result.result.message, result.result.message
        # At once, not goal_time_tolerance (2 s) after the stop's end.
        assert system.client.get_clock().now().nanoseconds - sent_ns < 1.5e9
        system.spin_for(1.5)


def test_cancel_stops_the_arm_within_its_limits(system):
    handle = send_goal(system, LONG)
    assert handle.accepted
    duration = reference(LONG).duration
    system.spin_for(0.4 * duration)
    cancel_ns, n_status, result = cancel_goal(system, handle)
    assert result.status == GoalStatus.STATUS_CANCELED, result.result.message
    stopped = braked_to_rest(system, n_status)
    times, positions, velocities = states_between(system, cancel_ns - int(0.2e9))
    assert times.size > 20
    assert_no_jump(times, positions, velocities)
    # It came to rest where its stop ends, long before the plan's end, and stays there.
    assert stopped - 1e-9 * cancel_ns < 0.5 * duration
    assert np.all(np.abs(velocities[times > stopped]) == 0.0) and np.any(times > stopped)
    assert 1e-9 * (stamp_ns(system.joint_states[-1])) - 1e-9 * cancel_ns < duration
    assert np.max(np.abs(positions[-1] - LONG[-1])) > 0.1
    moving = np.max(np.abs(velocities[times < 1e-9 * cancel_ns]))
    assert moving > 0.5  # it was moving when cancelled
    # The stop's message lasts 1 s at least, at rest at its end: delivered later than
    # its braking (here 0.6 s after its stamp), the arm still takes it, as it would a
    # stop of a few tens of milliseconds, not reject it and go on with the goal.
    stop = system.trajectories[-1]
    assert duration_to_seconds(stop.points[-1].time_from_start) >= 1.0
    braking = stopped - 1e-9 * stamp_ns(stop)
    assert 0.0 < braking < 0.6
    stop.header.stamp = Time(nanoseconds=system.client.get_clock().now().nanoseconds
                             - int(0.6e9)).to_msg()
    n = len(system.arm_status)
    system.trajectory_publisher.publish(stop)
    assert float(accepted_status(system, n)['started_late_by']) >= 0.6
    assert at(system, stop.points[-1].positions)


def test_a_cancel_whose_arm_does_not_settle_says_so(system, monkeypatch):
    """Canceled, as asked, but with a WARN and the error: the arm did not stop as planned."""
    assert system.set_planner_parameters({'goal_time_tolerance': 0.2})[0].successful
    handle = send_goal(system, LONG)
    assert handle.accepted
    system.spin_for(1.0)
    monkeypatch.setattr(follow_waypoints, '_settled', lambda *args: False)
    _, n_status, result = cancel_goal(system, handle)
    assert result.status == GoalStatus.STATUS_CANCELED, result.result.message
    assert 'did not settle within goal_time_tolerance (0.2 s)' in result.result.message
    ended = [s for s in system.planner_status[n_status:] if 'goal: canceled' in s.message]
    assert len(ended) == 1 and ended[0].level == DiagnosticStatus.WARN, ended


def test_a_cancel_in_the_last_moments_of_a_goal_is_a_cancel(system, monkeypatch):
    """
    A goal cancelled when it ends at rest sooner than a stop could take over ends CANCELED.

    Building the hold of its end is made slower than what is left of the
    goal: before, that was "planning took longer than replan_lead_time" and
    the goal ended "cancel failed", though the arm stops at its end anyway.
    """
    n_trajectories = len(system.trajectories)
    handle = send_goal(system, W)
    assert handle.accepted
    assert system.spin_until(lambda: len(system.trajectories) > n_trajectories, 5.0)
    end_ns = stamp_ns(system.trajectories[-1]) + int(reference(W).duration * 1e9)
    # 0.15 s before its end: within the lead time (0.5 s) of it.
    assert system.spin_until(lambda: system.client.get_clock().now().nanoseconds
                             >= end_ns - int(0.15e9), 30.0)
    real = planner_node.hold_message

    def slow(*args, **kwargs):
        time.sleep(0.3)
        return real(*args, **kwargs)
    monkeypatch.setattr(planner_node, 'hold_message', slow)
    cancel_ns, n_status, result = cancel_goal(system, handle)
    assert cancel_ns < end_ns
    assert result.status == GoalStatus.STATUS_CANCELED, result.result.message
    assert 'ends at rest' in result.result.message, result.result.message
    assert at(system, W[-1])
    times, positions, velocities = states_between(system, cancel_ns - int(0.2e9))
    assert_no_jump(times, positions, velocities)


def test_a_goal_that_does_not_settle_names_a_clock_the_arm_does_not_share(system):
    """With use_sim_time on one node only the abort said only "did not settle" (helper-68)."""
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    assert abs(system.planner.joint_state_clock_gap(NAMES)) < 1.0     # one clock here
    config = system.planner.parameters.config
    measured = (np.zeros(3), np.zeros(3))
    for gap, named in ((0.5, False), (-1.8e9, True), (40.0, True)):
        text = follow_waypoints._not_settled(measured, np.ones(3), config, gap)
        assert 'did not settle' in text
        assert ('do both nodes use the same clock (use_sim_time)?' in text) == named, text


def test_cancel_stops_the_arm_after_joint_names_changed_mid_goal(system):
    """The stop names the running trajectory's joints, not the new ones (helper-36)."""
    handle = send_goal(system, LONG)
    assert handle.accepted
    system.spin_for(1.0)
    result = system.planner.set_parameters([Parameter('joint_names', value=['a', 'b', 'c'])])
    assert result[0].successful, result[0].reason
    cancel_ns, n_status, result = cancel_goal(system, handle)
    assert result.status == GoalStatus.STATUS_CANCELED
    stopped = braked_to_rest(system, n_status)
    times, _, velocities = states_between(system, cancel_ns)
    assert np.all(velocities[times > stopped] == 0.0) and np.any(times > stopped)
    assert not any('unknown joints' in s.message for s in system.arm_status)


def test_a_new_goal_preempts_the_running_one_without_a_jump(system):
    first = send_goal(system, LONG)
    assert first.accepted
    system.spin_for(1.0)
    switch_ns = system.client.get_clock().now().nanoseconds
    second = send_goal(system, np.array([[0.0, 0.0, 0.0], [-0.5, 0.5, 0.2]]))
    assert second.accepted
    first_result = result_of(system, first)
    assert first_result.status == GoalStatus.STATUS_ABORTED
    assert 'preempted' in first_result.result.message
    second_result = result_of(system, second)
    assert second_result.status == GoalStatus.STATUS_SUCCEEDED, second_result.result.message
    assert at(system, [-0.5, 0.5, 0.2])  # settled within the goal tolerance: then at the end
    times, positions, velocities = states_between(system, switch_ns - int(0.2e9))
    assert_no_jump(times, positions, velocities)


def test_a_goal_after_joint_names_were_reordered_preempts_without_a_jump(system):
    """The running goal's state, in the new joint order, is the new goal's start (helper-62)."""
    first = send_goal(system, LONG)
    assert first.accepted
    system.spin_for(1.0)
    reordered = NAMES[::-1]
    result = system.planner.set_parameters([Parameter('joint_names', value=list(reordered))])
    assert result[0].successful, result[0].reason
    switch_ns = system.client.get_clock().now().nanoseconds
    second = send_goal(system, np.array([[0.0, 0.0, 0.0], [0.2, 0.5, -0.5]]), names=reordered)
    assert second.accepted
    assert result_of(system, first).status == GoalStatus.STATUS_ABORTED
    second_result = result_of(system, second)
    assert second_result.status == GoalStatus.STATUS_SUCCEEDED, second_result.result.message
    assert at(system, [-0.5, 0.5, 0.2])     # joint_states name the arm's own order
    times, positions, velocities = states_between(system, switch_ns - int(0.2e9))
    assert_no_jump(times, positions, velocities)


def test_a_goal_preempting_a_topic_trajectory_switches_without_a_jump(system):
    """A topic trajectory is stamped too: the planner and the arm agree on its start."""
    sent = system.client.get_clock().now().nanoseconds
    status, first = system.request(waypoint_message(NAMES, LONG))
    assert_planned(status)
    received = system.client.get_clock().now().nanoseconds
    delay = int(IN_PROCESS_START_DELAY * 1e9)
    assert sent + delay <= stamp_ns(first) <= received + delay  # not 0
    system.spin_for(1.0)
    switch_ns = system.client.get_clock().now().nanoseconds
    goal = send_goal(system, np.array([[0.0, 0.0, 0.0], [-0.5, 0.5, 0.2]]))
    assert goal.accepted
    assert result_of(system, goal).status == GoalStatus.STATUS_SUCCEEDED
    times, positions, velocities = states_between(system, switch_ns - int(0.2e9))
    assert_no_jump(times, positions, velocities)


def accepted_status(system, n):
    """Return the values of the arm's 'trajectory accepted' status after status ``n``."""
    assert system.spin_until(lambda: any(
        'accepted' in s.message for s in system.arm_status[n:]), 10.0)
    return status_values(next(s for s in system.arm_status[n:] if 'accepted' in s.message))


def test_a_trajectory_starts_start_delay_after_it_is_published(system):
    """Its stamp is publication + start_delay, where the arm starts it; 0: on receipt."""
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    for delay, waypoints in ((0.7, W), (0.0, W[::-1])):
        assert system.set_planner_parameters({'start_delay': delay})[0].successful
        n = len(system.arm_status)
        sent = system.client.get_clock().now().nanoseconds
        status, msg = system.request(waypoint_message(NAMES, waypoints))
        received = system.client.get_clock().now().nanoseconds
        assert_planned(status)
        values = accepted_status(system, n)
        assert 'started_late_by' not in values
        if delay:
            assert sent + delay * 1e9 <= stamp_ns(msg) <= received + delay * 1e9
            assert int(values['start_ns']) == stamp_ns(msg)
            # At rest where it starts until its stamp.
            assert system.spin_until(lambda: stamp_ns(system.joint_states[-1]) > stamp_ns(msg),
                                     5.0)
            times, positions, velocities = states_between(system, sent, stamp_ns(msg))
            assert times.size > 10
            np.testing.assert_array_equal(positions, np.tile(waypoints[0], (times.size, 1)))
            np.testing.assert_array_equal(velocities, 0.0)
        else:
            assert stamp_ns(msg) == 0
            assert sent <= int(values['start_ns']) <= system.client.get_clock().now().nanoseconds
        assert system.spin_until(lambda: np.allclose(
            system.joint_states[-1].position, waypoints[-1], rtol=0, atol=1e-9), 10.0)


def test_a_slowly_built_message_is_still_stamped_ahead_of_its_arrival(system, monkeypatch):
    """The stamp is read once the message is built: building it takes no delivery time."""
    real = planner_node.trajectory_to_msg

    def slow(*args, **kwargs):
        time.sleep(1.0)     # a 933-point message took 0.28 s in CI, stamped 0.05 s ahead
        return real(*args, **kwargs)
    monkeypatch.setattr(planner_node, 'trajectory_to_msg', slow)
    assert system.set_planner_parameters({'start_delay': 0.4})[0].successful
    n = len(system.arm_status)
    status, msg = system.request(waypoint_message(NAMES, W))
    assert_planned(status)
    values = accepted_status(system, n)
    assert 'started_late_by' not in values, values
    assert int(values['start_ns']) == stamp_ns(msg)


def test_a_trajectory_that_arrives_after_its_stamp_starts_part_way_and_says_so(system):
    """The arm cannot go back in time: it starts that far along, with a WARN and the lag."""
    for ahead in (1.0, -0.3):
        n = len(system.arm_status)
        now = system.client.get_clock().now().nanoseconds
        stamp = Time(nanoseconds=now + int(ahead * 1e9)).to_msg()
        system.trajectory_publisher.publish(hold_message([0.0, 0.0, 0.0], list(NAMES), 0.5,
                                                         stamp))
        values = accepted_status(system, n)
        assert int(values['start_ns']) == now + int(ahead * 1e9)
        accepted = next(s for s in system.arm_status[n:] if 'accepted' in s.message)
        if ahead > 0:
            assert 'started_late_by' not in values
            assert accepted.level == DiagnosticStatus.OK, accepted.message
        else:
            assert float(values['started_late_by']) >= -ahead
            assert float(values['started_late_by']) < -ahead + 5.0
            # On ~/status too, not only in the log (helper-61).
            assert accepted.level == DiagnosticStatus.WARN, accepted.message
            assert 'after its header.stamp' in accepted.message


def test_a_stops_hold_that_arrives_late_still_holds(system):
    """A hold lasts long enough not to end before it arrives: a late stop still stops."""
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    n = len(system.arm_status)
    now = system.client.get_clock().now().nanoseconds
    # As a stop's hold stamped at its switch, with sample_period 0.01 s, 0.3 s late.
    system.trajectory_publisher.publish(hold_message(
        [0.2, 0.0, 0.0], list(NAMES), 0.01, Time(nanoseconds=now - int(0.3e9)).to_msg()))
    values = accepted_status(system, n)
    assert float(values['started_late_by']) >= 0.3
    assert at(system, [0.2, 0.0, 0.0])


def test_a_trajectory_that_ended_before_it_arrived_is_rejected(system):
    """As joint_trajectory_controller does: a latched old one, or a clock not shared."""
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    n = len(system.arm_status)
    now = system.client.get_clock().now().nanoseconds
    stamp = Time(nanoseconds=now - 3 * 10**9).to_msg()
    old = hold_message([0.5, 0.5, 0.5], list(NAMES), 0.5, stamp)
    system.trajectory_publisher.publish(old)
    assert system.spin_until(lambda: len(system.arm_status) > n, 10.0)
    status = system.arm_status[n]
    assert status.level == DiagnosticStatus.ERROR, status.message
    assert 'use_sim_time' in status.message
    ended = re.search(r'it ended ([0-9.e+-]+) s ago \(header.stamp ([0-9.e+-]+) s', status.message)
    assert ended is not None, status.message
    assert 2.0 <= float(ended.group(1)) < 5.0  # a hold lasts 1 s (MIN_HOLD_DURATION)
    assert float(ended.group(2)) == pytest.approx((now - 3 * 10**9) * 1e-9, abs=1e-3)
    system.spin_for(0.3)
    np.testing.assert_array_equal(system.joint_states[-1].position, [0.0, 0.0, 0.0])


def test_cancel_stops_a_goal_faster_than_the_nodes_limits(system):
    """The stop keeps the goal's own limits: from 3.3 rad/s the node's 2 rad/s fail."""
    goal = FollowWaypoints.Goal()
    goal.waypoints = waypoint_message(NAMES, 4.0 * LONG)
    goal.overrides.max_velocity = [4.0] * 3
    goal.overrides.max_acceleration = [20.0] * 3
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0)
    handle = sent.result()
    assert handle.accepted
    assert system.spin_until(lambda: system.joint_states and np.max(
        np.abs(system.joint_states[-1].velocity)) > V * 1.2, 10.0)
    cancel_ns, n_status, result = cancel_goal(system, handle)
    assert result.status == GoalStatus.STATUS_CANCELED, result.result.message
    assert 'braking to rest' in result.result.message, result.result.message
    stopped = braked_to_rest(system, n_status)
    times, positions, velocities = states_between(system, cancel_ns)
    assert np.all(velocities[times > stopped] == 0.0) and np.any(times > stopped)
    dt = np.diff(times)[:, None]
    assert np.max(np.abs(np.diff(velocities, axis=0)) - 20.0 * dt) <= 1e-6


def test_a_request_in_the_last_lead_time_starts_where_the_running_one_ends(system):
    """The running trajectory ends before the switch: its end, not older joint_states."""
    assert system.set_planner_parameters({'start_from_current_state': True})[0].successful
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    goal = np.array([[0.0, 0.0, 0.0], [1.5, -1.0, 1.0]])
    status, first = system.request(waypoint_message(NAMES, goal))
    assert_planned(status)
    end_ns = stamp_ns(first) + int(duration_to_seconds(first.points[-1].time_from_start) * 1e9)
    assert system.spin_until(
        lambda: system.client.get_clock().now().nanoseconds >= end_ns - int(0.25e9), 20.0)
    assert np.max(np.abs(system.joint_states[-1].velocity)) > 0.1   # on its way still
    status, second = system.request(waypoint_message(NAMES, W))
    assert_planned(status)
    np.testing.assert_allclose(second.points[0].positions, goal[-1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(second.points[0].velocities, 0.0, rtol=0, atol=1e-12)
    system.spin_for(0.8 + duration_to_seconds(second.points[-1].time_from_start))
    assert_no_jump(*states_between(system, end_ns - int(0.5e9)))


def test_two_requests_closer_than_the_lead_time_switch_without_a_jump(system):
    """The first still waits for its stamp when the second comes: the arm never runs it."""
    assert system.set_planner_parameters({'start_from_current_state': True,
                                          'replan_lead_time': 1.5})[0].successful
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    start_ns = system.client.get_clock().now().nanoseconds
    status, first = system.request(waypoint_message(NAMES, LONG[:2]))
    assert_planned(status)
    system.spin_for(0.1)
    status, second = system.request(waypoint_message(NAMES, W[::-1]))
    assert_planned(status)
    assert stamp_ns(second) - stamp_ns(first) < 1.5e9
    # It starts where the arm is: at rest at its first position, as the first never ran.
    np.testing.assert_array_equal(second.points[0].positions, [0.0, 0.0, 0.0])
    assert at(system, W[0], 10.0 + duration_to_seconds(second.points[-1].time_from_start))
    system.spin_for(0.1)
    assert_no_jump(*states_between(system, start_ns))
    np.testing.assert_allclose(system.joint_states[-1].position, W[0], atol=1e-9)


def test_a_request_planned_while_the_waiting_one_starts_is_planned_again(system, monkeypatch):
    """Planned from the one before the waiting trajectory, which started meanwhile: again."""
    # A lead time of 2 s: the second request reaches the planner 1 s before the first
    # starts, and its planning ends 0.9 s before its own switch (room for delivery).
    assert system.set_planner_parameters({'start_from_current_state': True,
                                          'replan_lead_time': 2.0})[0].successful
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    status, first = system.request(waypoint_message(NAMES, LONG[:2]))
    assert_planned(status)
    real = planner_node.plan_request

    def slow(*args, **kwargs):  # planning outlasts the first's wait for its stamp
        time.sleep(max(0.0, 1e-9 * (stamp_ns(first) - time.time_ns()) + 0.1))
        return real(*args, **kwargs)
    monkeypatch.setattr(planner_node, 'plan_request', slow)
    start_ns = system.client.get_clock().now().nanoseconds
    system.spin_for(1.0)
    status, second = system.request(waypoint_message(NAMES, W[::-1]))
    # Planned again from the first, which runs: it takes over from it (it was refused,
    # "send the request again").
    assert_planned(status)
    assert stamp_ns(second) > stamp_ns(first)
    monkeypatch.setattr(planner_node, 'plan_request', real)
    assert at(system, W[0], 10.0 + duration_to_seconds(second.points[-1].time_from_start))
    system.spin_for(0.1)
    assert_no_jump(*states_between(system, start_ns))
    np.testing.assert_allclose(system.joint_states[-1].position, W[0], atol=1e-9)


def test_a_new_goal_that_fails_to_plan_leaves_the_running_one_running(system):
    """It is aborted; the running goal is not preempted, and a cancel still stops it."""
    first = send_goal(system, LONG)
    assert first.accepted
    system.spin_for(1.0)
    second = send_goal(system, HUGE)
    assert second.accepted
    failed = result_of(system, second)
    assert failed.status == GoalStatus.STATUS_ABORTED
    assert failed.result.message.startswith('request ')
    running = system.planner.active_trajectory()
    assert running is not None
    cancel = first.cancel_goal_async()
    assert system.spin_until(cancel.done, 5.0)
    assert cancel.result().return_code == CancelGoal.Response.ERROR_NONE
    result = result_of(system, first)
    assert result.status == GoalStatus.STATUS_CANCELED, result.result.message


def test_a_goal_after_one_that_fails_preempts_the_running_one(system):
    """A runs; B (fails to plan) and C sent back to back: A ends preempted by C (helper-72)."""
    first = send_goal(system, LONG)
    assert first.accepted
    system.spin_for(1.0)
    goals = []
    for waypoints in (HUGE, np.array([[0.0, 0.0, 0.0], [0.3, 0.2, 0.1]])):
        goal = FollowWaypoints.Goal()
        goal.waypoints = waypoint_message(NAMES, waypoints)
        goals.append(system.action_client.send_goal_async(goal))  # not spun in between
    assert system.spin_until(lambda: all(g.done() for g in goals), 10.0)
    failed, third = (g.result() for g in goals)
    assert failed.accepted and third.accepted
    assert result_of(system, failed).status == GoalStatus.STATUS_ABORTED
    result = result_of(system, first)
    assert result.status == GoalStatus.STATUS_ABORTED
    # It said "replaced (a request on the waypoints topic)": nothing was sent there.
    assert result.result.message == 'preempted by a newer goal', result.result.message
    assert result_of(system, third).status == GoalStatus.STATUS_SUCCEEDED


def test_a_goal_sent_while_a_cancel_brakes_ends_the_cancel_at_once(system):
    """The cancelled goal ends CANCELED when the new one takes over, not 2 s later (helper-72)."""
    first = send_goal(system, LONG)
    assert first.accepted
    system.spin_for(1.0)
    start_ns = system.client.get_clock().now().nanoseconds
    cancel = first.cancel_goal_async()
    assert system.spin_until(cancel.done, 5.0)
    system.spin_for(0.1)  # braking: its stop lasts a few tenths of a second
    second = send_goal(system, np.array([[0.0, 0.0, 0.0], [0.3, 0.2, 0.1]]))
    assert second.accepted
    result = result_of(system, first)
    ended_ns = system.client.get_clock().now().nanoseconds
    assert result.status == GoalStatus.STATUS_CANCELED
    # It waited for the stop's end, then compared the arm, by then following the new
    # goal, with it: "did not settle within goal_time_tolerance", 2.8 s after the cancel.
    assert 'a newer goal took over before the stop ended' in result.result.message
    assert 'did not settle' not in result.result.message
    assert ended_ns - start_ns < 1.5e9
    assert result_of(system, second).status == GoalStatus.STATUS_SUCCEEDED
    times, positions, velocities = states_between(system, start_ns - int(0.2e9))
    assert_no_jump(times, positions, velocities)


class HeldPlanning:
    """A planner's ``_serve`` (each job the worker plans) held until ``release`` is set."""

    def __init__(self, real):
        self.real, self.release, self.entered = real, threading.Event(), threading.Event()

    def __call__(self, *args, **kwargs):
        self.entered.set()
        assert self.release.wait(10.0)
        return self.real(*args, **kwargs)


def test_a_cancel_while_a_newer_goal_plans_does_not_brake_the_newer_one(system, monkeypatch):
    """B is cancelled while C plans: C takes over and B ends canceled (helper-73)."""
    first = send_goal(system, LONG)
    assert first.accepted
    system.spin_for(1.0)
    held = HeldPlanning(system.planner._serve)
    monkeypatch.setattr(system.planner, '_serve', held)
    end = np.array([0.3, 0.2, 0.1])
    newer = send_goal(system, np.array([[0.0, 0.0, 0.0], end]))
    assert newer.accepted and system.spin_until(held.entered.is_set, 5.0)
    cancel = first.cancel_goal_async()
    assert system.spin_until(cancel.done, 5.0)
    system.spin_for(0.3)    # ticks of the cancelled goal while the newer one plans
    held.release.set()
    result = result_of(system, first)
    assert result.status == GoalStatus.STATUS_CANCELED, result.result.message
    assert result.result.message == 'canceled: a newer goal took over'
    # A stop queued behind the newer plan was planned from it and braked it part-way,
    # and the newer goal ended 'replaced (a request on the waypoints topic)'.
    newer_result = result_of(system, newer)
    assert newer_result.status == GoalStatus.STATUS_SUCCEEDED, newer_result.result.message
    assert at(system, end)


def test_a_topic_request_planned_before_a_cancels_stop_is_not_stopped(system, monkeypatch):
    """A request served while the cancel waited for the worker replaces the goal: it runs."""
    handle = send_goal(system, LONG)
    assert handle.accepted
    assert system.spin_until(system.planner.trajectory_running, 5.0)
    system.spin_for(0.5)
    held = HeldPlanning(system.planner._serve)
    monkeypatch.setattr(system.planner, '_serve', held)
    n_traj = len(system.trajectories)
    system.waypoint_publisher.publish(waypoint_message(NAMES, LONG[:2]))
    assert system.spin_until(held.entered.is_set, 5.0)
    cancel = handle.cancel_goal_async()   # its stop is queued behind the request
    assert system.spin_until(cancel.done, 5.0)
    system.spin_for(0.2)
    held.release.set()
    result = result_of(system, handle)
    assert result.status == GoalStatus.STATUS_CANCELED, result.result.message
    assert 'a newer trajectory replaced' in result.result.message, result.result.message
    # Only the request's trajectory was published: the stop did not replace it (it did,
    # with a hold where it starts).
    system.spin_for(0.3)
    assert len(system.trajectories) == n_traj + 1
    assert at(system, LONG[1], 15.0)


def test_a_goal_that_fails_after_the_one_it_would_preempt_ended_leaves_none_running(
        system, monkeypatch):
    """A tool goal is then accepted: none was refused 'a trajectory is running' (helper-73)."""
    short = np.array([[0.0, 0.0, 0.0], [0.05, 0.05, 0.05]])
    first = send_goal(system, short)
    assert first.accepted and system.spin_until(system.planner.trajectory_running, 5.0)
    held = HeldPlanning(system.planner._serve)
    monkeypatch.setattr(system.planner, '_serve', held)
    failing = send_goal(system, HUGE)
    assert failing.accepted and system.spin_until(held.entered.is_set, 5.0)
    assert result_of(system, first).status == GoalStatus.STATUS_SUCCEEDED
    held.release.set()
    assert result_of(system, failing).status == GoalStatus.STATUS_ABORTED
    assert not system.planner.trajectory_running()
    q = np.array(system.joint_states[-1].position)
    goal = FollowWaypoints.Goal()
    goal.tool_waypoints.header.frame_id = 'base_link'
    for dx in (0.0, -0.05):
        pose = Pose()
        (pose.position.x, pose.position.y), yaw = planar_tool(q), float(np.sum(q))
        pose.position.x += dx
        pose.orientation.z, pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
        goal.tool_waypoints.poses.append(pose)
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0)
    assert sent.result().accepted, [s.message for s in system.planner_status[-2:]]
    assert result_of(system, sent.result()).status == GoalStatus.STATUS_SUCCEEDED


def test_a_tool_goal_is_refused_while_a_topic_trajectory_runs(system):
    """It plans from rest: accepted while the arm moved, it jumped 42 rad/s (helper-36)."""
    n = len(system.arm_status)
    system.waypoint_publisher.publish(waypoint_message(NAMES, LONG))
    assert system.spin_until(lambda: len(system.arm_status) > n, 10.0)
    goal = FollowWaypoints.Goal()
    goal.tool_waypoints.poses = [Pose(), Pose()]
    goal.tool_waypoints.poses[1].position.x = 0.5
    n_status = len(system.planner_status)
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0) and not sent.result().accepted
    assert system.spin_until(lambda: any('a trajectory is running' in s.message
                                         for s in system.planner_status[n_status:]), 5.0)


def test_a_tool_goal_whose_first_pose_is_away_from_the_arm_is_aborted(system):
    """As a joint goal's first waypoint (helper-66: a UR5 jumped 0.9 rad to a tool goal)."""
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    goal = FollowWaypoints.Goal()
    goal.tool_waypoints.poses = [Pose(), Pose()]
    for pose, (x, y) in zip(goal.tool_waypoints.poses, ((1.5, 0.3), (1.2, 0.6))):
        pose.position.x, pose.position.y = x, y
        pose.orientation.w = 1.0
    # The arm rests at (0, 0, 0): its tool at (2, 0), far from (1.5, 0.3).
    assert planar_tool([0.0, 0.0, 0.0]) == pytest.approx((2.0, 0.0))
    n = len(system.trajectories)
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0) and sent.result().accepted
    result = result_of(system, sent.result())
    assert result.status == GoalStatus.STATUS_ABORTED
    assert "the tool path's first pose solves to joints" in result.result.message
    assert 'the arm would jump' in result.result.message
    assert len(system.trajectories) == n      # nothing was sent to the arm


def test_a_time_optimal_goal_preempts_from_the_moving_state_without_a_jump(system):
    """A goal overriding speed_profile: the third-order profile starts from the moving state."""
    first = send_goal(system, LONG)
    assert first.accepted
    system.spin_for(1.0)
    switch_ns = system.client.get_clock().now().nanoseconds
    n_status = len(system.planner_status)
    goal = FollowWaypoints.Goal()
    end = [0.4, -0.3, 0.6]
    goal.waypoints = waypoint_message(NAMES, np.array([[0.0, 0.0, 0.0], end]))
    goal.overrides.method, goal.overrides.timing = '555', 'optimal'
    goal.overrides.speed_profile = 'time_optimal'
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0) and sent.result().accepted
    assert result_of(system, first).status == GoalStatus.STATUS_ABORTED
    second = result_of(system, sent.result())
    assert second.status == GoalStatus.STATUS_SUCCEEDED, second.result.message
    assert at(system, end)
    times, positions, velocities = states_between(system, switch_ns - int(0.2e9))
    assert_no_jump(times, positions, velocities)
    # Planned by the third-order profile itself (not its fallback), from the moving state.
    planned = [status_values(s) for s in system.planner_status[n_status:]]
    assert any(v.get('speed_profile') == 'time_optimal' for v in planned), planned
    assert not any('speed_profile_skipped' in v for v in planned)
    assert system.planner.get_parameter('speed_profile').value == 'smoothed'


def test_malformed_goals_are_rejected_with_the_reason(system):
    n_status = len(system.planner_status)
    goal = FollowWaypoints.Goal()
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0) and not sent.result().accepted
    assert not send_goal(system, W, names=('joint1', 'joint2', 'elbow')).accepted
    assert system.spin_until(lambda: sum(
        'both are empty' in s.message or "unknown joints ['elbow']" in s.message
        for s in system.planner_status[n_status:]) >= 2, 5.0)
    messages = [s.message for s in system.planner_status[n_status:]]
    assert any('both are empty' in m for m in messages)
    assert any("unknown joints ['elbow']" in m for m in messages)
    # A value that is not finite is refused with the goal, naming the waypoint.
    nan = W.copy()
    nan[2, 0] = math.nan
    assert not send_goal(system, nan).accepted
    assert system.spin_until(lambda: any('waypoint 2: positions[0] is nan' in s.message
                                         for s in system.planner_status[n_status:]), 5.0)
    # A tool goal's pose likewise (it was accepted, then aborted: helper-88).
    goal = FollowWaypoints.Goal()
    goal.tool_waypoints.header.frame_id = 'base_link'
    goal.tool_waypoints.poses = [Pose(), Pose()]
    goal.tool_waypoints.poses[1].position.y = math.inf
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0) and not sent.result().accepted
    assert system.spin_until(lambda: any(
        'goal rejected: tool waypoint 1 is not finite: position (0.0, inf, 0.0)' in s.message
        for s in system.planner_status[n_status:]), 5.0)
    # Overrides that a set_parameters would refuse, or that would be ignored, are refused
    # with the goal (helper-62: accepted, then aborted).
    for name, value, reason in (('method', 'xyz', 'method must be one of'),
                                ('max_velocity', [1.0], 'max_velocity'),
                                ('max_tool_speed', [0.1], 'applies to tool_waypoints')):
        goal = FollowWaypoints.Goal()
        goal.waypoints = waypoint_message(NAMES, W)
        setattr(goal.overrides, name, value)
        sent = system.action_client.send_goal_async(goal)
        assert system.spin_until(sent.done, 10.0) and not sent.result().accepted, name
        assert system.spin_until(lambda: any(
            'goal rejected' in s.message and reason in s.message
            for s in system.planner_status[n_status:]), 5.0), name
    # A goal whose plan fails is accepted, then aborted with the planner's error.
    handle = send_goal(system, HUGE)
    assert handle.accepted
    result = result_of(system, handle)
    assert result.status == GoalStatus.STATUS_ABORTED and not result.result.success
    assert result.result.message.startswith('request ')
    assert any(s.message == result.result.message for s in system.planner_status)


def test_a_goal_that_starts_away_from_the_arm_at_rest_is_aborted(system):
    """It would jump there (helper-36): MoveIt refuses such a start state too."""
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    handle = send_goal(system, W + 1.0)
    assert handle.accepted
    result = result_of(system, handle)
    assert result.status == GoalStatus.STATUS_ABORTED
    assert 'the first waypoint is 1 from' in result.result.message
    assert system.planner.active_trajectory() is None
    assert result_of(system, send_goal(system, W)).status == GoalStatus.STATUS_SUCCEEDED


def test_a_grippers_own_joint_states_do_not_hide_the_arms(system):
    """
    A second publisher on joint_states naming only its own joint, as a gripper's driver.

    The planner reads the latest message that names the planned joints:
    with only the latest message kept, the gripper's (at 500 Hz, the arm's
    at 50) hid the arm's, a goal's start check was skipped and the arm
    jumped 1 rad, and start_from_current_state failed 19 times in 20
    (helper-88).
    """
    gripper = system.client.create_publisher(JointState, topics.JOINT_STATES, topics.STATE_QOS)

    def publish_gripper():
        msg = JointState()
        msg.header.stamp = system.client.get_clock().now().to_msg()
        msg.name, msg.position, msg.velocity = ['gripper_finger'], [0.01], [0.0]
        gripper.publish(msg)
    system.client.create_timer(0.002, publish_gripper)

    def arm_states():
        return [s for s in system.joint_states if 'joint1' in s.name]
    assert system.spin_until(lambda: len(arm_states()) > 2
                             and len(system.joint_states) > len(arm_states()) + 50, 5.0)
    result = result_of(system, send_goal(system, W + 1.0))
    assert result.status == GoalStatus.STATUS_ABORTED
    assert 'the first waypoint is 1 from' in result.result.message
    assert system.planner.active_trajectory() is None
    system.planner.set_parameters([Parameter('start_from_current_state', value=True)])
    for _ in range(5):
        response = call(system, plan_request(W + 0.2))
        assert response.success, response.message
        # Planned from where the arm is (at rest at 0), not from the first waypoint.
        start = np.array(response.trajectory.points[0].positions)
        np.testing.assert_allclose(start, W[0], atol=1e-9)
        system.spin_for(0.02)
    # The goal's feedback has the arm's measured state throughout.
    feedback = []
    assert result_of(system, send_goal(system, W, feedback=feedback)).status == (
        GoalStatus.STATUS_SUCCEEDED)
    assert feedback and all(math.isfinite(f.max_tracking_error) for _, f in feedback)


def test_one_point_is_a_move_from_the_arm_where_the_plan_starts_there(system):
    """
    As joint_trajectory_controller plays a one-point trajectory from where the arm is.

    A goal of one point at rest, and a plan with start_from_current_state,
    start from the arm's state (refused, "need at least 2 waypoints":
    helper-88); a topic request of one point without it is refused saying so.
    """
    assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
    here = np.array(system.joint_states[-1].position)
    target = here + np.array([0.4, -0.3, 0.2])
    refused = call(system, plan_request(target[None, :]))
    assert not refused.success
    assert 'need at least 2 waypoints, got 1 (one is enough where the plan starts from ' \
        'the arm' in refused.message
    result = result_of(system, send_goal(system, target[None, :]))
    assert result.status == GoalStatus.STATUS_SUCCEEDED, result.result.message
    assert at(system, target)
    assert np.max(np.abs(result.result.final_error)) <= 0.01
    # Sent again, where the arm now is: nothing to move, said so (it said "all
    # waypoints coincide", helper-91).
    again = result_of(system, send_goal(system, target[None, :]))
    assert again.status == GoalStatus.STATUS_ABORTED
    assert 'the one waypoint is where the arm is' in again.result.message
    system.planner.set_parameters([Parameter('start_from_current_state', value=True)])
    response = call(system, plan_request(here[None, :]))
    assert response.success, response.message
    points = response.trajectory.points
    np.testing.assert_allclose(points[0].positions, target, atol=1e-9)
    np.testing.assert_allclose(points[-1].positions, here, atol=1e-9)


def test_a_client_that_goes_away_leaves_the_node_serving(system):
    other = system.add(Node('vanishing_client', context=system.context))
    client = ActionClient(other, FollowWaypoints, '/planner_node/follow_waypoints')
    assert system.spin_until(client.server_is_ready, 10.0)
    goal = FollowWaypoints.Goal()
    goal.waypoints = waypoint_message(NAMES, W)
    sent = client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0) and sent.result().accepted
    system.spin_for(0.3)
    client.destroy()
    system.executor.remove_node(other)
    other.destroy_node()
    system.spin_for(0.3)
    handle = send_goal(system, W[::-1])
    assert handle.accepted
    result = result_of(system, handle)
    assert result.status == GoalStatus.STATUS_SUCCEEDED, result.result.message
    assert at(system, W[0])  # settled within the goal tolerance: then at the very end


def test_markers_follow_every_plan(system):
    assert call(system, plan_request()).success
    assert system.spin_until(lambda: system.markers, 5.0)
    markers = system.markers[-1].markers
    assert markers[0].action == Marker.DELETEALL
    line = next(m for m in markers if m.type == Marker.LINE_STRIP)
    spheres = next(m for m in markers if m.type == Marker.SPHERE_LIST)
    assert line.header.frame_id == spheres.header.frame_id == 'base_link'
    # Stamped 0 (the latest transform): an RViz started later still draws them.
    assert all((m.header.stamp.sec, m.header.stamp.nanosec) == (0, 0) for m in markers)
    for point, q in ((line.points[0], W[0]), (line.points[-1], W[-1])):
        assert (point.x, point.y) == pytest.approx(planar_tool(q), abs=1e-9)
    assert [(p.x, p.y) for p in spheres.points] == [pytest.approx(planar_tool(q), abs=1e-9)
                                                    for q in W]
    # The path stays where the arm can reach: within d1 + d2 of the base.
    assert all(math.hypot(p.x, p.y) <= sum(LINKS) + 1e-9 for p in line.points)
    n = len(system.markers)
    assert call(system, plan_request(W[::-1])).success
    assert system.spin_until(lambda: len(system.markers) > n, 5.0)
    first = system.markers[-1].markers[1].points[0]
    assert (first.x, first.y) == pytest.approx(planar_tool(W[-1]), abs=1e-9)
    assert status_values(system.planner_status[-1])['request']
    # A plan with no tool to draw clears them, once: they stayed latched (helper-72).
    assert system.set_planner_parameters({'kinematics': ''})[0].successful
    for cleared in ([[Marker.DELETEALL]], []):
        n = len(system.markers)
        assert call(system, plan_request()).success
        system.spin_for(0.3)
        assert [[m.action for m in array.markers] for array in system.markers[n:]] == cleared


def test_a_stop_that_fails_unexpectedly_leaves_the_node_serving(system, monkeypatch):
    """An unexpected error while planning a stop is reported; the worker serves the next."""
    node = system.planner

    def broken(job):
        raise RuntimeError('broken stop')
    monkeypatch.setattr(node, '_serve_stop', broken)
    job = node.plan_job(None, {}, kind='stop', interface='test')
    outcomes = []
    job.done = outcomes.append
    node._stops.append(job)
    node._requests.put(planner_node._WAKE)    # the worker takes the stop first
    assert system.spin_until(lambda: outcomes, 10.0)
    assert not outcomes[0].ok
    assert 'internal error: RuntimeError: broken stop' in outcomes[0].message
    response = call(system, plan_request())
    assert response.success, response.message
