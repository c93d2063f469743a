"""Properties of planned trajectories on many random requests (hypothesis)."""

from hypothesis import assume, given, strategies as st
import numpy as np
import pytest
from reference_spline import CONTINUOUS, exact_peaks, global_coefficients, random_limits
from splines445_ros.planning import plan
from splines445_ros.planning.planner import DEFAULT_WAYPOINT_TOLERANCE

METHODS = ['445', '434', '555']
coordinate = st.floats(-3.0, 3.0, allow_nan=False)


@st.composite
def requests(draw, max_points=10, boundary_scale=1.0):
    """Random waypoints (N, n), durations and boundary values."""
    n_points = draw(st.integers(2, max_points))
    n_joints = draw(st.integers(1, 4))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    durations = rng.uniform(0.2, 3.0, n_points - 1)
    boundary = [boundary_scale * rng.uniform(-1.0, 1.0, n_joints) for _ in range(4)]
    return points, durations, boundary


def knot_values(ppoly, derivative):
    """Left and right limits of a derivative at the interior knots: two (N-2, n)."""
    d = ppoly.derivative(derivative)
    S = d.c.shape[1]
    T = np.diff(ppoly.x)
    left = np.array([[np.polyval(d.c[:, s, j], T[s]) for j in range(d.c.shape[2])]
                     for s in range(S - 1)])
    right = d.c[-1, 1:, :]
    return left, right


def fixed_plan(method, req):
    """Plan a drawn request with its own durations and boundary values."""
    points, durations, (v0, a0, ve, ae) = req
    traj = plan(points, method, 'fixed', durations=durations, start_velocity=v0,
                start_acceleration=a0, end_velocity=ve, end_acceleration=ae)
    return traj, points, durations, (v0, a0, ve, ae)


def scale_of(values):
    return max(1.0, float(np.max(np.abs(values))))


@pytest.mark.parametrize('method', METHODS)
@given(req=requests())
def test_fixed_timing_interpolates_meets_boundary_and_is_continuous(method, req):
    traj, points, durations, (v0, a0, ve, ae) = fixed_plan(method, req)
    assert traj.breakpoints[0] == 0.0
    np.testing.assert_allclose(np.diff(traj.breakpoints), durations, rtol=1e-12)
    tol = 1e-9 * scale_of(points)
    np.testing.assert_allclose(traj.evaluate(traj.breakpoints), points, atol=tol)
    end = traj.duration
    for t, v, a in ((0.0, v0, a0), (end, ve, ae)):
        np.testing.assert_allclose(traj.evaluate([t], 1)[0], v, atol=1e-7 * scale_of(v))
        np.testing.assert_allclose(traj.evaluate([t], 2)[0], a, atol=1e-7 * scale_of(a))
    if len(points) > 2:
        for derivative in CONTINUOUS[method]:
            left, right = knot_values(traj.ppoly, derivative)
            np.testing.assert_allclose(left, right, rtol=1e-7, atol=1e-7 * scale_of(left))


@given(req=requests(max_points=8))
def test_434_jerk_jumps_where_445_does_not(req):
    points, durations, boundary = req
    assume(len(points) >= 3)
    t434 = plan(points, '434', 'fixed', durations=durations)
    left, right = knot_values(t434.ppoly, 3)
    # Not a property of every request, but the generic case: with random data the
    # 434 jerk is discontinuous somewhere; exactly equal jerks would mean the
    # baseline silently became 445.
    assert np.max(np.abs(left - right)) > 1e-9


@pytest.mark.parametrize('method', METHODS)
@given(req=requests(max_points=7))
def test_banded_solution_matches_dense_global_system(method, req):
    traj, points, durations, (v0, a0, ve, ae) = fixed_plan(method, req)
    for j in range(points.shape[1]):
        ref = global_coefficients(method, points[:, j], durations, v0[j], a0[j], ve[j], ae[j])
        got = traj.ppoly.c[::-1, :, j].T  # ascending (S, 6)
        np.testing.assert_allclose(got, ref, rtol=1e-7, atol=1e-7 * scale_of(ref))


@st.composite
def limited_requests(draw, boundary_fraction=0.0):
    points, _, _ = draw(requests(max_points=9))
    n = points.shape[1]
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    return (points,) + random_limits(rng, n, boundary_fraction)


def assume_distinct(points):
    # plan() merges waypoints within its default tolerance on every joint.
    steps = np.max(np.abs(np.diff(points, axis=0)), axis=1)
    assume(np.all(steps > 2.0 * DEFAULT_WAYPOINT_TOLERANCE))


def check_limits_hold_and_one_binds(traj, vmax, amax, jmax):
    limits = [vmax, amax, jmax]
    ratios = []
    for q, lim in enumerate(limits):
        if lim is None:
            continue
        peaks = exact_peaks(traj.ppoly, q + 1).max(axis=0)
        assert np.all(peaks <= lim * (1.0 + 1e-7)), (q, peaks, lim)
        ratios.append(np.max(peaks / lim))
    assert max(ratios) >= 1.0 - 1e-6, ratios
    binding = traj.binding
    assert binding.ratio == pytest.approx(max(ratios), rel=1e-6)


@pytest.mark.parametrize('method', METHODS)
@given(req=limited_requests())
def test_uniform_rest_to_rest_meets_limits_and_one_binds(method, req):
    points, vmax, amax, jmax, _ = req
    assume_distinct(points)
    traj = plan(points, method, 'uniform', max_velocity=vmax, max_acceleration=amax,
                max_jerk=jmax)
    check_limits_hold_and_one_binds(traj, vmax, amax, jmax)
    np.testing.assert_allclose(traj.evaluate(traj.breakpoints), points,
                               atol=1e-9 * scale_of(points))
    # Uniform timing keeps the chord-length proportions of eq. (11).
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    np.testing.assert_allclose(traj.durations / chords, traj.scale, rtol=1e-9)


@pytest.mark.parametrize('method', METHODS)
@given(req=limited_requests(boundary_fraction=0.9))
def test_uniform_with_boundary_values_meets_limits_and_boundary(method, req):
    points, vmax, amax, jmax, (v0, a0, ve, ae) = req
    assume_distinct(points)
    try:
        traj = plan(points, method, 'uniform', max_velocity=vmax, max_acceleration=amax,
                    max_jerk=jmax, start_velocity=v0, start_acceleration=a0,
                    end_velocity=ve, end_acceleration=ae)
    except ValueError as exc:
        # Some boundary values admit no common scale factor; that must be said.
        assert 'infeasible' in str(exc)
        return
    check_limits_hold_and_one_binds(traj, vmax, amax, jmax)
    np.testing.assert_allclose(traj.evaluate([0.0], 1)[0], v0, atol=1e-7)
    np.testing.assert_allclose(traj.evaluate([traj.duration], 2)[0], ae, atol=1e-6)


@pytest.mark.parametrize('method', METHODS)
@given(req=requests(max_points=8))
def test_core_peaks_match_independent_root_finding(method, req):
    traj, points, durations, (v0, a0, ve, ae) = fixed_plan(method, req)
    for d in (1, 2, 3):
        ref = exact_peaks(traj.ppoly, d)
        np.testing.assert_allclose(traj.segment_peaks(d), ref, rtol=1e-8,
                                   atol=1e-9 * scale_of(ref))


@given(req=requests(max_points=6), period=st.floats(0.001, 0.5))
def test_sampling_is_increasing_and_ends_exactly_on_last_waypoint(req, period):
    points, durations, _ = req
    traj = plan(points, '445', 'fixed', durations=durations)
    samples = traj.sample(period)
    assert samples.times[0] == 0.0
    assert samples.times[-1] == traj.duration
    assert np.all(np.diff(samples.times) > 0.0)
    assert np.all(np.diff(samples.times) < 2.0 * period * (1 + 1e-9))
    np.testing.assert_array_equal(samples.positions[-1], points[-1])
    np.testing.assert_allclose(samples.positions, traj.evaluate(samples.times),
                               atol=1e-12 * scale_of(points) * 100)


@given(req=requests(max_points=6), period=st.floats(0.001, 5.0))
def test_samples_pass_every_waypoint_at_its_time_however_coarse(req, period):
    # The published points must pass every waypoint: a controller
    # interpolating them would skip one that falls between two samples.
    points, durations, _ = req
    traj = plan(points, '445', 'fixed', durations=durations)
    samples = traj.sample(period)
    passed = np.concatenate([[0.0], np.cumsum(durations)])
    # Independently: the multiples of the period at least half a period from
    # every waypoint time (and before the end), plus the waypoint times.
    regular = [k * period for k in range(int(traj.duration / period) + 1)
               if k * period < traj.duration
               and min(abs(k * period - t) for t in traj.waypoint_times) >= 0.5 * period]
    np.testing.assert_allclose(samples.times, np.sort(np.concatenate([regular, passed])),
                               rtol=0, atol=1e-9 * max(1.0, traj.duration))
    for k, t in enumerate(traj.waypoint_times):
        index = np.flatnonzero(samples.times == t)
        assert index.size == 1
        np.testing.assert_array_equal(samples.positions[index[0]], points[k])
    # A regular sample dropped next to each of two waypoints: up to 2 periods.
    assert np.all(np.diff(samples.times) < 2.0 * period * (1 + 1e-9))


def test_waypoints_closer_than_the_resolution_give_one_sample():
    # Two waypoints 0.1 ns apart round to one nanosecond in a message: one of
    # them is dropped, so the published times stay strictly increasing.
    points = np.array([[0.0], [1.0], [1.0 + 1e-10], [2.0]])
    traj = plan(points, '445', 'uniform', max_velocity=[100.0], max_acceleration=[1e4],
                max_jerk=[1e6], waypoint_tolerance=0.0)
    assert np.min(np.diff(traj.waypoint_times)) < 1e-9
    samples = traj.sample(0.01, resolution=1e-9)
    ticks = np.round(samples.times / 1e-9)
    assert np.all(np.diff(ticks) > 0) and abs(samples.times[-1] - traj.duration) <= 0.5e-9
    for t, q in zip(traj.waypoint_times, points):
        k = np.argmin(np.abs(samples.times - t))
        assert abs(samples.times[k] - t) < 1e-9
        np.testing.assert_allclose(samples.positions[k], q, atol=1e-9)
    assert len(samples.times) == len(traj.sample(0.01).times) - 1
