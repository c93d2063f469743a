"""
A rest-to-rest 555 plan pulled back within its position limits by moving its knots.

A C4 spline through waypoints is not shape-preserving: between two
waypoints a joint can overshoot the last one, and a joint whose waypoints
run one way to a limit can pass it.  On the vendor arms this is 1 to 3
moves in 320 from limit to limit (``benchmarks/bench_position_limits.py``
and its arms), by 2e-4 to 4e-3 rad, under every profile: the path itself
swings out.  plan() then fell back to the chord-length durations, 1.3-1.6
times as long, or refused the request.

The fix moves the spline, not its timing.  With the knot times fixed the
555 spline (eq. 7 at rest) is linear in its knot positions, so each joint
that leaves its range is ``q(t) = q0(t) + U(t) d``, ``U`` the splines
through a unit position at each free knot (every knot but the waypoints),
and staying within ``[low, high]`` is linear in ``d``.  The smallest move
(least total ``|d|``, so few knots move, near the excursion) is one LP per
joint on sampled times, checked exactly (:func:`peaks.position_extrema`)
and solved again with a row at each exact extremum that is still out.
Next to a rest end the position leaves as ``q_end + c3 s**3 + ...`` in the
time ``s`` from the end, so those rows are written in ``(q - q_end) / s**3``,
which keeps them well scaled down to ``s -> 0``: the end jerk's own
direction, the condition of step 4 of :mod:`inner_knots`.  A segment with
no knot of its own between two waypoints (a knots-only plan) gets one at
its middle, placed on the spline itself: the C4 quintic spline through the
same positions with that knot is the same spline, so only the moves change
it.  The moved spline passes every waypoint at its time, is C4 at every
knot, and is stretched in time, uniformly, until it holds the v/a/j limits
again (never sped up): a uniform stretch keeps the positions it passes.
"""

from math import comb

import numpy as np
from scipy.optimize import linprog

from .inner_knots import kept_trajectory
from .rest_ends import KeptRequest, KeptSpline
from ..spline.continuity_system import spline_coefficients
from ..spline.limits import limit_ratios
from ..spline.peaks import position_extrema
from ..spline.trajectory import representable_durations

# Sampled times per piece of the first LP; the exact extrema still out are
# added after it.  On 180 random walks with a limit cut into a swing, 24 a
# piece found the same moves (177) in 1.4 times the time (16 ms against 12,
# median), 4 a piece one fewer.
SAMPLES_PER_PIECE = 8
# Times next to each rest end, as shares 2**-k of the end piece (k = 1..20),
# where the position leaves its end as s**3 (k up to 39 changed nothing).
END_SAMPLES = 0.5 ** np.arange(1, 21)
# LPs per joint: the first, then one for each round of exact extrema still out.
ROUNDS = 8
# How far inside its limit each row aims [rad]: above HiGHS's primal
# feasibility tolerance (1e-7), so that its solutions are within the limit.
# Next to a rest end a row is scaled by (piece / s)**3, so it aims
# MARGIN * (s / piece)**3 inside there; with an inner waypoint closer to the
# limit than 4 * MARGIN, a quarter of that distance (the waypoint is fixed).
MARGIN = 1e-6


def pulled_within(traj, low, high, slack, insert=True):
    """
    Return the rest-to-rest 555 ``traj`` with its knots moved to keep it within [low, high].

    ``low``, ``high`` (n,) (+-inf where unbounded); ``slack`` (2, n), how far
    past each a position still counts as within (round-off).  Only the
    joints that leave are moved.  ``insert``: a segment without a knot of
    its own gets one (False: only the knots ``traj`` has move).  Returns
    None when the LP or its rounds find no move, or the moved spline
    cannot be stretched within the v/a/j limits; else ``(trajectory,
    joints, inserted)``: the trajectory keeps a copy of ``traj.optimizer``,
    ``joints`` (k,) are the joints moved and ``inserted`` the knots added
    (segments that had none).
    """
    built = _knots(traj, insert)
    if built is None:
        return None
    widths, waypoint_knots = built
    times = np.concatenate([[0.0], np.cumsum(widths)])
    free = np.setdiff1d(np.arange(times.size), waypoint_knots)
    if free.size == 0:
        return None
    positions = traj.evaluate(times)
    positions[waypoint_knots] = traj.waypoints
    rest = (np.zeros(traj.n_joints),) * 4
    coeffs = spline_coefficients('555', positions, widths, rest)
    unit = np.zeros((times.size, free.size))
    unit[free, np.arange(free.size)] = 1.0
    units = spline_coefficients('555', unit, widths, (np.zeros(free.size),) * 4)  # (S, 6, m)
    ends = np.concatenate([coeffs[1:, 0, :], traj.waypoints[-1:]])
    q_low, q_high = (x.min(axis=0) if k == 0 else x.max(axis=0)
                     for k, x in enumerate(position_extrema(coeffs, widths, ends)[:2]))
    leaving = np.flatnonzero((q_low < low - slack[0]) | (q_high > high + slack[1]))
    if leaving.size == 0:
        return None
    rows = _Rows(coeffs, units, widths, traj.waypoints[-1])
    moves = np.zeros((free.size, traj.n_joints))
    for j in leaving:
        inner = traj.waypoints[1:-1, j]
        room = np.min(np.concatenate([inner - low[j], high[j] - inner]), initial=np.inf)
        margin = min(MARGIN, 0.25 * room)
        move = _joint_move(rows, j, low[j], high[j], slack[:, j], traj.waypoints[-1, j], margin)
        if move is None:
            return None
        moves[:, j] = move
    moved = positions.copy()
    moved[free] += moves
    turned = coeffs + np.einsum('skm,mn->skn', units, moves)
    spline = KeptSpline(widths, moved, waypoint_knots, turned,
                        limit_ratios(turned, widths, traj.limits))
    found = kept_trajectory(KeptRequest(traj.waypoints, rest, traj.limits), spline,
                            traj.dropped_waypoints, dict(traj.optimizer or {}))
    if found is None:
        return None
    return found, leaving, free.size - (traj.breakpoints.size - traj.waypoint_times.size)


def _knots(traj, insert):
    """
    Return the pieces' widths and the waypoints' knot indices, a knot in every segment.

    ``traj``'s knots, with (``insert``) one more at the middle of each
    segment between two waypoints that has none; widths None when a piece is below the
    resolution of the time axis.
    """
    breakpoints = traj.breakpoints
    at = np.searchsorted(breakpoints, traj.waypoint_times)
    if not np.array_equal(breakpoints[at], traj.waypoint_times):
        return None
    times, waypoint_knots = [breakpoints[0]], [0]
    for first, last in zip(at[:-1], at[1:]):
        if insert and last - first == 1:
            times.append(0.5 * (breakpoints[first] + breakpoints[last]))
        times.extend(breakpoints[first + 1:last + 1])
        waypoint_knots.append(len(times) - 1)
    widths = representable_durations(np.diff(times))
    if not np.all(widths > 0.0):
        return None
    return widths, np.array(waypoint_knots)


class _Rows:
    """The LP rows of one joint: its position at a piece's local time, linear in the moves."""

    def __init__(self, coeffs, units, widths, last_point):
        self.coeffs, self.units, self.widths = coeffs, units, widths
        self.last = widths.size - 1
        # The last piece's terms in the time s back from the end: q(w - s).
        w = widths[-1]
        shift = np.array([[comb(i, k) * w ** (i - k) * (-1.0) ** k if i >= k else 0.0
                           for i in range(6)] for k in range(6)])
        self.end_coeffs = shift @ coeffs[-1]
        self.end_units = shift @ units[-1]
        self.last_point = last_point

    def samples(self):
        """Return the (piece, local time) pairs of the first LP."""
        share = np.arange(1, SAMPLES_PER_PIECE + 1) / (SAMPLES_PER_PIECE + 1.0)
        pairs = [(s, t) for s, w in enumerate(self.widths) for t in w * share]
        pairs += [(0, t) for t in self.widths[0] * END_SAMPLES]
        pairs += [(self.last, self.widths[-1] * (1.0 - x)) for x in END_SAMPLES]
        return pairs

    def row(self, piece, tau, j, low, high):
        """
        Return (a (m,), value, lower, upper): ``lower <= value + a @ d <= upper``.

        In the end pieces, ``(q - q_end) (w / s)**3`` with ``s`` the time from
        the rest end and ``w`` the piece (rest: the terms in s and s**2 are 0).
        """
        if piece in (0, self.last):
            w = self.widths[piece]
            if piece == 0:
                s, c, u, q_end = tau, self.coeffs[0, :, j], self.units[0], self.coeffs[0, 0, j]
            else:
                s, c, u, q_end = w - tau, self.end_coeffs[:, j], self.end_units, self.last_point[j]
            if not s > 0.0:
                return None
            p = np.array([1.0, s, s * s]) * w ** 3
            scale = (w / s) ** 3
            return p @ u[3:], p @ c[3:], (low - q_end) * scale, (high - q_end) * scale
        p = tau ** np.arange(6)
        return p @ self.units[piece], p @ self.coeffs[piece, :, j], low, high


def _joint_move(rows, j, low, high, slack, last_point, margin):
    """
    Return the least total move (m,) of joint ``j``'s free knots into [low, high], or None.

    Each row aims ``margin`` inside its limit (:data:`MARGIN`).
    """
    table = [rows.row(s, t, j, low, high) for s, t in rows.samples()]
    m = rows.units.shape[2]
    for _ in range(ROUNDS):
        kept = [r for r in table if r is not None]
        a = np.array([r[0] for r in kept])
        value = np.array([r[1] for r in kept])
        lower = np.array([r[2] for r in kept])
        upper = np.array([r[3] for r in kept])
        # A row far from its limit (or with none) cannot bind: left out.
        above = np.isfinite(upper) & (upper - value < 1e9)
        below = np.isfinite(lower) & (value - lower < 1e9)
        a_ub = np.concatenate([a[above], -a[below]])
        b_ub = np.concatenate([upper[above] - value[above], value[below] - lower[below]]) - margin
        # |d| = d+ + d-, both >= 0.
        result = linprog(np.ones(2 * m), A_ub=np.hstack([a_ub, -a_ub]), b_ub=b_ub,
                         bounds=(0.0, None), method='highs')
        if result.status != 0:
            return None
        move = result.x[:m] - result.x[m:]
        c = rows.coeffs[:, :, j] + rows.units @ move
        ends = np.concatenate([c[1:, 0], [last_point]])
        q_low, q_high, t_low, t_high = (x[:, 0] for x in position_extrema(
            c[:, :, None], rows.widths, ends[:, None]))
        out = np.flatnonzero((q_low < low - slack[0]) | (q_high > high + slack[1]))
        if out.size == 0:
            return move
        table += [rows.row(s, t, j, low, high) for s in out for t in (t_low[s], t_high[s])]
    return None
