"""
Free inner knots for 555 optimal timing (issue 17): properties on random requests.

Every property is checked against something the implementation does not
compute itself: dense samples of the PPoly, peaks from ``numpy.roots``
(``reference_spline.exact_peaks``), derivatives of the pieces taken by
``numpy.polynomial``, and ``scipy.interpolate.make_interp_spline(k=5)``
through all knots (the unique C4 quintic spline with those knot values and
boundary derivatives).
"""

from hypothesis import assume, given, settings, strategies as st
import numpy as np
from numpy.polynomial import polynomial as P
import pytest
from reference_spline import exact_peaks
from scipy.interpolate import make_interp_spline
from splines445_ros.planning import plan
from splines445_ros.planning.inner_knots import (
    insert_knots, quintic_coefficients, split_durations,
)


@st.composite
def rest_to_rest_requests(draw):
    """2 to 7 waypoints, 1 to 3 joints, random v/a, jerk limit none, 20 a or 5 a."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_points = draw(st.integers(2, 7))
    n_joints = draw(st.integers(1, 3))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    assume(np.all(np.linalg.norm(np.diff(points, axis=0), axis=1) > 0.05))
    vmax = rng.uniform(0.5, 3.0, n_joints)
    amax = rng.uniform(2.0, 20.0, n_joints)
    jerk_ratio = draw(st.sampled_from([None, 20.0, 5.0]))
    jmax = None if jerk_ratio is None else jerk_ratio * amax
    n_inner = draw(st.integers(1, 3))
    return points, vmax, amax, jmax, n_inner


def limits(vmax, amax, jmax):
    return {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': jmax}


def dense_times(traj, per_piece=40):
    x = traj.breakpoints
    u = np.linspace(0.0, 1.0, per_piece, endpoint=False)
    return np.append((x[:-1, None] + np.diff(x)[:, None] * u[None, :]).ravel(), x[-1])


def check_limits(traj, vmax, amax, jmax):
    """Dense samples and numpy.roots peaks, jerk included, within 1e-9 of the limits."""
    t = dense_times(traj)
    for q, bound in enumerate((vmax, amax, jmax)):
        if bound is None:
            continue
        sampled = np.max(np.abs(traj.ppoly(t, nu=q + 1)), axis=0)
        assert np.all(sampled <= bound * (1 + 1e-9)), (q, sampled / bound)
        peaks = exact_peaks(traj.ppoly, q + 1).max(axis=0)
        assert np.all(peaks <= bound * (1 + 1e-9)), (q, peaks / bound)


def check_waypoints(traj, points):
    """Each waypoint is passed at its waypoint time; the waypoint times are knots."""
    assert traj.waypoint_times.shape == (len(points),)
    assert traj.waypoint_times[0] == 0.0
    assert traj.waypoint_times[-1] == pytest.approx(traj.duration, rel=1e-12)
    assert np.all(np.diff(traj.waypoint_times) > 0.0)
    assert np.all(np.isin(traj.waypoint_times, traj.breakpoints))
    scale = max(1.0, float(np.max(np.abs(points))))
    assert np.max(np.abs(traj.ppoly(traj.waypoint_times) - points)) <= 1e-9 * scale


def check_c4(traj):
    """Check that derivatives 0 to 4 of consecutive pieces agree at every interior knot."""
    c = traj.ppoly.c                       # descending powers (6, P, n)
    h = np.diff(traj.breakpoints)
    for i in range(h.size - 1):
        for j in range(c.shape[2]):
            left = c[::-1, i, j]
            right = c[::-1, i + 1, j]
            for d in range(5):
                end = P.polyval(h[i], P.polyder(left, d)) if d else P.polyval(h[i], left)
                start = P.polyder(right, d)[0] if d else right[0]
                size = max(1.0, abs(end), abs(start))
                assert abs(end - start) <= 1e-7 * size, (i, j, d, end, start)


def check_rest_to_rest(traj):
    ends = np.array([0.0, traj.duration])
    for d in (1, 2):
        assert np.max(np.abs(traj.ppoly(ends, nu=d))) <= 1e-9


def check_against_make_interp_spline(traj):
    """Our PPoly is the unique C4 quintic through its knot values with zero end v and a."""
    x = traj.breakpoints
    values = traj.ppoly(x)
    zeros = np.zeros(values.shape[1])
    reference = make_interp_spline(x, values, k=5,
                                   bc_type=([(1, zeros), (2, zeros)], [(1, zeros), (2, zeros)]))
    t = dense_times(traj, 7)
    scale = max(1.0, float(np.max(np.abs(values))))
    for d in range(4):
        ours, theirs = traj.ppoly(t, nu=d), reference(t, nu=d)
        assert np.max(np.abs(ours - theirs)) <= 1e-6 * scale * max(
            1.0, float(np.max(np.abs(theirs)))), d


@settings(max_examples=20)
@given(req=rest_to_rest_requests())
def test_inner_knots_hold_limits_hit_waypoints_are_c4_and_not_longer(req):
    points, vmax, amax, jmax, n_inner = req
    knots_only = plan(points, '555', 'optimal', **limits(vmax, amax, jmax))
    traj = plan(points, '555', 'optimal', inner_knots=n_inner, **limits(vmax, amax, jmax))
    assert traj.duration <= knots_only.duration
    check_limits(traj, vmax, amax, jmax)
    check_waypoints(traj, points)
    check_rest_to_rest(traj)
    check_c4(traj)
    check_against_make_interp_spline(traj)
    assert traj.optimizer['inner_knots'] in (0, n_inner)
    if traj.optimizer['inner_knots']:
        assert traj.breakpoints.size == (len(points) - 1) * (n_inner + 1) + 1
        # Inner knots are free: the refinement changed the shape, not just the timing.
        assert traj.duration < knots_only.duration


def test_inner_knots_shorten_a_typical_request_a_lot():
    """20 waypoints, 3 joints: inner knots gain more than 10 % over knots only."""
    rng = np.random.default_rng(7)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (20, 3)), axis=0)
    kwargs = limits(np.full(3, 2.0), np.full(3, 10.0), np.full(3, 200.0))
    knots_only = plan(points, '555', 'optimal', **kwargs)
    traj = plan(points, '555', 'optimal', inner_knots=2, **kwargs)
    assert traj.duration < 0.9 * knots_only.duration
    check_limits(traj, *kwargs.values())
    check_waypoints(traj, points)
    # One limit binds (the exact restoration stops at the limits).
    assert np.max(traj.limit_ratios()) == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize('n_inner', [1, 2, 4])
def test_warm_start_with_inserted_knots_is_the_same_spline(n_inner):
    rng = np.random.default_rng(n_inner)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (9, 3)), axis=0)
    traj = plan(points, '555', 'optimal', max_velocity=[1.0, 2.0, 3.0],
                max_acceleration=[5.0, 10.0, 8.0], max_jerk=[100.0, 200.0, 80.0])
    pieces, waypoint_knots = split_durations(traj.durations, n_inner)
    assert np.allclose(np.cumsum(pieces)[waypoint_knots[1:] - 1], traj.breakpoints[1:])
    states = insert_knots(traj, pieces)
    coeffs = quintic_coefficients(pieces, *states)
    knots = np.concatenate([[0.0], np.cumsum(pieces)])
    t = np.linspace(0.0, traj.duration, 1001)
    piece = np.clip(np.searchsorted(knots, t, side='right') - 1, 0, pieces.size - 1)
    tau = t - knots[piece]
    for d in range(4):
        ours = np.stack([P.polyval(tau[k], P.polyder(coeffs[piece[k]], d))
                         for k in range(t.size)])
        expected = traj.evaluate(t, d)
        scale = max(1.0, float(np.max(np.abs(expected))))
        assert np.max(np.abs(ours - expected)) <= 1e-9 * scale, d


def test_a_joint_that_does_not_move_does_not_stop_the_refinement():
    rng = np.random.default_rng(5)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (6, 3)), axis=0)
    points[:, 1] = 0.7
    kwargs = limits(np.full(3, 2.0), np.full(3, 10.0), np.full(3, 100.0))
    traj = plan(points, '555', 'optimal', inner_knots=2, **kwargs)
    assert traj.optimizer['inner_knots'] == 2
    assert np.max(np.abs(traj.ppoly(dense_times(traj))[:, 1] - 0.7)) <= 1e-9
    check_limits(traj, *kwargs.values())
    check_waypoints(traj, points)


def test_zero_inner_knots_is_todays_plan():
    rng = np.random.default_rng(3)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (8, 2)), axis=0)
    kwargs = limits(np.full(2, 2.0), np.full(2, 10.0), None)
    today = plan(points, '555', 'optimal', **kwargs)
    zero = plan(points, '555', 'optimal', inner_knots=0, **kwargs)
    assert np.array_equal(today.breakpoints, zero.breakpoints)
    assert np.array_equal(zero.waypoint_times, zero.breakpoints)


def test_boundary_values_fall_back_to_knots_only():
    rng = np.random.default_rng(4)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (6, 2)), axis=0)
    kwargs = limits(np.full(2, 2.0), np.full(2, 10.0), None)
    traj = plan(points, '555', 'optimal', inner_knots=2, start_velocity=[0.5, -0.5], **kwargs)
    assert traj.optimizer['inner_knots'] == 0
    assert traj.breakpoints.size == len(points)
    check_waypoints(traj, points)


@pytest.mark.parametrize('kwargs, message', [
    ({'method': '445', 'timing': 'optimal', 'inner_knots': 2}, 'needs method "555"'),
    ({'method': '555', 'timing': 'uniform', 'inner_knots': 1}, 'needs method "555"'),
    ({'method': '555', 'timing': 'optimal', 'inner_knots': -1}, 'between 0 and'),
    ({'method': '555', 'timing': 'optimal', 'inner_knots': 99}, 'between 0 and'),
    ({'method': '555', 'timing': 'optimal', 'inner_knots': 1.5}, 'must be an integer'),
    ({'method': '555', 'timing': 'optimal', 'inner_knots': True}, 'must be an integer'),
])
def test_bad_inner_knots_are_rejected(kwargs, message):
    with pytest.raises(ValueError, match=message):
        plan([[0.0], [1.0], [0.5]], max_velocity=[1.0], max_acceleration=[1.0], **kwargs)


def test_joint_threads_do_not_change_the_result(monkeypatch):
    """The joints' LPs solved in threads give the same spline, bit for bit, as one by one."""
    from splines445_ros.planning import inner_knots
    rng = np.random.default_rng(12)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (9, 4)), axis=0)
    kwargs = limits(np.full(4, 2.0), np.full(4, 10.0), np.full(4, 200.0))
    monkeypatch.setattr(inner_knots, 'JOINT_THREADS', 4)
    threaded = plan(points, '555', 'optimal', inner_knots=2, **kwargs)
    monkeypatch.setattr(inner_knots, 'JOINT_THREADS', 1)
    serial = plan(points, '555', 'optimal', inner_knots=2, **kwargs)
    assert threaded.optimizer['inner_knots'] == 2
    assert np.array_equal(threaded.breakpoints, serial.breakpoints)
    assert np.array_equal(threaded.ppoly.c, serial.ppoly.c)
