"""Exact position extremes: position limits, and the excursion beyond the waypoints."""

from hypothesis import given, strategies as st
import numpy as np
import pytest
from splines445_ros.planning import check_position_limits, plan


@st.composite
def random_plan(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n = draw(st.integers(1, 3))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (draw(st.integers(2, 7)), n)), axis=0)
    boundary = {}
    if draw(st.booleans()):
        boundary = {'start_velocity': rng.uniform(-0.3, 0.3, n),
                    'end_acceleration': rng.uniform(-1.0, 1.0, n)}
    return plan(points, draw(st.sampled_from(['445', '434', '555'])), 'uniform',
                max_velocity=np.full(n, 2.0), max_acceleration=np.full(n, 6.0), **boundary)


def dense_extremes(traj, count=40001):
    times = np.linspace(0.0, traj.duration, count)
    q = traj.evaluate(times)
    return q.min(axis=0), q.max(axis=0), times[q.argmin(axis=0)], times[q.argmax(axis=0)]


@given(random_plan())
def test_exact_extremes_agree_with_a_dense_sampling(traj):
    low, high, t_low, t_high = traj.position_extrema()
    d_low, d_high, _, _ = dense_extremes(traj)
    # Exact extremes bound the samples, and a sample lies within a*dt^2/8 of
    # an interior extreme (the velocity vanishes there).
    dt = traj.duration / 40000
    slack = 6.0 * dt * dt / 8.0 + 1e-12
    assert np.all(low <= d_low + 1e-12) and np.all(high >= d_high - 1e-12)
    assert np.all(low >= d_low - slack) and np.all(high <= d_high + slack)
    # The reported times are where those values are reached.
    joints = np.arange(traj.n_joints)
    np.testing.assert_allclose(traj.evaluate(t_low)[joints, joints], low, atol=1e-12)
    np.testing.assert_allclose(traj.evaluate(t_high)[joints, joints], high, atol=1e-12)
    excursion = traj.excursion()
    np.testing.assert_allclose(
        excursion, np.maximum.reduce([d_high - traj.waypoints.max(axis=0),
                                      traj.waypoints.min(axis=0) - d_low,
                                      np.zeros(traj.n_joints)]), atol=slack)


@given(random_plan(), st.data())
def test_position_limits_reject_exactly_the_plans_that_leave_them(traj, data):
    low, high, t_low, t_high = traj.position_extrema()
    j = data.draw(st.integers(0, traj.n_joints - 1))
    margin = 1e-6
    # Just outside the plan's range, and exactly at it: accepted.
    check_position_limits(traj, low - margin, high + margin)
    check_position_limits(traj, low, high)
    # A goal (or start) exactly on a limit is not "an ulp above" it.
    check_position_limits(traj, np.minimum(low, traj.waypoints[0]),
                          np.maximum(high, traj.waypoints[-1]))
    # Just inside on one side of one joint: rejected, naming joint, time and excess.
    upper = high + margin
    upper[j] = high[j] - margin
    with pytest.raises(ValueError, match=rf'joint {j} goes to .* at t = .* above '
                                         rf'max_position\[{j}\]') as error:
        check_position_limits(traj, None, upper)
    assert f't = {t_high[j]:.6g} s' in str(error.value)
    lower = np.full(traj.n_joints, -np.inf)
    lower[j] = low[j] + margin
    with pytest.raises(ValueError, match=rf'joint {j} .* below min_position\[{j}\]'):
        check_position_limits(traj, lower, None)


def test_plan_rejects_a_swing_beyond_the_position_limits():
    # Near-duplicates above the tolerance at a rest start make 555 uniform swing.
    points = np.array([[0.0, 0.0], [2e-3, -2e-3], [1.0, 0.5], [2.0, -0.5]])
    limits = {'max_velocity': [1.0, 1.0], 'max_acceleration': [3.0, 3.0]}
    free = plan(points, '555', 'uniform', **limits)
    assert np.max(free.excursion()) > 0.05  # the swing, beyond the waypoints' range
    with pytest.raises(ValueError, match='joint'):
        plan(points, '555', 'uniform', min_position=[-0.05, -0.55],
             max_position=[2.05, 0.55], **limits)
    # Limits around its whole swing admit it.
    low, high = free.position_extrema()[:2]
    plan(points, '555', 'uniform', min_position=low - 1e-9, max_position=high + 1e-9, **limits)


@pytest.mark.parametrize('vmax, amax', [(1.0, 3.0), (2.0, 10.0)])
def test_a_goal_exactly_on_a_limit_is_not_a_violation(vmax, amax):
    # Found in review: the polynomial evaluated at the segment's end landed
    # 8.9e-16 above the goal, and a goal on its joint range was rejected.
    points = np.array([[0.0, 0.0], [0.7, 1.3], [1.1, 3.1]])
    for timing in ('uniform', 'optimal'):
        traj = plan(points, '434', timing, max_velocity=[vmax] * 2,
                    max_acceleration=[amax] * 2, max_position=[1.1, 3.1])
        assert traj.position_extrema()[1][1] <= 3.1
