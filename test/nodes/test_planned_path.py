"""
The planned path as RViz markers (``splines445_ros.nodes.planned_path``).

The tool positions are checked against forward kinematics written here: the
planar arm's with cos and sin, the UR5's from its URDF's origins and axes
(:mod:`urdf_reference`), not the package's kinematics.
"""

import math

from builtin_interfaces.msg import Time
import numpy as np
import pytest
from splines445_ros.nodes.planned_path import (MAX_PATH_POINTS, PATH_PERIOD, planned_path_markers,
                                               tool_path_points, tool_position_function)
from splines445_ros.planning import plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.service.model_planning import build_robot_setup
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.tools import vendor_robots as vr
from urdf_reference import BatchedUrdfChain
from visualization_msgs.msg import Marker

D1, D2 = 0.7, 0.4  # not the defaults, so link_lengths must be used


def planar_tool(q):
    """Tool position (x, y, 0) of the planar arm at joints q (3,), written out."""
    q1, q2 = q[0], q[1]
    return np.array([D1 * math.cos(q1) + D2 * math.cos(q1 + q2),
                     D1 * math.sin(q1) + D2 * math.sin(q1 + q2), 0.0])


def planar_waypoints():
    return np.array([[0.0, 0.3, 0.0], [0.4, 1.0, -0.5], [1.1, 0.6, 0.2], [0.9, -0.3, 0.4]])


def planar_config():
    return PlannerConfig(kinematics='planar_3dof', link_lengths=(D1, D2))


@pytest.mark.parametrize('method, timing', [('445', 'uniform'), ('555', 'optimal')])
def test_planar_path_runs_from_the_first_to_the_last_waypoint(method, timing):
    waypoints = planar_waypoints()
    traj = plan(waypoints, method, timing, max_velocity=pe.MAX_VELOCITY,
                max_acceleration=pe.MAX_ACCELERATION, max_jerk=[50.0] * 3)
    if timing == 'optimal':  # knots between the waypoints too
        assert len(traj.breakpoints) > len(waypoints)
    forward, frame = tool_position_function(planar_config())
    assert frame == 'base_link'  # arm_sim_node's tool_pose frame
    path, spheres = tool_path_points(traj, forward)
    assert np.all(np.isfinite(path)) and np.all(np.isfinite(spheres))
    assert path.shape[1] == 3 and np.all(path[:, 2] == 0.0)
    np.testing.assert_allclose(path[0], planar_tool(waypoints[0]), atol=1e-9)
    np.testing.assert_allclose(path[-1], planar_tool(waypoints[-1]), atol=1e-9)
    # One sphere per waypoint, at the waypoint (555 optimal has inner knots
    # between them: the spheres must not sit on those).
    np.testing.assert_allclose(spheres, [planar_tool(w) for w in waypoints], atol=1e-9)
    # Sampled evenly in time, at least every 10 ms, along the trajectory.
    assert len(path) >= traj.duration / PATH_PERIOD + 1
    times = np.linspace(0.0, traj.duration, len(path))
    expected = [planar_tool(q) for q in traj.evaluate(times, 0)]
    np.testing.assert_allclose(path, expected, atol=1e-9)
    # Smooth enough for a line: consecutive points close together.
    assert np.max(np.linalg.norm(np.diff(path, axis=0), axis=1)) < 0.05


def test_a_long_plan_is_capped_and_keeps_its_end():
    waypoints = planar_waypoints()
    traj = plan(waypoints, '445', 'uniform', max_velocity=[0.02] * 3,
                max_acceleration=[0.1] * 3)
    assert traj.duration / PATH_PERIOD > 2 * MAX_PATH_POINTS  # long enough to be capped
    forward, _ = tool_position_function(planar_config())
    path, _ = tool_path_points(traj, forward)
    assert len(path) == MAX_PATH_POINTS
    np.testing.assert_allclose(path[-1], planar_tool(waypoints[-1]), atol=1e-9)
    few, spheres = tool_path_points(traj, forward, samples=5)
    assert len(few) == 5 and len(spheres) == len(waypoints)
    np.testing.assert_allclose(few[0], planar_tool(waypoints[0]), atol=1e-9)
    np.testing.assert_allclose(few[-1], planar_tool(waypoints[-1]), atol=1e-9)


def test_the_planar_function_takes_one_row_or_many():
    forward, _ = tool_position_function(planar_config())
    q = planar_waypoints()
    np.testing.assert_allclose(forward(q[1]), planar_tool(q[1]), atol=1e-12)
    np.testing.assert_allclose(forward(q), [planar_tool(r) for r in q], atol=1e-12)


def test_joint_space_planner_has_no_markers():
    assert tool_position_function(PlannerConfig()) is None
    assert PlannerConfig().kinematics == ''
    # kinematics "model" before a robot exists: nothing to draw yet.
    assert tool_position_function(PlannerConfig(kinematics='model'), None) is None


def test_markers_clear_then_draw_the_line_and_the_spheres():
    rng = np.random.default_rng(3)
    path, spheres = rng.normal(size=(40, 3)), rng.normal(size=(4, 3))
    stamp = Time(sec=12, nanosec=345)
    markers = planned_path_markers(path, spheres, 'base_link', stamp).markers
    assert len(markers) == 3
    clear, line, balls = markers
    assert clear.action == Marker.DELETEALL
    for marker in markers:
        assert marker.header.frame_id == 'base_link'
        assert (marker.header.stamp.sec, marker.header.stamp.nanosec) == (12, 345)
    assert (line.type, line.action, line.ns, line.id) == (Marker.LINE_STRIP, Marker.ADD,
                                                          'tool_path', 0)
    assert (balls.type, balls.action, balls.ns, balls.id) == (Marker.SPHERE_LIST, Marker.ADD,
                                                              'waypoints', 1)
    assert 0.001 <= line.scale.x <= 0.01   # about 5 mm wide
    assert 0.01 <= balls.scale.x <= 0.03   # about 2 cm across
    assert balls.scale.x == balls.scale.y == balls.scale.z
    for marker in (line, balls):
        assert marker.pose.orientation.w == 1.0
        assert marker.color.a == 1.0
    colours = [(m.color.r, m.color.g, m.color.b) for m in (line, balls)]
    assert colours[0] != colours[1]
    np.testing.assert_array_equal([[p.x, p.y, p.z] for p in line.points], path)
    np.testing.assert_array_equal([[p.x, p.y, p.z] for p in balls.points], spheres)
    unstamped = planned_path_markers(path, spheres, 'world').markers
    assert all(m.header.stamp.sec == 0 and m.header.stamp.nanosec == 0 for m in unstamped)
    assert all(m.header.frame_id == 'world' for m in unstamped)


def ur5_setup(base_frame):
    config = PlannerConfig.from_values({
        'kinematics': 'model', 'model_file': vr.ur5_urdf(), 'tool_frame': 'tool0',
        'base_frame': base_frame, 'joint_names': list(vr.UR5_JOINTS),
        'max_velocity': [0.0], 'max_acceleration': [5.0] * 6, 'max_jerk': [0.0]})
    return build_robot_setup(config)


@pytest.mark.parametrize('base_frame, frame', [('base_link', 'base_link'), ('', 'base_link')])
def test_model_arm_path_is_the_urdfs_tool_position(base_frame, frame):
    setup = ur5_setup(base_frame)
    ready = np.array(vr.UR5_READY)
    waypoints = np.array([ready, ready + [0.3, 0.2, -0.3, 0.1, 0.2, 0.5],
                          ready + [-0.2, 0.4, -0.1, -0.2, 0.1, -0.4]])
    config = setup.config
    traj = plan(waypoints, '555', 'uniform', max_velocity=config.max_velocity,
                max_acceleration=config.max_acceleration)
    forward, frame_id = tool_position_function(config, setup)
    assert frame_id == frame
    path, spheres = tool_path_points(traj, forward)
    assert np.all(np.isfinite(path))
    # The UR5's root link is base_link: the world is base_link's frame.
    urdf = BatchedUrdfChain(vr.ur5_urdf(), 'base_link', 'tool0', list(vr.UR5_JOINTS))
    reference = urdf(waypoints)[0]
    np.testing.assert_allclose(spheres, reference, atol=1e-8)
    np.testing.assert_allclose(path[0], reference[0], atol=1e-8)
    np.testing.assert_allclose(path[-1], reference[-1], atol=1e-8)
    times = np.linspace(0.0, traj.duration, len(path))
    np.testing.assert_allclose(path, urdf(traj.evaluate(times, 0))[0], atol=1e-8)
    # The robot's own kinematics agree too, one row at a time.
    np.testing.assert_allclose(forward(waypoints[1]), setup.kinematics.forward(
        waypoints[1])[:3], atol=1e-12)
    markers = planned_path_markers(path, spheres, frame_id).markers
    assert markers[0].action == Marker.DELETEALL
    assert [m.header.frame_id for m in markers] == [frame] * 3
    np.testing.assert_allclose([[p.x, p.y, p.z] for p in markers[2].points], reference,
                               atol=1e-8)
