"""planner_node with kinematics: tool waypoints (PoseArray) in, a refined trajectory out."""

import math

from diagnostic_msgs.msg import DiagnosticStatus
from example_counts import examples
from geometry_msgs.msg import Pose, PoseArray
from hypothesis import given, settings, strategies as st
from node_status import assert_planned
import numpy as np
import pytest
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.ros_conversions import parse_tool_request, sampled_trajectory_from_msg
from splines445_ros.robot import paper_example as pe
from splines445_ros.tools.in_process import InProcessSystem, overrides, tool_waypoint_message
from urdf_reference import distance_to_polyline

D1, D2 = 1.1, 0.9
XY = pe.triangle_points()
TRIANGLE = np.column_stack([XY, np.zeros(len(XY))])
PLANNER = {'kinematics': 'planar_3dof', 'max_path_deviation': 1e-3, 'method': '434',
           'max_velocity': pe.MAX_VELOCITY.tolist(),
           'max_acceleration': pe.MAX_ACCELERATION.tolist(), 'max_jerk': [0.0, 0.0, 0.0]}
RESTORE = {'max_inserted_waypoints': 200, 'timing': 'uniform', 'start_from_current_state': False,
           'kinematics': 'planar_3dof', 'max_refinement_time': 30.0}


@pytest.fixture(scope='module')
def system():
    with InProcessSystem(planner_parameters=PLANNER) as s:
        yield s


def tool_of(q):
    q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2]
    return np.column_stack([D1 * np.cos(q1) + D2 * np.cos(q1 + q2),
                            D1 * np.sin(q1) + D2 * np.sin(q1 + q2), q1 + q2 + q3])


def test_a_tool_request_is_refined_end_to_end(system):
    n_arm_status = len(system.arm_status)
    status, msg = system.request(tool_waypoint_message(TRIANGLE))
    assert_planned(status)
    # The arm simulation accepted the refined trajectory.
    assert system.spin_until(lambda: len(system.arm_status) > n_arm_status, 10.0)
    accepted = system.arm_status[n_arm_status]
    assert accepted.level != DiagnosticStatus.ERROR, accepted.message
    assert 'trajectory accepted' in accepted.message
    values = status_values(status)
    assert values['tool_waypoints'] == '12'
    assert int(values['inserted_waypoints']) > 0
    assert float(values['max_path_deviation_reached']) <= 1e-3
    assert float(values['unrefined_max_path_deviation']) > 0.03
    assert int(values['waypoints']) == 12 + int(values['inserted_waypoints'])
    # The published trajectory, played back like joint_trajectory_controller at 0.2 ms.
    played = sampled_trajectory_from_msg(msg, pe.JOINT_NAMES)
    t = np.arange(0.0, played.times[-1], 2e-4)
    q = np.array([played.state_at(x)[0] for x in t])
    tool = tool_of(q)
    # Within 1 mm of the waypoints' polyline (plus the playback's interpolation error).
    assert distance_to_polyline(tool[:, :2], XY).max() <= 1e-3 + 1e-5
    np.testing.assert_allclose(tool[:, 2], 0.0, atol=1e-6)
    # Through every tool waypoint, from rest to rest.
    for p in XY:
        assert np.min(np.linalg.norm(tool[:, :2] - p, axis=1)) < 1e-3
    np.testing.assert_allclose(tool_of(np.array([msg.points[-1].positions]))[0, :2], XY[-1],
                               atol=1e-12)
    np.testing.assert_allclose(msg.points[0].velocities, 0.0, atol=1e-12)
    np.testing.assert_allclose(msg.points[-1].velocities, 0.0, atol=1e-12)
    vel = np.array([p.velocities for p in msg.points])
    assert np.all(np.abs(vel) <= pe.MAX_VELOCITY * (1 + 1e-9))


@pytest.mark.parametrize('method', ['445', '555'])
def test_optimal_timing_and_an_orientation_tolerance(system, method):
    poses = np.array([[1.2, 0.0, 0.0], [1.2, 0.6, 1.0], [0.8, 0.9, -0.5]])
    assert system.set_planner_parameters({'method': method, 'timing': 'optimal',
                                          'max_path_deviation': 5e-3,
                                          'max_orientation_deviation': 0.01})[0].successful
    try:
        status, msg = system.request(tool_waypoint_message(poses))
    finally:
        system.set_planner_parameters({'method': '434', 'timing': 'uniform',
                                       'max_path_deviation': 1e-3,
                                       'max_orientation_deviation': 0.0})
    assert_planned(status)
    values = status_values(status)
    assert (values['method'], values['timing']) == (method, 'optimal')
    if method == '445':
        assert int(values['inserted_waypoints']) > 0   # refined
    else:
        # 555 optimal is timed along the lines' own inverse kinematics: the
        # unrefined deviation is the spline's, already small.
        assert float(values['unrefined_max_path_deviation']) <= 5e-3
    assert float(values['max_path_deviation_reached']) <= 5e-3
    assert float(values['max_orientation_deviation_reached']) <= 0.01
    played = sampled_trajectory_from_msg(msg, pe.JOINT_NAMES)
    t = np.arange(0.0, played.times[-1], 1e-3)
    tool = tool_of(np.array([played.state_at(x)[0] for x in t]))
    assert distance_to_polyline(tool[:, :2], poses[:, :2]).max() <= 5e-3 + 1e-5


def test_no_tolerance_plans_the_unrefined_path(system):
    assert system.set_planner_parameters({'max_path_deviation': 0.0})[0].successful
    try:
        status, _ = system.request(tool_waypoint_message(TRIANGLE))
    finally:
        system.set_planner_parameters({'max_path_deviation': 1e-3})
    values = status_values(status)
    assert values['inserted_waypoints'] == '0'
    assert float(values['max_path_deviation_reached']) > 0.03


def bad_tool_requests():
    nan = tool_waypoint_message(TRIANGLE)
    nan.poses[4].position.y = math.nan
    tilted = tool_waypoint_message(TRIANGLE)
    tilted.poses[2].orientation.x = 0.3
    unreachable = tool_waypoint_message([[1.0, 0.0, 0.0], [2.5, 0.0, 0.0]])
    through_base = tool_waypoint_message([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]])
    return [
        ('NaN', nan, 'tool waypoint 4 is not finite'),
        ('empty', PoseArray(), 'need at least 2 tool waypoints, got 0'),
        ('one pose', tool_waypoint_message(TRIANGLE[:1]), 'at least 2 tool waypoints'),
        ('tilted', tilted, 'tool waypoint 2: the orientation tilts'),
        ('unreachable', unreachable, 'tool waypoint 1 at (x, y, yaw) = (2.5, 0, 0) is '
                                     'unreachable'),
        ('through the base', through_base, 'line from tool waypoint 0 to 1 leaves the reach'),
        # A plan of microseconds with a misleading warning before (helper-66).
        ('identical poses', tool_waypoint_message([[1.0, 0.5, 0.3]] * 3),
         'all 3 tool waypoints coincide'),
        # Another frame was planned as if it were the base frame (helper-66).
        ('another frame', tool_waypoint_message(TRIANGLE, 'camera_optical_frame'),
         "tool_waypoints are in frame 'camera_optical_frame', but the base frame of the "
         "planar arm is 'base_link'"),
    ]


def test_bad_tool_requests_get_an_error_and_the_node_keeps_serving(system):
    for name, msg, expected in bad_tool_requests():
        status, traj = system.request(msg)
        assert status.level == DiagnosticStatus.ERROR, name
        assert expected in status.message, (name, status.message)
        assert 'internal error' not in status.message
        assert traj is None
    for values, expected in [
            ({'max_inserted_waypoints': 3}, 'after inserting 3 waypoints (max_inserted)'),
            ({'max_refinement_time': 1e-9}, 'past max_refinement_time (1e-09 s): '),
            ({'timing': 'fixed'}, 'timing "fixed" needs times'),
            ({'start_from_current_state': True}, 'rest to rest'),
            ({'kinematics': ''}, 'tool_waypoints need the kinematics parameter')]:
        assert system.set_planner_parameters(values)[0].successful
        try:
            status, traj = system.request(tool_waypoint_message(TRIANGLE))
        finally:
            system.set_planner_parameters({name: RESTORE[name] for name in values})
        assert status.level == DiagnosticStatus.ERROR and expected in status.message, (
            values, status.message)
        assert traj is None
    assert system.planner.parameters.config.kinematics == 'planar_3dof'
    assert system.planner.parameters.config.max_inserted_waypoints == 200
    assert system.planner.parameters.config.max_refinement_time == 30.0
    status, traj = system.request(tool_waypoint_message(TRIANGLE))
    assert_planned(status)
    assert traj is not None
    counters = [int(status_values(s)['request']) for s in system.planner_status]
    assert counters == list(range(1, len(counters) + 1))  # one status per message


ANY_FLOAT = st.one_of(st.floats(-3.0, 3.0), st.floats(allow_nan=True, allow_infinity=True),
                      st.sampled_from([0.0, 1e300, -1e-300]))


@settings(max_examples=examples(40))
@given(rows=st.lists(st.tuples(*[ANY_FLOAT] * 7), max_size=6))
def test_random_pose_arrays_get_one_status_each_and_never_an_internal_error(system, rows):
    msg = PoseArray()
    for x, y, z, qx, qy, qz, qw in rows:
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = x, y, z
        pose.orientation.x, pose.orientation.y = qx, qy
        pose.orientation.z, pose.orientation.w = qz, qw
        msg.poses.append(pose)
    count = len(system.planner_status)
    status, traj = system.request(msg)
    assert len(system.planner_status) == count + 1
    assert 'internal error' not in status.message, status.message
    assert (traj is not None) == (status.level == DiagnosticStatus.OK), status.message


@pytest.mark.parametrize('values, reason', [
    ({'kinematics': 'scara'}, 'kinematics must be one of'),
    ({'link_lengths': [1.1, -0.9]}, 'link_lengths[1]'),
    ({'link_lengths': [1.1]}, 'link_lengths needs 2 values'),
    ({'max_path_deviation': -1e-3}, 'max_path_deviation = -0.001'),
    ({'max_orientation_deviation': math.nan}, 'max_orientation_deviation'),
    ({'max_inserted_waypoints': -1}, 'max_inserted_waypoints'),
    ({'max_refinement_time': -1.0}, 'max_refinement_time = -1.0'),
    ({'max_refinement_time': math.inf}, 'max_refinement_time = inf'),
])
def test_invalid_tool_parameters_are_rejected_with_a_reason(system, values, reason):
    before = system.planner.parameters.config
    result = system.set_planner_parameters(values)[0]
    assert not result.successful and reason in result.reason, result.reason
    assert system.planner.parameters.config == before


def test_planar_kinematics_needs_three_joints(system):
    before = system.planner.parameters.config
    result = system.planner.set_parameters_atomically(overrides(
        {'joint_names': ['a', 'b'], 'max_velocity': [1.0, 1.0],
         'max_acceleration': [1.0, 1.0], 'max_jerk': [0.0, 0.0]}))
    assert not result.successful and 'needs 3 joint_names' in result.reason, result.reason
    assert system.planner.parameters.config == before


def test_params_file_configures_tool_paths():
    import os
    import yaml
    from splines445_ros.service.planner_config import PlannerConfig
    path = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'planar_arm.yaml')
    with open(path, encoding='utf-8') as handle:
        values = yaml.safe_load(handle)['planner_node']['ros__parameters']
    config = PlannerConfig.from_values(values)
    assert config.kinematics == 'planar_3dof' and config.max_path_deviation == 1e-3
    assert config.tool_kinematics().d1 == 1.1


@settings(max_examples=examples(60), deadline=None)
@given(yaw=st.floats(-10.0, 10.0), sign=st.sampled_from([1.0, -1.0]))
def test_yaw_of_a_quaternion_is_the_same_for_q_and_minus_q(yaw, sign):
    # q and -q are one rotation: the same yaw, wrapped into (-pi, pi], so a
    # request never asks joint 3 for a needless full turn.
    msg = PoseArray()
    for x in (1.0, 0.5):
        pose = Pose()
        pose.position.x = x
        pose.orientation.z = sign * math.sin(0.5 * yaw)
        pose.orientation.w = sign * math.cos(0.5 * yaw)
        msg.poses.append(pose)
    parsed = parse_tool_request(msg)[:, 2]
    wrapped = math.remainder(yaw, 2.0 * math.pi)
    assert np.all(parsed > -math.pi - 1e-12) and np.all(parsed <= math.pi + 1e-12)
    # Equal as angles (at +-pi either sign is the same orientation).
    np.testing.assert_allclose(np.cos(parsed - wrapped), 1.0, atol=1e-12)
    if abs(abs(wrapped) - math.pi) > 1e-6:
        np.testing.assert_allclose(parsed, wrapped, atol=1e-9)
