"""
6-D straight tool paths on vendor arms (UR5, Panda) and the planar case as a special case.

Checked independently: forward kinematics written here from the URDF's joint
origins and axes (batched numpy), scipy's Rotation and Slerp for the
orientations, a 1 kHz sampling of the planned trajectory.
"""

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar
from scipy.spatial.transform import Rotation, Slerp
from splines445_ros.cartesian.path_deviation import PathMeasure
from splines445_ros.cartesian.tool_paths import plan_tool_path
from splines445_ros.planning import plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.robot.inverse_kinematics import ModelKinematics
from splines445_ros.robot.kinematics import PlanarArm
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.sim.mujoco_model import planar_arm_mjcf, PlanarArmModel
from splines445_ros.tools import vendor_robots as vr
from urdf_reference import BatchedUrdfChain

MM, DEG = 1e-3, math.radians(1.0)
UR5_LIMITS = {'max_velocity': [3.15] * 3 + [3.2] * 3, 'max_acceleration': [8.0] * 6,
              'max_jerk': [80.0] * 6}
PANDA_LIMITS = {'max_velocity': [2.175] * 4 + [2.61] * 3, 'max_acceleration': [6.0] * 7,
                'max_jerk': [60.0] * 7}


def check_1khz(tool_path, poses, fk, tol_position, tol_orientation):
    """Largest deviations at 1 kHz from the edges and the slerps, by the test's own FK."""
    traj = tool_path.trajectory
    t = np.arange(0.0, traj.duration, 1e-3)
    pos, mat = fk(traj.evaluate(t))
    passed = traj.waypoint_times[tool_path.waypoint_knots]
    edge = np.clip(np.searchsorted(passed, t, side='right') - 1, 0, len(poses) - 2)
    a, b = poses[edge, :3], poses[edge + 1, :3]
    ab = b - a
    s = np.clip(np.sum((pos - a) * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    position = np.linalg.norm(pos - a - s[:, None] * ab, axis=1)
    requested = Rotation.from_quat(poses[:, 3:], scalar_first=True)
    angle = np.empty(len(t))
    for e in range(len(poses) - 1):
        on = edge == e
        slerp = Slerp([0.0, 1.0], requested[e:e + 2])
        wanted = slerp(s[on])
        angle[on] = (wanted.inv() * Rotation.from_matrix(mat[on])).magnitude()
    assert position.max() <= tol_position * (1 + 1e-6), position.max()
    assert angle.max() <= tol_orientation * (1 + 1e-6), angle.max()
    # Through every requested pose.
    at = traj.evaluate(passed)
    p_at, m_at = fk(at)
    np.testing.assert_allclose(p_at, poses[:, :3], atol=1e-8)
    np.testing.assert_allclose(
        (requested.inv() * Rotation.from_matrix(m_at)).magnitude(), 0.0, atol=1e-8)
    return position.max(), angle.max()


@pytest.fixture(scope='module')
def ur5():
    robot = load_robot_model(vr.ur5_urdf())
    kin = ModelKinematics(robot, 'tool0', 'base_link', seed=vr.UR5_READY)
    fk = BatchedUrdfChain(vr.ur5_urdf(), 'base_link', 'tool0', list(vr.UR5_JOINTS))
    return kin, fk


def seam(kin, ready, corners, z, turn_last_edge=0.0):
    """Return a closed seam on a table at height z, the tool pointing down as in ``ready``."""
    down = Rotation.from_quat(kin.forward(np.array(ready))[3:], scalar_first=True)
    poses = []
    for k, (x, y) in enumerate(corners):
        orientation = down
        if turn_last_edge and k == len(corners) - 1:
            orientation = Rotation.from_euler('z', turn_last_edge) * down
        poses.append([x, y, z, *orientation.as_quat(scalar_first=True)])
    return np.array(poses)


UR5_SEAM = [(0.3, -0.2), (0.55, -0.2), (0.55, 0.2), (0.3, 0.2), (0.3, -0.2)]


@pytest.mark.parametrize('method, timing', [('555', 'uniform'), ('555', 'optimal'),
                                            ('434', 'uniform')])
def test_ur5_seam_within_1mm_and_1deg(ur5, method, timing):
    kin, fk = ur5
    poses = seam(kin, vr.UR5_READY, UR5_SEAM, 0.15, turn_last_edge=math.radians(60))
    result = plan_tool_path(poses, kin, MM, DEG, max_inserted=2000, method=method,
                            timing=timing, **UR5_LIMITS)
    if (method, timing) == ('555', 'optimal'):
        # Timed along the inverse kinematics of the lines themselves.
        assert result.construction == 'tool lines'
    else:
        assert result.initial_deviation.max_position > 10 * MM  # the refinement had work to do
        assert result.inserted > 0
    position, angle = check_1khz(result, poses, fk, MM, DEG)
    # The library's maxima bound what a 1 kHz sampling sees.
    assert result.max_deviation >= position - 1e-9
    assert result.max_orientation_deviation >= angle - 1e-9
    assert result.trajectory.within_limits(rtol=1e-6)


def test_panda_seam_within_1mm_and_1deg():
    robot = load_robot_model(vr.panda_urdf())
    kin = ModelKinematics(robot, 'panda_hand_tcp', 'panda_link0', vr.PANDA_ARM_JOINTS,
                          seed=vr.PANDA_READY)
    fk = BatchedUrdfChain(vr.panda_urdf(), 'panda_link0', 'panda_hand_tcp',
                          list(vr.PANDA_ARM_JOINTS))
    corners = [(0.35, -0.15), (0.55, -0.15), (0.55, 0.15), (0.35, 0.15), (0.35, -0.15)]
    poses = seam(kin, vr.PANDA_READY, corners, 0.25)
    result = plan_tool_path(poses, kin, MM, DEG, max_inserted=2000, method='555',
                            timing='uniform', **PANDA_LIMITS)
    check_1khz(result, poses, fk, MM, DEG)
    lower, upper = kin.lower, kin.upper
    q = result.trajectory.evaluate(np.linspace(0, result.trajectory.duration, 2000))
    assert np.all(q >= lower - 1e-9) and np.all(q <= upper + 1e-9)


def test_the_planar_case_is_the_special_case(tmp_path):
    """The paper's triangle as 6-D poses on the planar arm's model: the same refinement."""
    path = tmp_path / 'planar.xml'
    path.write_text(planar_arm_mjcf(PlanarArmModel(), pe.JOINT_NAMES))
    q0 = pe.joint_waypoints()[0]
    model = ModelKinematics(load_robot_model(str(path)), 'tool', seed=q0)
    xy = pe.triangle_points()
    yaw = np.linspace(0.0, 0.8, len(xy))
    planar_poses = np.column_stack([xy, yaw])
    spatial_poses = np.column_stack([xy, np.zeros(len(xy)), np.cos(yaw / 2),
                                     np.zeros(len(xy)), np.zeros(len(xy)), np.sin(yaw / 2)])
    kwargs = {'max_velocity': pe.MAX_VELOCITY, 'max_acceleration': pe.MAX_ACCELERATION,
              'method': '555', 'timing': 'uniform'}
    planar = plan_tool_path(planar_poses, PlanarArm(1.1, 0.9), 1e-3, 0.01, **kwargs)
    spatial = plan_tool_path(spatial_poses, model, 1e-3, 0.01, **kwargs)
    assert spatial.inserted == planar.inserted > 0
    np.testing.assert_allclose(spatial.joints, planar.joints, atol=1e-7)
    np.testing.assert_allclose(spatial.deviation.position, planar.deviation.position,
                               atol=1e-8)
    np.testing.assert_allclose(spatial.deviation.orientation, planar.deviation.orientation,
                               atol=1e-8)


def test_bad_spatial_poses_are_named(ur5):
    kin, _ = ur5
    good = kin.forward(np.array(vr.UR5_READY))
    with pytest.raises(ValueError, match='tool waypoint 1 has qy = nan'):
        plan_tool_path([good, [*good[:5], math.nan, good[6]]], kin, MM)
    with pytest.raises(ValueError, match='tool waypoint 1 has a zero quaternion'):
        plan_tool_path([good, [*good[:3], 0, 0, 0, 0]], kin, MM)
    with pytest.raises(ValueError, match=r'shape \(N, 3\).*or \(N, 7\)'):
        plan_tool_path(np.zeros((3, 6)), kin, MM)
    far = good.copy()
    far[0] = 2.0
    with pytest.raises(ValueError, match=r'tool waypoint 2 at \(x, y, z\) = \(2, .*out of reach'):
        plan_tool_path([good, good + [0.05, 0, 0, 0, 0, 0, 0], far], kin, MM, **UR5_LIMITS)


def test_a_tool_waypoint_out_of_reach_is_named_by_the_tool_lines_too(ur5):
    """With a tool speed the lines are walked without the waypoints' own IK: still named."""
    kin, _ = ur5
    good = kin.forward(np.array(vr.UR5_READY))
    far = good.copy()
    far[0] = 2.0
    with pytest.raises(ValueError, match=r'tool waypoint 2 at \(x, y, z\) = \(2, .*out of reach'):
        plan_tool_path([good, good + [0.05, 0, 0, 0, 0, 0, 0], far], kin, MM, method='555',
                       timing='optimal', max_tool_speed=0.1, **UR5_LIMITS)


def off_the_turn(fk, traj, start, goal):
    """Largest angle [rad] at 1 kHz between the tool and the rotation from start to goal."""
    first = Rotation.from_quat(start, scalar_first=True)
    turn = (first.inv() * Rotation.from_quat(goal, scalar_first=True)).as_rotvec()
    _, mat = fk(traj.evaluate(np.arange(0.0, traj.duration, 1e-3)))
    worst = 0.0
    for tool in Rotation.from_matrix(mat):
        def away(s, tool=tool):
            return ((first * Rotation.from_rotvec(s * turn)).inv() * tool).magnitude()
        worst = max(worst, minimize_scalar(away, bounds=(0.0, 1.0), method='bounded',
                                           options={'xatol': 1e-10}).fun)
    return worst


@pytest.mark.parametrize('method, timing', [('555', 'optimal'), ('434', 'optimal'),
                                            ('445', 'uniform')])
def test_a_turn_in_place_stays_on_its_rotation(ur5, method, timing):
    """A pure rotation is measured by how far the tool has turned, however it is timed."""
    kin, fk = ur5
    start = kin.forward(np.array(vr.UR5_READY))
    goal = start.copy()
    goal[3:] = (Rotation.from_rotvec(math.radians(70) * np.array([0.3, 0.2, 0.93]))
                * Rotation.from_quat(start[3:], scalar_first=True)).as_quat(scalar_first=True)
    result = plan_tool_path([start, goal], kin, MM, DEG, method=method, timing=timing,
                            **UR5_LIMITS)
    traj = result.trajectory
    position, _ = fk(traj.evaluate(np.arange(0.0, traj.duration, 1e-3)))
    assert np.max(np.linalg.norm(position - start[:3], axis=1)) <= MM
    angle = off_the_turn(fk, traj, start[3:], goal[3:])
    assert angle <= DEG
    assert result.max_orientation_deviation >= angle - 1e-6
    _, at_goal = fk(traj.evaluate(np.array([traj.duration])))
    goal_rotation = Rotation.from_quat(goal[3:], scalar_first=True)
    assert (goal_rotation.inv() * Rotation.from_matrix(at_goal[0])).magnitude() < 1e-8


@pytest.mark.parametrize('tolerances', [(None, DEG), (MM, None), (0.0, DEG), (MM, 0.0)])
def test_one_tolerance_alone_never_skips_a_waypoint(ur5, tolerances):
    """A waypoint 15 cm away, or turned 60 degrees in place, is passed with either unchecked."""
    kin, fk = ur5
    a = kin.forward(np.array(vr.UR5_READY))
    moved, turned, last = a.copy(), a.copy(), a.copy()
    moved[0] += 0.15
    turned[:3] = moved[:3]
    turned[3:] = (Rotation.from_euler('z', math.radians(60))
                  * Rotation.from_quat(a[3:], scalar_first=True)).as_quat(scalar_first=True)
    last[:3] = moved[:3] + [0.0, 0.15, 0.0]
    last[3:] = turned[3:]
    poses = np.array([a, moved, turned, last])
    result = plan_tool_path(poses, kin, *tolerances, method='555', timing='optimal',
                            **UR5_LIMITS)
    traj = result.trajectory
    passed = traj.waypoint_times[result.waypoint_knots]
    position, mat = fk(traj.evaluate(passed))
    np.testing.assert_allclose(position, poses[:, :3], atol=1e-8)
    requested = Rotation.from_quat(poses[:, 3:], scalar_first=True)
    np.testing.assert_allclose((requested.inv() * Rotation.from_matrix(mat)).magnitude(), 0.0,
                               atol=1e-8)


def test_a_waypoint_the_goal_replaces_is_passed_at_the_goal(ur5):
    """A waypoint 20 micrometres before the goal is merged into it: passed there, not earlier."""
    kin, fk = ur5
    a = kin.forward(np.array(vr.UR5_READY))
    b, goal = a.copy(), a.copy()
    b[0] += 0.15
    goal[:3] = b[:3] + [0.0, 2e-5, 0.0]
    result = plan_tool_path([a, b, goal], kin, MM, DEG, method='555', timing='optimal',
                            **UR5_LIMITS)
    knots = result.waypoint_knots
    assert knots[1] == knots[2] != knots[0]
    traj = result.trajectory
    position, _ = fk(traj.evaluate(traj.waypoint_times[knots]))
    # Within the merging share (0.1) of the position tolerance of each.
    np.testing.assert_allclose(position[1], b[:3], atol=0.1 * MM)
    np.testing.assert_allclose(position[2], goal[:3], atol=1e-8)


@pytest.mark.parametrize('method, timing', [('555', 'optimal'), ('445', 'uniform')])
def test_a_coordinate_beyond_any_reach_is_refused_by_name(ur5, method, timing):
    kin, _ = ur5
    good = kin.forward(np.array(vr.UR5_READY))
    far = good.copy()
    far[0] = 1e300
    with pytest.raises(ValueError, match=r'tool waypoint 1 has x = 1e\+300: beyond'):
        plan_tool_path([good, far], kin, MM, DEG, method=method, timing=timing, **UR5_LIMITS)


def test_a_line_the_tool_lines_cannot_keep_within_is_named(ur5):
    """With a tool speed the tool lines' error is raised: it names the line, by waypoints."""
    kin, _ = ur5
    poses = seam(kin, vr.UR5_READY, UR5_SEAM, 0.15)
    with pytest.raises(ValueError, match=r'the line from tool waypoint \d to \d: the tool path '
                                         r'needs more than max_inserted = 1 knots'):
        plan_tool_path(poses, kin, 1e-7, DEG, method='555', timing='optimal',
                       max_tool_speed=0.1, max_inserted=1, **UR5_LIMITS)


class _TurningTool:
    """A tool at the origin turned about z by the one joint's angle (quaternions, no matrices)."""

    def forward(self, q):
        angle = np.asarray(q, dtype=float)[..., 0]
        zero = np.zeros_like(angle)
        return np.stack([zero, zero, zero, np.cos(angle / 2), zero, zero, np.sin(angle / 2)],
                        axis=-1)


@pytest.mark.parametrize('overshoot', [0.0, 0.03, 0.1])
def test_a_turn_of_nearly_pi_is_measured_past_pi(overshoot):
    """A rotation vector stops at pi: a tool just past it read as turned the other way."""
    edge = 3.1
    traj = plan(np.array([[0.0], [edge + overshoot]]), '555', 'fixed', durations=[1.0])
    poses = _TurningTool().forward(np.array([[0.0], [edge]]))
    deviation = PathMeasure(traj, _TurningTool(), poses, np.array([0])).deviation((MM, DEG))
    # The tool's largest angle from the turn is its overshoot at the end (the test's own).
    assert deviation.max_orientation == pytest.approx(overshoot, abs=1e-6)


@pytest.mark.parametrize('tolerances', [(MM, None), (None, DEG)])
def test_a_recorded_jitter_is_merged_with_one_tolerance_unchecked(ur5, tolerances):
    """20 micrometres and a microradian from the one before: no line of its own (no stop)."""
    kin, fk = ur5
    a = kin.forward(np.array(vr.UR5_READY))
    jitter, goal = a.copy(), a.copy()
    jitter[1] += 2e-5
    jitter[3:] = (Rotation.from_rotvec([1e-6, 0.0, 0.0])
                  * Rotation.from_quat(a[3:], scalar_first=True)).as_quat(scalar_first=True)
    goal[0] += 0.2
    result = plan_tool_path([a, jitter, goal], kin, *tolerances, method='555',
                            timing='optimal', **UR5_LIMITS)
    assert len(result.poses) == 2
    alone = plan_tool_path([a, goal], kin, *tolerances, method='555', timing='optimal',
                           **UR5_LIMITS)
    assert result.trajectory.duration == pytest.approx(alone.trajectory.duration, rel=1e-9)
    position, _ = fk(result.trajectory.evaluate(
        result.trajectory.waypoint_times[result.waypoint_knots[1:2]]))
    assert np.linalg.norm(position[0] - jitter[:3]) < 1e-4
