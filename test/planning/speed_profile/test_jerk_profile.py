"""The third-order profile (issue 38): every limit held on the grid, by formulas of its own."""

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from splines445_ros.planning import plan
from splines445_ros.planning.constraints import (GriddedPath, JointAcceleration, JointJerk,
                                                 JointVelocity)
from splines445_ros.planning.path_following.inner_knots import plan_with_inner_knots
from splines445_ros.planning.speed_profile.jerk_profile import ThirdOrderProfile
from splines445_ros.planning.speed_profile.path_velocity import PathLimits
from splines445_ros.planning.spline.limits import JointLimits

RTOL = 1e-6


def random_path(seed):
    """Return a natural cubic path through random waypoints, a grid of 16 steps per segment."""
    rng = np.random.default_rng(seed)
    n_joints, n_points = int(rng.integers(1, 5)), int(rng.integers(2, 7))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    knots = np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 2.0, n_points - 1))])
    spline = CubicSpline(knots, points, bc_type='natural')
    s = np.linspace(0.0, knots[-1], 16 * (n_points - 1) + 1)
    v, a = rng.uniform(1.0, 3.0, n_joints), rng.uniform(5.0, 15.0, n_joints)
    j = rng.uniform(5.0, 30.0) * a
    return spline, s, v, a, j


def grid_figures(spline, s, x):
    """Velocity, acceleration (at both ends of every step) and jerk of ``x``, from the spline."""
    ds = np.diff(s)
    u = (x[1:] - x[:-1]) / (2.0 * ds)
    d1, d2, d3 = spline(s, 1), spline(s, 2), spline(s, 3)
    velocity = np.sqrt(x)[:, None] * np.abs(d1)
    acceleration = np.concatenate([d1[:-1] * u[:, None] + d2[:-1] * x[:-1, None],
                                   d1[1:] * u[:, None] + d2[1:] * x[1:, None]])
    mean_u = 0.5 * (u[:-1] + u[1:])
    du_ds = (u[1:] - u[:-1]) / (0.5 * (ds[:-1] + ds[1:]))
    inner = slice(1, -1)
    jerk = np.sqrt(x[inner])[:, None] * (d3[inner] * x[inner, None] + 3.0 * d2[inner]
                                         * mean_u[:, None] + d1[inner] * du_ds[:, None])
    return velocity, np.abs(acceleration), np.abs(jerk)


def third_order(spline, s, v, a, j, scale=None):
    """Return the second-order fastest profile and the third-order one (ThirdOrderProfile)."""
    path = GriddedPath(s, spline(s), spline(s, 1), spline(s, 2), spline(s, 3))
    scale = np.ones(s.size) if scale is None else scale
    fastest = PathLimits(path, (JointVelocity(v), JointAcceleration(a))).profile(scale)
    profile = ThirdOrderProfile(path, (JointAcceleration(a), JointJerk(j)))
    return fastest, profile.profile(scale, fastest)


@settings(max_examples=examples(20))
@given(st.integers(0, 2**32 - 1))
def test_the_profile_holds_velocity_acceleration_and_jerk_on_the_grid(seed):
    spline, s, v, a, j = random_path(seed)
    fastest, x = third_order(spline, s, v, a, j)
    assert x is not None
    assert x[0] == 0.0 and x[-1] == 0.0
    assert np.all(x <= fastest * (1 + RTOL) + 1e-12)
    velocity, acceleration, jerk = grid_figures(spline, s, x)
    assert np.all(velocity <= v * (1 + RTOL) + 1e-9)
    assert np.all(acceleration <= a * (1 + RTOL) + 1e-9)
    assert np.all(jerk <= j * (1 + RTOL) + 1e-9)
    # Not timid: it moves wherever the fastest profile does (that one stops
    # where the path has a cusp), and no uniform speed-up keeps every limit
    # (sped up by f, the ratios grow as f, f**2 and f**3).
    assert np.all(x[1:-1][fastest[1:-1] > 0.0] > 0.0)
    factor = max(np.max(velocity / v), np.max(acceleration / a) ** 0.5,
                 np.max(jerk / j) ** (1 / 3))
    assert factor > 0.99


def test_the_jerk_costs_time_and_a_looser_jerk_costs_less():
    """The second-order profile is faster; a ten times larger jerk limit comes closer to it."""
    spline, s, v, a, j = random_path(7)

    def traversal(x):
        return float(np.sum(2.0 * np.diff(s) / (np.sqrt(x[1:]) + np.sqrt(x[:-1]))))

    fastest, tight = third_order(spline, s, v, a, j)
    _, loose = third_order(spline, s, v, a, 10.0 * j)
    assert traversal(fastest) < traversal(loose) < traversal(tight)


def test_a_local_factor_scales_the_limits_it_holds():
    """With factor 1/2 on the grid the profile holds v / 2, a / 4 and j / 8."""
    spline, s, v, a, j = random_path(11)
    _, x = third_order(spline, s, v, a, j, scale=np.full(s.size, 0.5))
    velocity, acceleration, jerk = grid_figures(spline, s, x)
    assert np.all(velocity <= v / 2 * (1 + RTOL) + 1e-9)
    assert np.all(acceleration <= a / 4 * (1 + RTOL) + 1e-9)
    assert np.all(jerk <= j / 8 * (1 + RTOL) + 1e-9)


@pytest.mark.parametrize('seed', [1, 2])
def test_the_inner_knot_spline_on_it_meets_every_limit_exactly(seed):
    """plan_with_inner_knots(third_order=True): a C4 plan through the waypoints, exact limits."""
    rng = np.random.default_rng(seed)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (8, 3)), axis=0)
    v, a = rng.uniform(1.0, 3.0, 3), rng.uniform(5.0, 15.0, 3)
    limits = JointLimits.from_user(3, v, a, 20.0 * a)
    zero = np.zeros(3)
    traj = plan_with_inner_knots(points, (zero,) * 4, limits, 8, windows=(0.1, 0.05),
                                 third_order=True)
    assert traj is not None
    assert np.allclose(traj.evaluate(traj.waypoint_times), points, atol=1e-9)
    assert traj.within_limits(rtol=1e-9)
    # Dense samples agree with the exact peaks the check above used.
    t = np.linspace(0.0, traj.duration, 20001)
    for derivative, bound in ((1, v), (2, a), (3, 20.0 * a)):
        assert np.all(np.abs(traj.evaluate(t, derivative)) <= bound * (1 + 1e-6))
    # The default plan with these windows is a second-order profile's: no faster.
    default = plan(points, method='555', timing='optimal', max_velocity=v,
                   max_acceleration=a, max_jerk=20.0 * a)
    assert traj.duration <= default.duration * 1.05
