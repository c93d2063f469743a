"""
The speed profile averaged over moving windows: :class:`AveragedTiming` (inner_knots, step 2).

Rest to rest, the path position ``s(t)`` of the fastest profile is averaged
over boxes of the smoothing windows (:func:`plan_options.smoothing_windows`):
a box of width ``W`` turns every jump of the path acceleration into a ramp
lasting ``W`` and removes the frequencies ``k / W`` from it, so the spline
built on the profile neither rings nor shakes an arm whose lowest mode is
near them.  This module holds that average and its inverse (the time at
which a path position is passed).
"""

from functools import lru_cache

import numpy as np

from .path_velocity import path_position
# AveragedTiming.time_at: safeguarded Newton steps (issue 23, the planning time of
# small requests; they replaced a table of the averaged profile at the grid
# points and 5 regula falsi steps within its brackets, 0.2 ms of a 3 x 3
# candidate's 0.8): most steps, and the largest position error accepted
# (relative to the path's length; the table's regula falsi got within 3e-11
# on the plans' profiles, and missed 1e-5 on a random one, 4e-5 next to
# its end).  Targets still further off (where the average flattens, next to
# a rest end) get regula falsi (Illinois) steps on Newton's brackets, at
# most INVERSE_STEPS.  Only where the inner knots sit depends on it: the
# waypoints are knots themselves and the limits are exact.
NEWTON_STEPS = 6
NEWTON_TOLERANCE = 1e-12
INVERSE_STEPS = 20


@lru_cache(maxsize=64)
def _window_shifts(widths):
    """
    Return the shifts and signs (2**k,) and the product of the window ``widths``.

    The windows are those of :class:`AveragedTiming`.
    Every profile of a request has the same windows: computed once (read-only).
    """
    n = len(widths)
    subsets = [[k for k in range(n) if subset >> k & 1] for subset in range(1 << n)]
    shifts = np.array([sum(widths[k] for k in ks) for ks in subsets])
    signs = np.array([(-1.0) ** len(ks) for ks in subsets])
    shifts.flags.writeable = signs.flags.writeable = False
    return shifts, signs, np.prod(widths)


class AveragedTiming:
    """
    The profile's path position in time, ``s(t)``, averaged over moving windows (step 2).

    Within a grid step ``u`` is constant, so ``s(t)`` is a quadratic there
    (:func:`path_velocity.path_position`), ``s = 0`` before the start and
    the path's end after it.  One average over ``[t - W, t]`` is
    ``(S1(t) - S1(t - W)) / W`` with ``S1`` the antiderivative; k windows
    are the alternating sum of the k-th antiderivative over the 2**k
    combinations of shifts, divided by the widths' product.  The
    antiderivatives are exact polynomials per step, so positions are exact
    to round-off.
    """

    def __init__(self, times, x, s, widths):
        self.times, self.x, self.s = times, x, s
        self.widths = list(widths)
        self.duration = times[-1] + sum(self.widths)
        if not self.widths:
            return
        # Polynomial coefficients in tau = t - t_i of s and of its k-th
        # antiderivatives on every step; the last row holds s beyond the end.
        # (Differences by slices: np.diff's values, without its wrapper.)
        h = times[1:] - times[:-1]
        poly = np.zeros((s.size, 3 + len(self.widths)))
        poly[:-1, 0] = s[:-1]
        poly[:-1, 1] = np.sqrt(np.maximum(x[:-1], 0.0))
        poly[:-1, 2] = (x[1:] - x[:-1]) / (4.0 * (s[1:] - s[:-1]))  # u / 2
        poly[-1, 0] = s[-1]
        powers = np.arange(poly.shape[1])
        h_powers = h[:, None] ** powers
        for _ in self.widths:
            poly = np.concatenate([np.zeros((s.size, 1)), poly[:, :-1] / powers[1:]], axis=1)
            ends = np.sum(poly[:-1] * h_powers, axis=1)
            poly[:, 0] = np.concatenate([[0.0], np.cumsum(ends)])
        self.poly = poly
        self._shifts, self._signs, self._product = _window_shifts(tuple(self.widths))

    def _antiderivative(self, t, slope=False):
        # Few numpy calls: small requests call this thousands of times.
        i = self.times.searchsorted(t, side='right') - 1
        np.maximum(i, 0, out=i)
        tau = t - self.times[i]
        rows = self.poly[i]
        value = rows[..., -1] * tau
        value += rows[..., -2]
        if slope:
            # Its derivative by the same Horner steps (velocity of the average).
            top = self.poly.shape[1] - 1
            rate = rows[..., -1] * (top * tau)
            rate += (top - 1) * rows[..., -2]
        for k in range(self.poly.shape[1] - 3, -1, -1):
            # In place: the same products and sums without new arrays.
            if slope and k > 0:
                rate *= tau
                rate += k * rows[..., k]
            value *= tau
            value += rows[..., k]
        before = t <= 0.0
        value[before] = 0.0
        if not slope:
            return value
        rate[before] = 0.0
        return value, rate

    def position_at(self, t):
        """Return the path position at the times ``t``."""
        if not self.widths:
            return path_position(self.times, self.x, self.s, t)
        t = np.asarray(t, float)
        # Repeated moving averages: differences of the k-th antiderivative,
        # at all 2**k shifts in one call.
        values = self._antiderivative(t[..., None] - self._shifts)
        return np.minimum(np.maximum(values @ self._signs / self._product, 0.0), self.s[-1])

    def time_at(self, s):
        """
        Return the times at which the path positions ``s`` (from the start to the end) are passed.

        The ends are pinned to 0 and :attr:`duration`: at rest there, the
        averaged samples repeat the end positions, where interpolation
        would pick any of their times.
        """
        if not self.widths:
            return np.interp(s, self.s, self.times)
        s = np.asarray(s, float)
        if s.ndim == 0:
            return self.time_at(s.reshape(1)).reshape(())
        out = np.empty(s.shape)
        inner = (s > 0.0) & (s < self.s[-1])
        out[inner] = self._newton(s[inner])
        out[s <= 0.0] = 0.0
        out[s >= self.s[-1]] = self.duration
        return out

    def _newton(self, s):
        """
        Return time_at's times of the positions ``s`` strictly inside the path.

        The average of an increasing ``s(t)`` over windows of total width
        ``W`` is between ``s(t - W)`` and ``s(t)``, so it passes a position
        between the plain profile's time there and ``W`` later: a bracket.
        Newton's steps start in its middle with the average's velocity as
        slope (a step that leaves the bracket is a bisection) and stop once
        every position is within :data:`NEWTON_TOLERANCE` of the path's
        length, at most :data:`NEWTON_STEPS` (two or three on the plans'
        profiles); regula falsi with the Illinois rule takes the targets
        still further off on from their brackets, where the average is a
        smooth increasing function (:data:`INVERSE_STEPS`).
        """
        lo = np.interp(s, self.s, self.times)
        hi = lo + sum(self.widths)
        t = 0.5 * (lo + hi)
        tolerance = NEWTON_TOLERANCE * self.s[-1]
        with np.errstate(divide='ignore', invalid='ignore'):
            for _ in range(NEWTON_STEPS):
                values, rates = self._antiderivative(t[..., None] - self._shifts, slope=True)
                f = values @ self._signs / self._product - s
                off = np.abs(f) > tolerance
                if not off.any():
                    return t
                rate = rates @ self._signs / self._product
                above = f > 0.0
                np.copyto(hi, t, where=above)
                np.copyto(lo, t, where=~above)
                step = t - f / rate
                inside = (step > lo) & (step < hi)
                t = np.where(inside, step, 0.5 * (lo + hi))
        # The last step's positions; the targets still off get regula falsi.
        f = self.position_at(t) - s
        off = np.abs(f) > tolerance
        if np.any(off):
            above = f > 0.0
            np.copyto(hi, t, where=above)
            np.copyto(lo, t, where=~above)
            k = np.flatnonzero(off)
            ends = self.position_at(np.concatenate([lo[k], hi[k]])) - np.tile(s[k], 2)
            t[k] = regula_falsi(self.position_at, s[k], lo[k], hi[k], ends[:k.size],
                                ends[k.size:], INVERSE_STEPS)
        return t


def regula_falsi(position_at, s, lo_t, hi_t, lo_f, hi_f, steps):
    """
    Return the times (K,) at which the increasing ``position_at`` passes ``s`` (K,).

    Regula falsi with the Illinois rule (an end kept twice in a row has its
    value halved), ``steps`` evaluations, from brackets ``lo_t`` < ``hi_t``
    with ``lo_f`` <= 0 < ``hi_f`` (the positions there less ``s``; updated
    in place); the last estimate.  The brackets are updated with np.copyto
    and masked ufuncs: the same values in 18 numpy calls a step instead of
    24 (a profile calls this once, 5 steps, on a handful of targets; 0.19
    -> 0.15 ms on 3 x 3).
    """
    was_above = was_below = None
    out = lo_t
    for _ in range(steps):
        span = hi_f - lo_f
        out = lo_t.copy()
        np.divide(lo_t * hi_f - hi_t * lo_f, span, out=out, where=span > 0.0)
        f = position_at(out) - s
        above = f > 0.0
        below = ~above
        np.copyto(hi_t, out, where=above)
        np.copyto(hi_f, f, where=above)
        np.copyto(lo_t, out, where=below)
        np.copyto(lo_f, f, where=below)
        if was_above is not None:
            np.multiply(lo_f, 0.5, out=lo_f, where=above & was_above)
            np.multiply(hi_f, 0.5, out=hi_f, where=below & was_below)
        was_above, was_below = above, below
    return np.array(out, float)
