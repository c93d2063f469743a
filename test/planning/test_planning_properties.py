"""Properties of planned trajectories on many random requests (hypothesis)."""

from hypothesis import assume, given, strategies as st
import numpy as np
from numpy.polynomial import polynomial as P
import pytest
from reference_spline import CONTINUOUS, exact_peaks, global_coefficients, random_limits
from splines445_ros.planning import plan
from splines445_ros.planning.durations.timing import FIRST_SEGMENT_SHARES
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


def knot_jump_sizes(ppoly, derivative):
    """
    |right - left| of a derivative at every interior knot, per joint: (N-2, n), and a scale.

    From each segment's own polynomial (numpy.polynomial, ascending terms),
    not from the PPoly's derivative nor from the Trajectory; the scale is the
    largest |value| on either side (at least 1).
    """
    c = ppoly.c[::-1]  # ascending terms (order, S, n)
    T = np.diff(ppoly.x)
    S, n = c.shape[1:]
    left, right = np.zeros((max(S - 1, 0), n)), np.zeros((max(S - 1, 0), n))
    for s in range(S - 1):
        for j in range(n):
            left[s, j] = P.polyval(T[s], P.polyder(c[:, s, j], derivative))
            right[s, j] = P.polyval(0.0, P.polyder(c[:, s + 1, j], derivative))
    return np.abs(right - left), scale_of(np.concatenate([left, right, np.zeros((1, n))]))


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


QUANTITY_NAMES = ('velocity', 'acceleration', 'jerk')


def check_limits_hold_and_one_binds(traj, vmax, amax, jmax):
    limits = [vmax, amax, jmax]
    # Peak / limit per segment, joint and quantity (S, n, 3) from numpy.roots.
    ratios = np.zeros((traj.ppoly.c.shape[1], traj.ppoly.c.shape[2], 3))
    for q, lim in enumerate(limits):
        if lim is None:
            continue
        peaks = exact_peaks(traj.ppoly, q + 1)
        assert np.all(peaks.max(axis=0) <= lim * (1.0 + 1e-7)), (q, peaks, lim)
        ratios[..., q] = peaks / lim
    largest = float(np.max(ratios))
    assert largest >= 1.0 - 1e-6, largest
    binding = traj.binding
    assert binding.ratio == pytest.approx(largest, rel=1e-6)
    # Where one ratio is the largest by a clear margin, the binding limit names it.
    order = np.sort(ratios, axis=None)
    if order[-2] < largest * (1.0 - 1e-6):
        segment, joint, q = np.unravel_index(np.argmax(ratios), ratios.shape)
        assert (binding.segment, binding.joint, binding.quantity) == (
            segment, joint, QUANTITY_NAMES[q]), (binding, ratios)


# Confirming a refusal of uniform timing: the common factors tried (relative
# to the spline's own rest-to-rest factor), the points per segment at which
# the peaks are sampled, and the local minima of the largest ratio refined.
REFUSAL_FACTORS = np.geomspace(1e-3, 1e4, 250)
REFUSAL_SAMPLES = np.linspace(0.0, 1.0, 33)
REFUSAL_MINIMA = 4
REFUSAL_ZOOM_BELOW = 3.0
REFUSAL_ZOOM = 33


def _sampled_derivative(c, base, derivative):
    """d-th derivative of descending PPoly terms (6, S, n) at REFUSAL_SAMPLES: (S, n, M)."""
    order = c.shape[0]
    tau = REFUSAL_SAMPLES[None, :] * base[:, None]                    # (S, M)
    out = np.zeros(c.shape[1:] + (tau.shape[1],))
    for i in range(order - 1 - derivative, -1, -1):
        power = order - 1 - i
        falling = np.prod(np.arange(power - derivative + 1, power + 1))
        out += falling * c[i][:, :, None] * tau[:, None, :] ** (power - derivative)
    return out


class ScaledFixedPlans:
    """
    Fixed-timing plans for durations ``factor * base``, for many factors at once.

    A spline is linear in its waypoints and boundary values, and time-scaling
    the one for durations ``base`` with start and end values
    ``(factor * v, factor**2 * a)`` gives the one for ``factor * base`` with
    ``(v, a)``; so with P, V, A the fixed plans for ``base`` driven by the
    waypoints alone, by the boundary velocities alone and by the boundary
    accelerations alone, the plan for ``factor * base`` at ``t = factor * s``
    is ``P(s) + factor V(s) + factor**2 A(s)``, its d-th derivative that
    divided by ``factor**d``.  One fixed plan gives every factor's samples.
    """

    def __init__(self, method, points, base, boundary, limits):
        self.method, self.points, self.base = method, points, base
        self.boundary, self.limits = boundary, limits
        # The three as one plan of three times the joints: the waypoints with
        # zero boundary values, then zero waypoints with the velocities, then
        # with the accelerations.
        v0, a0, ve, ae = boundary
        zero = np.zeros_like(v0)
        n = points.shape[1]
        c = plan(np.hstack([points, np.zeros_like(points), np.zeros_like(points)]), method,
                 'fixed', durations=base, start_velocity=np.r_[zero, v0, zero],
                 start_acceleration=np.r_[zero, zero, a0], end_velocity=np.r_[zero, ve, zero],
                 end_acceleration=np.r_[zero, zero, ae]).ppoly.c
        driven = [c[..., :n], c[..., n:2 * n], c[..., 2 * n:]]
        self.derivatives = np.array([q + 1 for q, lim in enumerate(limits) if lim is not None])
        # (3 parts, quantities, S, n, M), divided by the limits.
        self.parts = np.array([[_sampled_derivative(part, base, d)
                                / np.asarray(limits[d - 1])[None, :, None]
                                for d in self.derivatives] for part in driven])

    def fixed_plan(self, durations):
        v0, a0, ve, ae = self.boundary
        return plan(self.points, self.method, 'fixed', durations=durations, start_velocity=v0,
                    start_acceleration=a0, end_velocity=ve, end_acceleration=ae)

    def sampled_values(self, factors):
        """Return the sampled |derivative| / limit: (G, quantities, S, n, M)."""
        factors = np.asarray(factors, dtype=float)
        f = factors[:, None, None, None, None]
        p, v, a = self.parts
        values = np.abs(p[None] + f * (v[None] + f * a[None]))
        return values / factors[:, None, None, None, None] ** self.derivatives[:, None, None, None]

    def sampled_ratios(self, factors):
        """Largest sampled |derivative| / limit for every factor: (G,), a lower bound."""
        factors = np.asarray(factors, dtype=float)
        f = factors[:, None, None]
        p, v, a = self.parts.reshape(3, 1, self.derivatives.size, -1)
        values = a * f   # as sampled_values, in place
        values += v
        values *= f
        values += p
        np.abs(values, out=values)
        peaks = values.max(axis=2) / factors[:, None] ** self.derivatives[None, :]
        return peaks.max(axis=1)

    def exact_ratio(self, factor):
        """Largest exact peak / limit (numpy.roots) of the fixed plan for ``factor * base``."""
        traj = self.fixed_plan(factor * self.base)
        return max(float(np.max(exact_peaks(traj.ppoly, d) / self.limits[d - 1])) for d in
                   self.derivatives)

    def rest_to_rest_factor(self):
        """Closed-form factor of the waypoint part alone (sampled peaks): v ~ 1/f, a ~ 1/f^2..."""
        peaks = self.parts[0].reshape(self.derivatives.size, -1).max(axis=1)
        return float(np.max(peaks ** (1.0 / self.derivatives)))

    def feasible_factor(self, check=False):
        """
        Return a factor whose plan meets the limits (exact peaks, with a margin), or None.

        The factors of :data:`REFUSAL_FACTORS` are screened with sampled
        peaks (a sample above a limit proves a factor infeasible), the best
        local minima of the largest ratio are zoomed into three times, and
        every factor that the samples admit is checked with exact peaks.
        ``check``: also compare the composition with a direct fixed plan.
        """
        factors = self.rest_to_rest_factor() * REFUSAL_FACTORS
        ratios = self.sampled_ratios(factors)
        if check:
            # The composition is the fixed plan: the direct plan at the best factor agrees.
            best = int(np.argmin(ratios))
            c = self.fixed_plan(factors[best] * self.base).ppoly.c
            direct = [np.abs(_sampled_derivative(c, factors[best] * self.base, d))
                      / np.asarray(self.limits[d - 1])[None, :, None] for d in self.derivatives]
            np.testing.assert_allclose(self.sampled_values(factors[best:best + 1])[0], direct,
                                       rtol=1e-6, atol=1e-9 * ratios[best])
        low, high = ratios <= np.r_[np.inf, ratios[:-1]], ratios <= np.r_[ratios[1:], np.inf]
        minima = np.flatnonzero(low & high)
        minima = minima[np.argsort(ratios[minima])][:REFUSAL_MINIMA]
        minima = minima[ratios[minima] <= REFUSAL_ZOOM_BELOW]
        if not minima.size:
            return None
        lower = factors[np.maximum(minima - 1, 0)]
        upper = factors[np.minimum(minima + 1, factors.size - 1)]
        for _ in range(3):
            zoom = np.geomspace(lower, upper, REFUSAL_ZOOM, axis=1)     # (minima, Z)
            zoomed = self.sampled_ratios(zoom.ravel()).reshape(zoom.shape)
            k = np.argmin(zoomed, axis=1)
            rows = np.arange(k.size)
            for factor, ratio in zip(zoom[rows, k], zoomed[rows, k]):
                if ratio <= 1.0 + 1e-9 and self.exact_ratio(factor) <= 1.0 - 1e-9:
                    return factor
            lower = zoom[rows, np.maximum(k - 1, 0)]
            upper = zoom[rows, np.minimum(k + 1, REFUSAL_ZOOM - 1)]
        return None


def check_uniform_refusal(method, points, limits, boundary):
    """
    Confirm that no common factor of the chord durations meets the limits.

    Uniform timing (eq. 11) refuses when no factor ``c`` of the chord
    durations gives a plan within the limits with these boundary values; its
    documented fallback (timing.scaled_spline) also gives the first segment
    a share ``r`` of :data:`FIRST_SEGMENT_SHARES` (``c * [r T_1, T_2, ...]``)
    when a start value is not zero.  Every such timing is planned with
    ``timing='fixed'`` (:class:`ScaledFixedPlans`) and checked here.
    """
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    shares = [1.0]
    if chords.size >= 2 and np.any(np.concatenate(boundary[:2])):
        shares += list(FIRST_SEGMENT_SHARES)
    for share in shares:
        base = chords.copy()
        base[0] *= share
        factor = ScaledFixedPlans(method, points, base, boundary, limits).feasible_factor(
            check=share == 1.0)
        assert factor is None, (
            f'uniform timing refused, but durations {factor} * {base} meet the limits')


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
        # Some boundary values admit no common scale factor; that must be said,
        # and no common factor (nor documented first-segment share) may meet them.
        assert 'infeasible' in str(exc)
        check_uniform_refusal(method, points, (vmax, amax, jmax), (v0, a0, ve, ae))
        return
    check_limits_hold_and_one_binds(traj, vmax, amax, jmax)
    for t, v, a in ((0.0, v0, a0), (traj.duration, ve, ae)):
        np.testing.assert_allclose(traj.evaluate([t], 1)[0], v, atol=1e-7)
        np.testing.assert_allclose(traj.evaluate([t], 2)[0], a, atol=1e-6)


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
