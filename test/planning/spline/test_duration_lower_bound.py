"""
``Trajectory.duration_lower_bound``: no plan within the v/a limits is shorter; short moves count.

The bound must stay below every plan's duration (every method, timing and
speed profile, random requests), and on a single joint's rest-to-rest move
it is that move's bang-bang time, written out here.  Its warning (a uniform
plan far above it) no longer fires on short moves, which the acceleration
limit sets (helper-74: a 0.1 rad move was 24 times the velocity-only bound).
"""

import math

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
from splines445_ros.planning import plan
from splines445_ros.service.request_planning import SLOW_PLAN_FACTOR, slow_plan_warning


def bang_bang(d, v, a):
    """Shortest rest-to-rest time over ``d`` with |v| <= v, |a| <= a (triangle or trapezoid)."""
    if d <= v * v / a:
        return 2.0 * math.sqrt(d / a)
    return d / v + v / a


@settings(max_examples=examples(30), deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_no_plan_is_shorter_than_the_bound(seed):
    rng = np.random.default_rng(seed)
    n, m = int(rng.integers(2, 8)), int(rng.integers(1, 5))
    waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n, m)) * rng.choice([0.01, 0.1, 1.0]), axis=0)
    limits = {'max_velocity': rng.uniform(0.5, 3.0, m),
              'max_acceleration': rng.uniform(1.0, 15.0, m)}
    plans = [plan(waypoints, method, timing, **limits)
             for method in ('434', '445', '555') for timing in ('uniform', 'optimal')]
    plans.append(plan(waypoints, '555', 'optimal', speed_profile='time_optimal', **limits))
    for traj in plans:
        assert traj.duration >= traj.duration_lower_bound() * (1.0 - 1e-9), (
            traj.method, traj.timing, traj.duration, traj.duration_lower_bound())


def test_a_single_joints_move_is_bounded_by_its_bang_bang_time():
    for d, v, a in ((0.1, 2.0, 5.0), (3.0, 1.0, 4.0), (0.5, 0.5, 10.0)):
        traj = plan(np.array([[0.0], [0.4 * d], [d]]), '555', 'optimal',
                    max_velocity=[v], max_acceleration=[a])
        assert math.isclose(traj.duration_lower_bound(), bang_bang(d, v, a), rel_tol=1e-12)
        # Out to its highest point and back: twice the move.
        back = plan(np.array([[0.0], [d], [0.0]]), '555', 'optimal', max_velocity=[v],
                    max_acceleration=[a])
        assert math.isclose(back.duration_lower_bound(), 2.0 * bang_bang(d, v, a),
                            rel_tol=1e-12)
    # The fastest plan with no jerk limit comes within a few per cent of it.
    traj = plan(np.array([[0.0], [1.5], [3.0]]), '555', 'optimal', max_velocity=[1.0],
                max_acceleration=[4.0], speed_profile='time_optimal')
    assert traj.duration < 1.05 * bang_bang(3.0, 1.0, 4.0)


def test_a_moving_end_keeps_the_velocity_bound_for_its_joint():
    waypoints = np.array([[0.0, 0.0], [0.05, 0.05], [0.1, 0.1]])
    limits = {'max_velocity': [2.0, 2.0], 'max_acceleration': [5.0, 5.0]}
    resting = plan(waypoints, '555', 'uniform', **limits)
    moving = plan(waypoints, '555', 'uniform', end_velocity=[0.5, 0.5], **limits)
    assert math.isclose(resting.duration_lower_bound(), bang_bang(0.1, 2.0, 5.0))
    assert math.isclose(moving.duration_lower_bound(), 0.1 / 2.0)


def test_short_moves_are_not_warned_of_near_duplicates_are():
    limits = {'max_velocity': [2.0] * 3, 'max_acceleration': [5.0] * 3}
    short = plan(np.array([[0.0] * 3, [0.05] * 3, [0.1] * 3]), '445', 'uniform', **limits)
    assert slow_plan_warning(short) is None
    # The velocity-only bound (0.05 s) was below a twentieth of it, near the factor.
    assert short.duration > 6.0 * 0.1 / 2.0
    near = np.array([[0.0, 0.0, 0.0], [1e-5, 0.0, 0.0], [0.5, 1.0, -0.5], [1.0, 0.5, 0.0]])
    slow = plan(near, '445', 'uniform', waypoint_tolerance=0.0, **limits)
    assert slow.duration > SLOW_PLAN_FACTOR * slow.duration_lower_bound()
    assert 'times the lower bound' in slow_plan_warning(slow)
