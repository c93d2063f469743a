"""
Time-optimal durations of a two-segment rest-to-rest request, by batched search (issue 23).

Rest to rest, a spline whose durations are all multiplied by ``c`` has
peaks ``v / c``, ``a / c**2``, ``j / c**3`` (every method is linear in its
waypoints, and the boundary values are zero), so the total time after the
common factor that brings it to its limits (the *restored total* of
:mod:`optimal`)::

    R(T) = sum_k T_k * max_{s, j, q} r_{s, j, q}(T) ** (1 / q)

does not change when ``T`` is scaled.  With two segments it is a function
of ``x = log(T_1 / T_2)`` alone, and the problem that
:func:`optimal.minimise_total_time` solves by sequential linear programs is
one-dimensional.  Here ``R`` is evaluated exactly (the method's continuity
system and the exact polynomial peaks of :func:`limits.limit_ratios`) at
:data:`RATIO_GRID_POINTS` values of ``x`` in one batched pass, and the grid is refined
around its best point until its spacing is below :data:`X_TOLERANCE`.  A
pass costs about one evaluation of the SLP, which on 3 x 3 requests took
3-8 LPs (each with its Jacobian) and 5-15 evaluations.  The first pass
spans every ratio within ``exp(X_RANGE)`` of the start's, so only a local
minimum whose basin is narrower than its spacing can be missed, where the
SLP kept to the basin it started in.
"""

import numpy as np

from ..spline.continuity_system import ContinuitySystem
from ..spline.limits import limit_ratios

# Values of x per pass (odd: the best point's neighbours bracket the next pass).
RATIO_GRID_POINTS = 33
# First pass: x within this of the start's (duration ratios 1/400 to 400 times its).
X_RANGE = 6.0
# Passes go on until the grid's spacing in x is below this.  The total at
# the best grid point is then within about X_TOLERANCE * |dR/dx| / 2 of the
# minimum; a segment that is not at a limit there is within 1e-4 of one, or
# shortening it by 0.1 % breaks one (test_optimal_timing's optimality check).
X_TOLERANCE = 1e-4
# A total to beat is out of reach (RatioSearch.cannot_beat) when after
# GIVE_UP_PASSES passes the best total is above it by more than GIVE_UP_DIP
# (relative): the
# minimum was below the second pass's best (spacing 0.023) by at most 1.2 %
# on 2000 random requests (1-7 joints, a fifth with near-duplicate
# waypoints, the three methods; test_ratio_search.py checks the give-up).
GIVE_UP_PASSES = 2
GIVE_UP_DIP = 0.03
# Most passes (a best point at an end of the grid moves the grid on).
MAX_PASSES = 40


def restored_totals(method, points, durations, limits):
    """
    Return the restored totals (B,) of the rows of ``durations`` (B, 2) and their factors (B,).

    Rest to rest.  Also returns the splines' terms (B, 2, 6, n) and exact
    ratios (B, 2, n, 3).  The exact peaks of each spline over the limits, to the
    power ``1 / q`` for velocity (q = 1), acceleration (2) and jerk (3),
    give the factor that brings it to its limits; the restored total is the
    factor times the total time.  Raises ValueError when the continuity
    system is singular.
    """
    B, S = durations.shape
    system = ContinuitySystem(method, durations)
    dP = points[1:] - points[:-1]
    zero = np.zeros(points.shape[1])
    vel, acc = system.solve(dP, zero, zero, zero, zero)
    coeffs = system.coefficients(points[:-1], dP, vel, acc)     # (B, S, 6, n)
    ratios = limit_ratios(coeffs.reshape(B * S, *coeffs.shape[2:]), durations.reshape(-1),
                          limits).reshape(B, S, -1, 3)
    factors = (ratios ** (1.0 / np.arange(1, 4))).reshape(B, -1).max(axis=1)
    return durations.sum(axis=1) * factors, factors, coeffs, ratios


class RatioSearch:
    """
    The search for the two durations of the smallest restored total, pass by pass.

    ``points`` (3, n), rest to rest; ``start`` (2,) centres the first pass
    and sets the total of the durations found (not yet scaled: the factor
    ``exp(log factor)`` brings them exactly to the limits, as
    :func:`optimal.minimise_total_time` returns them).  The values ``also``
    of x join the first pass (the uniform solution's: the result is never
    longer than it).  :meth:`run` takes passes, :attr:`best_total` is the
    best restored total so far, :meth:`cannot_beat` tells a total that the
    minimum will not beat after :data:`GIVE_UP_PASSES` passes, and
    :meth:`result` runs to the end.  Raises ValueError when a continuity
    system is singular or no total is finite.  :attr:`terms` and
    :attr:`ratios` are the best spline's (for the durations found, before
    their factor).
    """

    def __init__(self, method, points, start, limits, also=()):
        """Prepare the first pass; nothing is evaluated yet."""
        self.method, self.points, self.limits = method, points, limits
        self.total = float(start[0] + start[1])
        centre = float(np.log(start[0] / start[1]))
        self._x = np.concatenate(
            [np.linspace(centre - X_RANGE, centre + X_RANGE, RATIO_GRID_POINTS), also])
        self.passes = 0
        self.done = False
        # The best total so far, its durations and factor.
        self.best_total, self._durations, self._factor = np.inf, None, None
        self.terms = self.ratios = None

    def run(self, passes=MAX_PASSES):
        """Take passes until the search is done or has taken ``passes``; return self."""
        while not self.done and self.passes < passes:
            self._pass()
        return self

    def cannot_beat(self, total):
        """
        Whether the minimum is above ``total``, after :data:`GIVE_UP_PASSES` passes.

        True when the best total so far is above it by more than
        :data:`GIVE_UP_DIP` (the minimum's largest dip below it).
        """
        self.run(GIVE_UP_PASSES)
        return self.best_total > total * (1.0 + GIVE_UP_DIP)

    def result(self):
        """Run to the end; return the best durations (2,) and the log of their factor."""
        self.run()
        return self._durations, float(np.log(self._factor))

    def _pass(self):
        x = self._x
        self.passes += 1
        share = 1.0 / (1.0 + np.exp(-x))       # T_1 / (T_1 + T_2)
        durations = self.total * np.column_stack([share, 1.0 - share])
        totals, factors, terms, ratios = restored_totals(self.method, self.points, durations,
                                                         self.limits)
        totals[~np.isfinite(totals)] = np.inf
        best = int(np.argmin(totals))
        if totals[best] < self.best_total:
            self.best_total, self._durations, self._factor = (
                float(totals[best]), durations[best], factors[best])
            self.terms, self.ratios = terms[best], ratios[best]
        if not np.isfinite(self.best_total):
            raise ValueError('no spline of finite peaks on the grid')
        spacing = x[1] - x[0]
        if spacing <= X_TOLERANCE or self.passes == MAX_PASSES:
            self.done = True
            return
        # The next pass spans the best point's neighbours on this grid (one
        # side more when it is at an end; an extra point: its grid point's).
        n = RATIO_GRID_POINTS
        on_grid = best if best < n else int(np.argmin(np.abs(x[:n] - x[best])))
        lo = x[max(on_grid - 1, 0)] - (spacing * (n - 1) / 2 if on_grid == 0 else 0.0)
        hi = x[min(on_grid + 1, n - 1)] + (spacing * (n - 1) / 2 if on_grid == n - 1 else 0.0)
        self._x = np.linspace(lo, hi, n)
