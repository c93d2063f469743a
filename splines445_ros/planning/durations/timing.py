"""
Segment durations: chord lengths (eq. 11) and the paper's common scale factor.

With durations ``lambda * T`` the spline is linear in the waypoints and the
boundary values, and time-scaling shows how each part depends on ``lambda``::

    q(t) = G_P(s) + lambda * G_v(s) + lambda**2 * G_a(s),   s = t / lambda

where ``G_P``, ``G_v``, ``G_a`` are the splines for durations ``T`` driven by
the waypoints alone, by the boundary velocities alone and by the boundary
accelerations alone.  They are solved once (three right-hand sides of one
banded solve); every trial factor then only recombines coefficients.  With zero
boundary values the peaks scale exactly as ``v ~ 1/lambda``, ``a ~ 1/lambda**2``,
``j ~ 1/lambda**3`` and the factor is closed-form; otherwise the peaks are not
monotone in ``lambda`` and the factor is searched (see :func:`uniform_scale`).
"""

import numpy as np
from scipy.optimize import minimize_scalar

from ..spline.continuity_system import ContinuitySystem
from ..spline.limits import limit_ratios, rest_to_rest_times
from ..spline.peaks import sampled_segment_peaks_of

# Factors (relative to the rest-to-rest factor) scanned for a feasible one.
SCAN_GRID = np.geomspace(1.0 / 30.0, 1000.0, 32)
# Relative width of the final bracket of the factor search.
_BISECTION_RTOL = 1e-9
# First-segment shares tried when no common factor is feasible (see scaled_spline).
FIRST_SEGMENT_SHARES = np.geomspace(1.0 / 8.0, 8.0, 13)
# Largest ratio of neighbouring durations in the rest-to-rest starting guess.
NEIGHBOUR_RATIO = 20.0
# Safety factor applied to closed-form factors against round-off.
_ROUNDOFF = 1.0 + 1e-12
# rest_to_rest_lower_bound: relative margin below the sampled factor, far
# above the round-off of the polynomials' values.
LOWER_BOUND_RTOL = 1e-6


def chord_durations(waypoints):
    """Eq. (11): T_k = sqrt(sum_j (q_{j,k+1} - q_{j,k})^2), 'every joint at unit speed'."""
    return np.sqrt(np.sum(np.diff(waypoints, axis=0) ** 2, axis=1))


def rest_to_rest_durations(waypoints, limits):
    """
    Per-segment time of the fastest rest-to-rest move of its slowest joint: (S,).

    Joint j moves ``d = |dq_j|`` under ``v, a, j`` limits (jerk may be inf)
    with the classic jerk-limited profile (jerk ramps of ``a / j``,
    constant acceleration, cruise): a well-scaled starting point for optimal
    timing, since a tiny chord gets about ``sqrt(d / a)`` rather than a time
    proportional to ``d`` (eq. 11), which a rest end turns into a swing;
    then :func:`graded`.
    """
    v, a, j = (q[None, :] for q in (limits.velocity, limits.acceleration, limits.jerk))
    times = rest_to_rest_times(np.abs(np.diff(waypoints, axis=0)), v, a, j)
    return graded(np.max(times, axis=1))


def graded(durations, ratio=None):
    """
    Lengthen durations so that neighbours differ by at most ``ratio`` (S,).

    A segment far shorter than its neighbour cannot absorb the speed the
    neighbour brings (next to a rest end it must stop within its tiny
    chord), and the spline swings; with neighbours within
    :data:`NEIGHBOUR_RATIO` of each other it does not (the issue's 555
    example: 2895 s from [2, 2, 0.002] s, 3.40 s from [2, 2, 0.1] s).
    """
    ratio = NEIGHBOUR_RATIO if ratio is None else ratio
    out = np.array(durations, dtype=float)
    for k in range(1, out.size):
        out[k] = max(out[k], out[k - 1] / ratio)
    for k in range(out.size - 2, -1, -1):
        out[k] = max(out[k], out[k + 1] / ratio)
    return out


class ScaledSpline:
    """The spline of ``method`` through ``waypoints`` for durations ``lambda * base``."""

    def __init__(self, method, waypoints, base_durations, boundary):
        """Solve the three parts; ``boundary`` = (v_start, a_start, v_end, a_end)."""
        self.base_durations = np.asarray(base_durations, dtype=float)
        self.system = ContinuitySystem(method, self.base_durations)
        n = waypoints.shape[1]
        dP = np.diff(waypoints, axis=0)
        zeros_dp = np.zeros_like(dP)
        zero = np.zeros(n)
        v0, a0, ve, ae = boundary
        # Columns: waypoint part, velocity part, acceleration part.
        dp_all = np.concatenate([dP, zeros_dp, zeros_dp], axis=1)
        start_all = np.concatenate([waypoints[:-1], np.zeros_like(dP), np.zeros_like(dP)], axis=1)
        vel, acc = self.system.solve(
            dp_all,
            np.concatenate([zero, v0, zero]), np.concatenate([zero, zero, a0]),
            np.concatenate([zero, ve, zero]), np.concatenate([zero, zero, ae]))
        coeffs = self.system.coefficients(start_all, dp_all, vel, acc)
        self._parts = (coeffs[..., :n], coeffs[..., n:2 * n], coeffs[..., 2 * n:])
        self.has_boundary_part = bool(np.any(boundary))

    @property
    def waypoint_part(self):
        """Coefficients of ``G_P`` (the spline with zero boundary values) at factor 1."""
        return self._parts[0]

    def durations(self, scale):
        """Real-time durations for the factor ``scale``."""
        return scale * self.base_durations

    def coefficients(self, scale):
        """Return the real-time ascending polynomial terms (S, 6, n) for the factor ``scale``."""
        return self.coefficients_batch(np.array([scale]))[0]

    def coefficients_batch(self, scales):
        """Return the real-time polynomial terms (G, S, 6, n) for G factors at once."""
        s = np.asarray(scales, dtype=float)[:, None, None, None]
        position, velocity, acceleration = self._parts
        combined = position + s * velocity + s**2 * acceleration
        return combined / s ** np.arange(combined.shape[2])[None, None, :, None]

    def max_ratios(self, scales, limits):
        """Largest peak / limit of the whole spline for every factor in ``scales``: (G,)."""
        scales = np.asarray(scales, dtype=float)
        coeffs = self.coefficients_batch(scales)
        G, S = coeffs.shape[:2]
        durations = (scales[:, None] * self.base_durations[None, :]).reshape(-1)
        ratios = limit_ratios(coeffs.reshape(G * S, *coeffs.shape[2:]), durations, limits)
        return ratios.reshape(G, -1).max(axis=1)


def closed_form_scale(ratios_at_unit_scale):
    """
    Smallest factor for a rest-to-rest spline from its (S, n, 3) ratios at factor 1.

    Velocity ratios scale as 1/lambda, acceleration as 1/lambda^2, jerk as 1/lambda^3.
    """
    per_quantity = np.max(ratios_at_unit_scale, axis=(0, 1))
    return float(np.max(per_quantity ** (1.0 / np.arange(1, 4)))) * _ROUNDOFF


def rescaled_ratios(ratios_at_unit_scale, scale):
    """Rest-to-rest ratios (S, n, 3) at ``scale`` from those at factor 1 (exact scaling)."""
    return ratios_at_unit_scale / scale ** np.arange(1, 4)[None, None, :]


def _excess(spline, limits, scale):
    ratios = limit_ratios(spline.coefficients(scale), spline.durations(scale), limits)
    return float(np.max(ratios)) - 1.0, ratios


def _scan(spline, limits, guess):
    """
    Excess ``max_ratio - 1`` on the scan grid around ``guess``: (grid, excess).

    When even the smallest grid factor is feasible (the rest-to-rest guess
    can be far too large, e.g. after a very short chord), the grid is
    extended downwards, :data:`SCAN_GRID`'s span at a time, until a factor
    is infeasible or the factors reach ``1e-12 * guess``.
    """
    grid = guess * SCAN_GRID
    excess = spline.max_ratios(grid, limits) - 1.0
    span = SCAN_GRID[0] / SCAN_GRID[-1]
    while excess[0] <= 0.0 and grid[0] > 1e-12 * guess:
        lower = grid[0] * span * SCAN_GRID[:-1] / SCAN_GRID[0]
        grid = np.concatenate([lower, grid])
        excess = np.concatenate([spline.max_ratios(lower, limits) - 1.0, excess])
    return grid, excess


def _refine(spline, limits, grid, excess):
    """Smallest feasible factor below the first feasible grid factor, and its ratios."""
    k = int(np.flatnonzero(excess <= 0.0)[0])
    high = grid[k]
    f_high, r_high = _excess(spline, limits, high)
    if k == 0:
        return high, r_high
    low, f_low = grid[k - 1], excess[k - 1]
    side = 0
    while high - low > _BISECTION_RTOL * high:
        middle = (low * f_high - high * f_low) / (f_high - f_low)
        if not low < middle < high:
            middle = 0.5 * (low + high)
        f_mid, r_mid = _excess(spline, limits, middle)
        if f_mid <= 0.0:
            high, f_high, r_high = middle, f_mid, r_mid
            if side == 1:
                f_low *= 0.5
            side = 1
        else:
            low, f_low = middle, f_mid
            if side == -1:
                f_high *= 0.5
            side = -1
    return high, r_high


def rest_to_rest_lower_bound(spline, limits):
    """
    Return a lower bound of :func:`rest_to_rest_scale`, from sampled peaks (no root finding).

    The peaks at fixed points (:func:`peaks.sampled_peaks`) are within
    round-off below the exact ones, and the closed-form factor grows with
    them (:func:`_rest_to_rest_guess` on sampled peaks);
    :data:`LOWER_BOUND_RTOL` below it for that round-off.  A caller
    that only needs to know that uniform timing is longer than a plan in
    hand spares its exact peaks (0.2 ms of a 3 x 3 request's rival).
    """
    lower = limit_ratios(spline.waypoint_part, spline.base_durations, limits,
                         peaks_of=sampled_segment_peaks_of)
    return closed_form_scale(lower) * (1.0 - LOWER_BOUND_RTOL)


def rest_to_rest_scale(spline, limits):
    """Return the factor that would meet the limits if the boundary values were zero."""
    return _rest_to_rest_guess(spline, limits)[0]


def _rest_to_rest_guess(spline, limits):
    position_only = limit_ratios(spline.waypoint_part, spline.base_durations, limits)
    guess = closed_form_scale(position_only)
    if not (np.isfinite(guess) and guess > 0.0 and np.all(np.isfinite(guess *
                                                                      spline.base_durations))):
        raise ValueError('no finite time scale: the waypoints are too large or too close '
                         'for the limits')
    return guess, position_only


def _search_near_best(spline, limits, grid, excess):
    """Minimise the excess next to the best grid factor; a finer feasible grid or None."""
    best = int(np.argmin(excess))
    lo, hi = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
    found = minimize_scalar(lambda y: _excess(spline, limits, np.exp(y))[0],
                            bounds=(np.log(lo), np.log(hi)), method='bounded',
                            options={'xatol': 1e-6})
    if found.fun > 0.0:
        return None
    return (np.array([lo, float(np.exp(found.x))]),
            np.array([excess[max(best - 1, 0)], found.fun]))


def uniform_scale(spline, limits):
    """
    Return the smallest common factor that meets the limits and the ratios there.

    Rest-to-rest: closed form.  Otherwise the peaks are not monotone in the
    factor and the feasible factors can form a narrow interval, so a
    geometric grid around the rest-to-rest factor (:data:`SCAN_GRID`) is
    evaluated at once (one batched peak computation) for the smallest
    feasible grid factor; when none is feasible, the excess ``max_ratio - 1``
    is minimised (bounded Brent, in log factor) next to the best grid factor.
    The boundary between the infeasible factor below and the feasible one is
    then found by the Illinois variant of regula falsi, always keeping a
    feasible end.  Raises ValueError when no factor is feasible.
    """
    guess, position_only = _rest_to_rest_guess(spline, limits)
    if not spline.has_boundary_part:
        return guess, rescaled_ratios(position_only, guess)
    grid, excess = _scan(spline, limits, guess)
    if not np.any(excess <= 0.0):
        near = _search_near_best(spline, limits, grid, excess)
        if near is None:
            raise ValueError('infeasible: no common time scale meets the limits with these '
                             'boundary velocities and accelerations')
        grid, excess = near
    return _refine(spline, limits, grid, excess)


def scaled_spline(method, points, chords, boundary, limits):
    """
    Return the uniform-timing spline, its factor and its ratios (the paper's timing).

    The durations are ``lambda * chords`` with the smallest feasible factor.
    When no common factor is feasible, which happens when the start state is
    close to the limits (replanning from a moving arm), the first segment gets
    its own share ``r`` of the timing: durations ``lambda * [r * T_1, T_2, ...]``
    for each ``r`` in :data:`FIRST_SEGMENT_SHARES`, and the shortest feasible
    result is taken.  Raises ValueError when none is feasible.
    """
    spline = ScaledSpline(method, points, chords, boundary)
    try:
        scale, ratios = uniform_scale(spline, limits)
        return spline, scale, ratios
    except ValueError:
        if len(chords) < 2 or not np.any(boundary[:2]):
            raise
    # Scan every share at once per share (batched), then refine only the best.
    candidates = []
    for share in FIRST_SEGMENT_SHARES:
        base = chords.copy()
        base[0] *= share
        candidate = ScaledSpline(method, points, base, boundary)
        guess = _rest_to_rest_guess(candidate, limits)[0]
        grid, excess = _scan(candidate, limits, guess)
        candidates.append((candidate, grid, excess))
    feasible = [(grid[np.flatnonzero(excess <= 0.0)[0]] * c.base_durations.sum(), i)
                for i, (c, grid, excess) in enumerate(candidates) if np.any(excess <= 0.0)]
    if feasible:
        candidate, grid, excess = candidates[min(feasible)[1]]
        return (candidate,) + _refine(candidate, limits, grid, excess)
    for i in np.argsort([np.min(excess) for _, _, excess in candidates])[:3]:
        candidate, grid, excess = candidates[i]
        near = _search_near_best(candidate, limits, grid, excess)
        if near is not None:
            return (candidate,) + _refine(candidate, limits, *near)
    raise ValueError('infeasible: no time scale meets the limits with these boundary '
                     'velocities and accelerations, not even with a separately timed '
                     'first segment')
