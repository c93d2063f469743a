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
# Relative width of the final bracket of the factor search.
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


def uniform_scale(spline, limits):
    """
    Return the smallest common factor that meets the limits and the ratios there.

    Rest-to-rest: closed form.  Otherwise: a feasible factor is bracketed
    (geometric steps from the rest-to-rest factor), then the boundary between
    infeasible and feasible is found by the Illinois variant of regula falsi on
    ``max_ratio - 1``, always keeping a feasible end.  Raises ValueError when
    no factor in a wide range is feasible (boundary values that no common
    scaling reconciles with the limits).
    """
    position_only = limit_ratios(spline.waypoint_part, spline.base_durations, limits)
    guess = closed_form_scale(position_only)
    if not spline.has_boundary_part:
        return guess, rescaled_ratios(position_only, guess)

    def excess(scale):
        ratios = limit_ratios(spline.coefficients(scale), spline.durations(scale), limits)
        return float(np.max(ratios)) - 1.0, ratios

    high, (f_high, r_high) = guess, excess(guess)
    if f_high > 0.0:
        found = False
        for direction in (_BRACKET_STEP, 1.0 / _BRACKET_STEP):
            trial = guess
            for _ in range(_BRACKET_STEPS):
                trial *= direction
                f_trial, r_trial = excess(trial)
                if f_trial <= 0.0:
                    high, f_high, r_high, found = trial, f_trial, r_trial, True
                    break
            if found:
                break
        if not found:
            raise ValueError('infeasible: no common time scale meets the limits with these '
                             'boundary velocities and accelerations')
    # Walk down until infeasible: [low, high] brackets the smallest feasible factor.
    for _ in range(_BRACKET_STEPS):
        low = high / _BRACKET_STEP
        f_low, r_low = excess(low)
        if f_low > 0.0:
            break
        high, f_high, r_high = low, f_low, r_low
    else:
        return high, r_high
    side = 0
    while high - low > _BISECTION_RTOL * high:
        middle = (low * f_high - high * f_low) / (f_high - f_low)
        if not low < middle < high:
            middle = 0.5 * (low + high)
        f_mid, r_mid = excess(middle)
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
