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
``j ~ 1/lambda**3`` and the factor is closed-form; otherwise it is bracketed and
bisected, because the peaks are not monotone in ``lambda``.
"""

import numpy as np

from .continuity_system import ContinuitySystem
from .limits import limit_ratios

# Bracketing steps and range of the scale search (relative to the first guess).
_BRACKET_STEP = 1.5
_BRACKET_STEPS = 60
# Relative width at which bisection stops.
_BISECTION_RTOL = 1e-9
# Safety factor applied to closed-form factors against round-off.
_ROUNDOFF = 1.0 + 1e-12


def chord_durations(waypoints):
    """Eq. (11): T_k = sqrt(sum_j (q_{j,k+1} - q_{j,k})^2), 'every joint at unit speed'."""
    return np.sqrt(np.sum(np.diff(waypoints, axis=0) ** 2, axis=1))


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
        position, velocity, acceleration = self._parts
        combined = position + scale * velocity + scale**2 * acceleration
        return combined / (scale ** np.arange(combined.shape[1]))[None, :, None]

    def max_ratio(self, scale, limits):
        """Largest peak / limit over all segments, joints and quantities."""
        return float(np.max(limit_ratios(self.coefficients(scale), self.durations(scale), limits)))


def closed_form_scale(ratios_at_unit_scale):
    """
    Smallest factor for a rest-to-rest spline from its (S, n, 3) ratios at factor 1.

    Velocity ratios scale as 1/lambda, acceleration as 1/lambda^2, jerk as 1/lambda^3.
    """
    per_quantity = np.max(ratios_at_unit_scale, axis=(0, 1))
    return float(np.max(per_quantity ** (1.0 / np.arange(1, 4)))) * _ROUNDOFF


def uniform_scale(spline, limits):
    """
    Smallest common factor (found by bracketing and bisection) that meets the limits.

    Raises ValueError when no factor in a wide range around the rest-to-rest
    factor is feasible (boundary values that no common scaling can reconcile
    with the limits).
    """
    position_only = limit_ratios(spline.waypoint_part, spline.base_durations, limits)
    guess = closed_form_scale(position_only)
    if not spline.has_boundary_part:
        return guess

    def feasible(scale):
        return spline.max_ratio(scale, limits) <= 1.0

    feasible_scale = None
    if feasible(guess):
        feasible_scale = guess
    else:
        for direction in (_BRACKET_STEP, 1.0 / _BRACKET_STEP):
            trial = guess
            for _ in range(_BRACKET_STEPS):
                trial *= direction
                if feasible(trial):
                    feasible_scale = trial
                    break
            if feasible_scale is not None:
                break
    if feasible_scale is None:
        raise ValueError('infeasible: no common time scale meets the limits with these '
                         'boundary velocities and accelerations')
    # Walk down until infeasible, then bisect the bracket [infeasible, feasible].
    high = feasible_scale
    low = high / _BRACKET_STEP
    for _ in range(_BRACKET_STEPS):
        if not feasible(low):
            break
        high, low = low, low / _BRACKET_STEP
    else:
        return high
    while high - low > _BISECTION_RTOL * high:
        middle = 0.5 * (low + high)
        if feasible(middle):
            high = middle
        else:
            low = middle
    return high
