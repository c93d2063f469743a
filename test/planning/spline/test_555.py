"""
The 555 method (C4 quintic spline) against independent routes and its defining properties.

* scipy's ``make_interp_spline(x, y, k=5, bc_type=...)`` builds the same
  spline (degree 5, knots at the waypoints, C4, first and second derivative
  given at both ends) by B-spline collocation, a route that shares nothing
  with the Hermite-form banded system of the planning core.
* Properties on random requests (hypothesis): C4 at every interior knot,
  waypoints, boundary values, limits hold and one binds, optimal timing
  feasible and not longer than uniform.
* Stability: a displaced waypoint's effect decays along a 555 spline (odd
  degree), but not along a 445 spline (the -1 root of even degree).
"""

from example_counts import examples
from hypothesis import assume, given, settings, strategies as st
import numpy as np
import pytest
from reference_spline import exact_peaks, random_limits
from scipy.interpolate import make_interp_spline
from splines445_ros.planning import get_method, METHODS, plan
from test_planning_properties import assume_distinct, check_uniform_refusal


@st.composite
def requests(draw, max_points=12):
    """Random waypoints (N, n), durations and boundary values."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_points = draw(st.integers(2, max_points))
    n_joints = draw(st.integers(1, 4))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    durations = rng.uniform(0.2, 3.0, n_points - 1)
    boundary = [rng.uniform(-1.0, 1.0, n_joints) for _ in range(4)]
    return points, durations, boundary


def scale_of(values):
    return max(1.0, float(np.max(np.abs(values))))


def plan_fixed(points, durations, boundary):
    v0, a0, ve, ae = boundary
    return plan(points, '555', 'fixed', durations=durations, start_velocity=v0,
                start_acceleration=a0, end_velocity=ve, end_acceleration=ae)


def test_555_is_a_method_and_integer_555_is_accepted():
    assert '555' in METHODS
    definition = get_method(555)
    assert definition.name == '555'
    assert definition.continuous == (3, 4)   # jerk and snap equations; v, a are unknowns
    points = np.array([[0.0, 1.0], [1.0, -1.0], [2.5, 0.0], [3.0, 2.0]])
    a = plan(points, 555, 'fixed', durations=[1.0, 0.5, 2.0])
    b = plan(points, '555', 'fixed', durations=[1.0, 0.5, 2.0])
    assert a.method == b.method == '555'
    np.testing.assert_array_equal(a.ppoly.c, b.ppoly.c)


@given(req=requests())
def test_555_equals_scipy_quintic_interpolating_spline(req):
    points, durations, boundary = req
    assume(len(points) >= 3)  # scipy needs more waypoints than boundary conditions per end
    traj = plan_fixed(points, durations, boundary)
    v0, a0, ve, ae = boundary
    x = np.concatenate([[0.0], np.cumsum(durations)])
    times = np.concatenate([np.linspace(0.0, x[-1], 301), x])
    for j in range(points.shape[1]):
        ref = make_interp_spline(x, points[:, j], k=5,
                                 bc_type=([(1, v0[j]), (2, a0[j])], [(1, ve[j]), (2, ae[j])]))
        for d in range(5):
            expected = ref(times, d)
            got = traj.ppoly(times, d)[:, j]
            np.testing.assert_allclose(got, expected, rtol=1e-6,
                                       atol=1e-7 * scale_of(expected), err_msg=f'derivative {d}')


def _knot_sides(ppoly, derivative):
    d = ppoly.derivative(derivative)
    T = np.diff(ppoly.x)[:-1]
    left = np.zeros_like(d.c[0, :-1])
    for row in d.c[:, :-1]:
        left = left * T[:, None] + row
    return left, d.c[-1, 1:]


def knot_jump_array(ppoly, derivative):
    """|jump| of a derivative at every interior knot and joint: (N-2, n)."""
    left, right = _knot_sides(ppoly, derivative)
    return np.abs(right - left)


def knot_jumps(ppoly, derivative):
    """Largest |jump| of a derivative across the interior knots and its scale."""
    left, right = _knot_sides(ppoly, derivative)
    return np.max(np.abs(right - left)), scale_of(np.concatenate([left, right]))


# Bounds on the absolute contributions of a quintic's end conditions to its jerk
# and snap at either end (from the Hermite quintic, eqs. 20-22: e.g. snap at
# tau = T is (360 dP - 168 v0 T - 192 v1 T - 24 a0 T^2 + 36 a1 T^2) / T^4).
_TERM_BOUNDS = {3: (60.0, 36.0, 9.0), 4: (360.0, 192.0, 36.0)}


def cancellation_scale(ppoly, derivative):
    """
    Per interior knot, the size of the terms that are summed into the derivative there.

    A backward-stable solve leaves a continuity residual of a few machine
    epsilons times this sum of absolute contributions (|B| |u|), not times the
    derivative's value: on a segment hundreds of times shorter than its
    neighbours (optimal timing does that near close waypoints) the terms
    ``dP / T^4`` are large and cancel.  A wrong or missing equation leaves a
    jump of the order of the derivative itself.
    """
    x = ppoly.x
    T = np.diff(x)
    vel = np.abs(ppoly(x, 1))
    acc = np.abs(ppoly(x, 2))
    dp_c, v_c, a_c = _TERM_BOUNDS[derivative]
    per_segment = ((dp_c * np.abs(np.diff(ppoly(x), axis=0))
                    + v_c * (vel[:-1] + vel[1:]) * T[:, None]
                    + a_c * (acc[:-1] + acc[1:]) * T[:, None] ** 2)
                   / T[:, None] ** derivative)
    return per_segment[:-1] + per_segment[1:]


@given(req=requests())
def test_fixed_555_is_c4_through_waypoints_with_boundary_values(req):
    points, durations, boundary = req
    traj = plan_fixed(points, durations, boundary)
    v0, a0, ve, ae = boundary
    np.testing.assert_allclose(traj.ppoly(traj.breakpoints), points,
                               atol=1e-9 * scale_of(points))
    for t, v, a in ((0.0, v0, a0), (traj.duration, ve, ae)):
        np.testing.assert_allclose(traj.ppoly(t, 1), v, atol=1e-8 * scale_of(v))
        np.testing.assert_allclose(traj.ppoly(t, 2), a, atol=1e-8 * scale_of(a))
    if len(points) > 2:
        for d in (1, 2, 3, 4):
            jump, scale = knot_jumps(traj.ppoly, d)
            assert jump <= 1e-8 * scale, (d, jump, scale)
        # The fifth derivative is not made continuous: generically it jumps.
        jump, scale = knot_jumps(traj.ppoly, 5)
        assert jump > 1e-6 * scale


@given(req=requests(max_points=10))
def test_555_is_time_symmetric(req):
    """Reversing the waypoints (and the boundary velocities) reverses the trajectory."""
    points, durations, (v0, a0, ve, ae) = req
    forward = plan_fixed(points, durations, (v0, a0, ve, ae))
    backward = plan_fixed(points[::-1], durations[::-1], (-ve, ae, -v0, a0))
    t = np.linspace(0.0, forward.duration, 97)
    np.testing.assert_allclose(backward.ppoly(forward.duration - t), forward.ppoly(t),
                               atol=1e-8 * scale_of(points))


@st.composite
def limited_requests(draw, boundary_fraction):
    """Random waypoints, limits (jerk sometimes) and boundary values up to a fraction of them."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_points = draw(st.integers(2, 12))
    n_joints = draw(st.integers(1, 4))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    assume(np.all(np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-3))
    return (points,) + random_limits(rng, n_joints, boundary_fraction)


def peak_ratios(traj, vmax, amax, jmax):
    """Largest peak / limit per quantity, from numpy.roots on every segment."""
    return [float(np.max(exact_peaks(traj.ppoly, q + 1).max(axis=0) / lim))
            for q, lim in enumerate((vmax, amax, jmax)) if lim is not None]


def kwargs_of(vmax, amax, jmax, boundary):
    v0, a0, ve, ae = boundary
    return {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': jmax,
            'start_velocity': v0, 'start_acceleration': a0, 'end_velocity': ve,
            'end_acceleration': ae}


@pytest.mark.parametrize('fraction', [0.0, 0.5])
@given(data=st.data())
def test_uniform_555_meets_limits_one_binds_and_keeps_chord_proportions(fraction, data):
    points, vmax, amax, jmax, boundary = data.draw(limited_requests(fraction))
    assume_distinct(points)
    try:
        traj = plan(points, '555', 'uniform', **kwargs_of(vmax, amax, jmax, boundary))
    except ValueError as exc:
        assert fraction > 0.0 and 'infeasible' in str(exc)
        # No common factor (nor documented first-segment share) meets the limits.
        check_uniform_refusal('555', points, (vmax, amax, jmax), boundary)
        return
    ratios = peak_ratios(traj, vmax, amax, jmax)
    assert max(ratios) <= 1.0 + 1e-7, ratios
    assert max(ratios) >= 1.0 - 1e-6, ratios
    np.testing.assert_allclose(traj.ppoly(traj.breakpoints), points, atol=1e-9 * scale_of(points))
    v0, a0, ve, ae = boundary
    for t, v, a in ((0.0, v0, a0), (traj.duration, ve, ae)):
        np.testing.assert_allclose(traj.ppoly(t, 1), v, atol=1e-8)
        np.testing.assert_allclose(traj.ppoly(t, 2), a, atol=1e-6)
    if fraction == 0.0:
        chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
        np.testing.assert_allclose(traj.durations / chords, traj.scale, rtol=1e-9)


@settings(max_examples=examples(20))
@given(data=st.data())
def test_optimal_555_is_feasible_c4_and_not_longer_than_uniform(data):
    fraction = data.draw(st.sampled_from([0.0, 0.5]))
    points, vmax, amax, jmax, boundary = data.draw(limited_requests(fraction))
    kwargs = kwargs_of(vmax, amax, jmax, boundary)
    try:
        uniform = plan(points, '555', 'uniform', **kwargs)
    except ValueError:
        uniform = None
    try:
        optimal = plan(points, '555', 'optimal', **kwargs)
    except ValueError as exc:
        assert uniform is None and 'infeasible' in str(exc)
        return
    if uniform is not None:
        assert optimal.duration <= uniform.duration * (1.0 + 1e-12)
    assert max(peak_ratios(optimal, vmax, amax, jmax)) <= 1.0 + 1e-7
    # Through every waypoint (with inner knots, the waypoints are some of the knots).
    np.testing.assert_allclose(optimal.ppoly(optimal.waypoint_times), points,
                               atol=1e-9 * scale_of(points))
    if len(points) > 2:
        for d in (1, 2):  # shared knot states: continuous up to evaluation round-off
            jump, scale = knot_jumps(optimal.ppoly, d)
            assert jump <= 1e-7 * scale, (d, jump, scale)
        for d in (3, 4):  # solved continuity equations: per knot, to the solve's round-off
            jumps = knot_jump_array(optimal.ppoly, d)
            bound = 1e-12 * cancellation_scale(optimal.ppoly, d)
            assert np.all(jumps <= bound), (d, jumps.max(), (jumps / bound).max())


def knot_velocity_response(method, n_points=60, displaced=10):
    """|knot velocity| of the spline through zeros with one waypoint displaced by 1."""
    points = np.zeros((n_points, 1))
    points[displaced] = 1.0
    traj = plan(points, method, 'fixed', durations=np.ones(n_points - 1))
    return np.abs(traj.ppoly(traj.breakpoints, 1)[:, 0])


def test_disturbance_decays_along_555_but_not_along_445():
    v555 = knot_velocity_response('555')
    v445 = knot_velocity_response('445')
    # Quintic spline: the knot recursion's roots are -0.43 and -0.043 (and
    # reciprocals), so 35 knots further down the effect is below 0.5^35.
    assert v555[45] < 1e-9 * v555[11]
    # Quartic (445): the root -1 carries the disturbance to the end undamped.
    assert v445[45] > 0.1 * v445[11]


def test_long_random_walk_555_uniform_is_not_slowed_by_oscillation():
    """On 300 waypoints 555 uniform is within 2x of 434, where 445 is many times slower."""
    rng = np.random.default_rng(555)
    points = np.cumsum(rng.uniform(-0.4, 0.4, (300, 7)), axis=0)
    limits = {'max_velocity': np.full(7, 2.0), 'max_acceleration': np.full(7, 10.0)}
    d555 = plan(points, '555', **limits).duration
    d434 = plan(points, '434', **limits).duration
    d445 = plan(points, '445', **limits).duration
    assert d555 < 2.0 * d434
    assert d445 > 3.0 * d555


def test_optimal_555_next_to_close_waypoints_is_c4_to_round_off():
    # Found by the property above: two waypoints 6 mrad apart make optimal
    # timing give that segment a duration ~500 times shorter than others.
    points = np.array([-0.51196843, -1.28453995, -1.29044559, -1.74194661, -2.3424049,
                       -2.77640104, -3.6539497, -3.69576152, -4.57960347, -3.64068808])[:, None]
    # (The durations optimiser's case: knots at the waypoints only.)
    traj = plan(points, '555', 'optimal', max_velocity=[2.8002313],
                max_acceleration=[6.55412069], max_jerk=[17.16598309], inner_knots=0)
    assert traj.durations.max() / traj.durations.min() > 100.0
    for d in (3, 4):
        jumps = knot_jump_array(traj.ppoly, d)
        assert np.all(jumps <= 1e-12 * cancellation_scale(traj.ppoly, d)), d


def test_uniform_timing_far_along_the_time_axis_is_stretched_back_to_its_limits():
    """
    A 1000-waypoint single-joint walk lasting about 4600 s, 555 uniform with a jerk limit.

    Solved again on the widths the PPoly can represent, the spline exceeded
    a limit by round-off; a stretch by that ratio (1 + 1e-15) moved no
    breakpoint so far along the time axis, and planning failed.
    """
    rng = np.random.default_rng(445)
    rng.uniform(-1.0, 1.0, (50, 1))
    rng.uniform(-1.0, 1.0, (200, 1))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (1000, 1)), axis=0)
    traj = plan(points, '555', 'uniform', max_velocity=[2.0], max_acceleration=[10.0],
                max_jerk=[200.0])
    assert traj.within_limits(rtol=0.0)
    assert np.allclose(traj.evaluate(traj.breakpoints), points, rtol=0.0, atol=1e-6)
