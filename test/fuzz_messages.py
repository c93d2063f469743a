"""Hypothesis strategies for good and bad messages (test helpers only)."""

from hypothesis import strategies as st
import numpy as np
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

JOINTS = ('joint1', 'joint2', 'joint3')
VMAX = np.array([2.0, 2.0, 2.0])
AMAX = np.array([10.0, 10.0, 10.0])


def _duration(point, seconds):
    total = int(round(seconds * 1e9))
    point.time_from_start.sec = total // 1_000_000_000
    point.time_from_start.nanosec = total % 1_000_000_000


@st.composite
def good_requests(draw):
    """Draw a valid waypoint request and what it asks for, in parameter joint order."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    order = list(draw(st.permutations(JOINTS)))
    n_points = draw(st.integers(2, 10))
    steps = rng.uniform(-0.8, 0.8, (n_points, 3))
    steps[1] += 0.05 * np.sign(steps[1] + 1e-9)  # at least two distinct waypoints
    waypoints = np.cumsum(steps, axis=0)
    if n_points > 2 and draw(st.booleans()):
        k = draw(st.integers(1, n_points - 1))
        waypoints[k] = waypoints[k - 1]  # a consecutive duplicate
    boundary = [np.zeros(3)] * 4
    if draw(st.booleans()):
        boundary = [0.3 * rng.uniform(-1, 1, 3) * lim for lim in (VMAX, AMAX, VMAX, AMAX)]
    msg = JointTrajectory()
    msg.joint_names = order
    index = [JOINTS.index(name) for name in order]
    for q in waypoints:
        msg.points.append(JointTrajectoryPoint(positions=[float(q[i]) for i in index]))
    msg.points[0].velocities = [float(boundary[0][i]) for i in index]
    msg.points[0].accelerations = [float(boundary[1][i]) for i in index]
    msg.points[-1].velocities = [float(boundary[2][i]) for i in index]
    msg.points[-1].accelerations = [float(boundary[3][i]) for i in index]
    return msg, waypoints, boundary


CORRUPTIONS = ('nan', 'inf', 'huge', 'empty', 'one_point', 'short_positions', 'long_positions',
               'unknown_name', 'duplicate_name', 'missing_name', 'velocity_over_limit',
               'acceleration_over_limit', 'wrong_velocity_length', 'all_same', 'no_names')


@st.composite
def bad_requests(draw):
    """Draw a good request with one corruption; return (message, corruption name)."""
    msg, _, _ = draw(good_requests())
    kind = draw(st.sampled_from(CORRUPTIONS))
    k = draw(st.integers(0, len(msg.points) - 1))
    j = draw(st.integers(0, 2))
    point = msg.points[k]
    if kind in ('nan', 'inf'):
        values = list(point.positions)
        values[j] = float(kind) * draw(st.sampled_from([1.0, -1.0]))
        point.positions = values
    elif kind == 'huge':
        scale = draw(st.sampled_from([1e6, 1e12, 1e100, 1e300]))
        for p in msg.points:
            p.positions = [scale * (v + 1.0) * (-1) ** i for i, v in enumerate(p.positions)]
    elif kind == 'empty':
        msg = JointTrajectory()
    elif kind == 'one_point':
        msg.points = msg.points[:1]
    elif kind == 'short_positions':
        point.positions = list(point.positions)[:2]
    elif kind == 'long_positions':
        point.positions = list(point.positions) + [0.0]
    elif kind == 'unknown_name':
        names = list(msg.joint_names)
        names[j] = 'elbow'
        msg.joint_names = names
    elif kind == 'duplicate_name':
        names = list(msg.joint_names)
        names[j] = names[(j + 1) % 3]
        msg.joint_names = names
    elif kind == 'missing_name':
        msg.joint_names = list(msg.joint_names)[:2]
        for p in msg.points:
            p.positions = list(p.positions)[:2]
            p.velocities = list(p.velocities)[:2] if len(p.velocities) else []
            p.accelerations = list(p.accelerations)[:2] if len(p.accelerations) else []
    elif kind == 'velocity_over_limit':
        values = list(msg.points[0].velocities)
        values[j] = 2.5 * draw(st.sampled_from([1.0, -1.0]))
        msg.points[0].velocities = values
    elif kind == 'acceleration_over_limit':
        values = list(msg.points[-1].accelerations)
        values[j] = 11.0 * draw(st.sampled_from([1.0, -1.0]))
        msg.points[-1].accelerations = values
    elif kind == 'wrong_velocity_length':
        msg.points[-1].velocities = [0.0]
    elif kind == 'all_same':
        for p in msg.points:
            p.positions = list(msg.points[0].positions)
    elif kind == 'no_names':
        msg.joint_names = []
    return msg, kind


@st.composite
def arm_trajectories(draw):
    """Draw a good or bad joint_trajectory for the arm; return (message, is_good)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    order = list(draw(st.permutations(JOINTS)))
    n_points = draw(st.integers(1, 12))
    times = np.cumsum(rng.uniform(0.001, 0.02, n_points))
    positions = rng.uniform(-2.0, 2.0, (n_points, 3))
    with_vel = draw(st.booleans())
    with_acc = with_vel and draw(st.booleans())
    kind = draw(st.sampled_from(('good', 'good', 'good', 'nan', 'repeat_time', 'backwards',
                                 'unknown_name', 'missing_name', 'duplicate_name', 'empty',
                                 'some_velocities', 'short_positions', 'huge', 'huge_velocity',
                                 'negative_stamp')))
    msg = JointTrajectory()
    msg.joint_names = order
    for k in range(n_points):
        point = JointTrajectoryPoint(positions=[float(v) for v in positions[k]])
        if with_vel:
            point.velocities = [float(v) for v in rng.uniform(-1, 1, 3)]
        if with_acc:
            point.accelerations = [float(v) for v in rng.uniform(-1, 1, 3)]
        _duration(point, times[k])
        msg.points.append(point)
    k = draw(st.integers(0, n_points - 1))
    if kind == 'nan':
        values = list(msg.points[k].positions)
        values[0] = float('nan')
        msg.points[k].positions = values
    elif kind in ('repeat_time', 'backwards'):
        if n_points < 2:
            msg.points.append(JointTrajectoryPoint(positions=[0.0, 0.0, 0.0]))
            _duration(msg.points[-1], times[-1])
        victim = msg.points[-1]
        before = times[-2] if n_points >= 2 else times[-1]
        _duration(victim, before if kind == 'repeat_time' else max(before - 0.005, 0.0))
        if with_vel:
            victim.velocities = [0.0, 0.0, 0.0]
        if with_acc:
            victim.accelerations = [0.0, 0.0, 0.0]
    elif kind == 'unknown_name':
        msg.joint_names = ['x'] + order[1:]
    elif kind == 'missing_name':
        msg.joint_names = order[:2]
        for p in msg.points:
            p.positions = list(p.positions)[:2]
            p.velocities = list(p.velocities)[:2] if with_vel else []
            p.accelerations = list(p.accelerations)[:2] if with_acc else []
    elif kind == 'duplicate_name':
        msg.joint_names = [order[0], order[0], order[2]]
    elif kind == 'empty':
        msg.points = []
    elif kind == 'some_velocities':
        msg.points[k].velocities = [0.0, 0.0, 0.0] if not with_vel else []
        if n_points == 1:
            msg.points.append(JointTrajectoryPoint(positions=[0.0, 0.0, 0.0],
                                                   velocities=[] if not with_vel else
                                                   [0.0, 0.0, 0.0]))
            _duration(msg.points[-1], times[-1] + 0.01)
            msg.points[0].velocities = [] if with_vel else [0.0, 0.0, 0.0]
    elif kind == 'short_positions':
        msg.points[k].positions = [0.0]
    elif kind == 'huge':
        # Finite, but its interpolation overflowed and the arm crashed (helper-36).
        values = list(msg.points[k].positions)
        values[0] = draw(st.sampled_from([1e308, -1e308, 1e7]))
        msg.points[k].positions = values
    elif kind == 'huge_velocity':
        msg.points[k].velocities = [draw(st.sampled_from([1e308, 2e6])), 0.0, 0.0]
        if not with_vel:
            for p in msg.points:
                p.velocities = list(p.velocities) or [0.0, 0.0, 0.0]
    elif kind == 'negative_stamp':
        msg.header.stamp.sec = -draw(st.integers(1, 2**31 - 1))
    return msg, kind == 'good'
