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
(least total ``|d|``, so few knots move) of the knots around the excursion
(its segments and one on either side, a window that grows where a round
leaves elsewhere) is one LP per joint on sampled times, checked exactly
(:func:`peaks.position_extrema`) and solved again with a row at each
exact extremum that is still out.
Next to a rest end the position leaves as ``q_end + c3 s**3 + ...`` in the
time ``s`` from the end, so those rows are written in ``(q - q_end) / s**3``,
which keeps them well scaled down to ``s -> 0``: the end jerk's own
direction, the condition of step 4 of :mod:`inner_knots`.  Next to an inner
waypoint (fixed) they are written in ``(q - q_w) / s**2``: on a limit, a
joint must turn there (velocity 0, acceleration away from the limit), which
the unscaled rows, held to HiGHS's tolerance, cannot make it do.  A segment with
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

from .inner_knots import moved_trajectory, unit_splines
from ..speed_profile.residual_vibration import spline_content
from ..spline.continuity_system import spline_coefficients
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
# The segments on either side of one where a joint leaves whose knots move too.
WINDOW = 1
# LPs per joint: the first, then one for each round of exact extrema still out.
ROUNDS = 8
# How far inside its limit each row aims [rad]: above HiGHS's primal
# feasibility tolerance (1e-7), so that its solutions are within the limit.
# Next to a rest end a row is scaled by (half piece / s)**3, next to an inner
# waypoint by (half piece / s)**2, so it aims less far inside there, down to
# 0 at the waypoint itself.
MARGIN = 1e-6
# An inner waypoint this close to a limit [rad] gets the END_SAMPLES on both
# sides too (a joint turning on its limit); further in, the pieces' own
# samples and the exact extrema hold it.
NEAR_LIMIT = 4.0 * MARGIN


def pulled_within(traj, low, high, slack, insert=True, mode=None):
    """
    Return the rest-to-rest 555 ``traj`` with its knots moved to keep it within [low, high].

    ``low``, ``high`` (n,) (+-inf where unbounded); ``slack`` (2, n), how far
    past each a position still counts as within (round-off).  Only the
    joints that leave are moved.  ``insert``: a segment without a knot of
    its own gets one (False: only the knots ``traj`` has move).  ``mode``
    [Hz]: the moves keep the content of that mode in the acceleration
    (:mod:`residual_vibration`'s ``Z``, two equality rows a joint), so
    the ringing after the stop is the plan's own as long as it is not
    stretched.  Returns None when the LP or its rounds find no move, or
    the moved spline cannot be stretched within the v/a/j limits; else
    ``(trajectory, joints, inserted)``: the trajectory keeps a copy of
    ``traj.optimizer``, ``joints`` (k,) are the joints moved and
    ``inserted`` the segments that got a knot (they had none).  A waypoint past a limit (no move
    helps) is None at once.
    """
    points = traj.waypoints
    if np.any(points < low - slack[0]) or np.any(points > high + slack[1]):
        return None
    built = knot_layout(traj, insert)
    if built is None:
        return None
    widths, waypoint_knots = built
    times = np.concatenate([[0.0], np.cumsum(widths)])
    free = np.setdiff1d(np.arange(times.size), waypoint_knots)
    if free.size == 0:
        return None
    positions = traj.evaluate(times)
    positions[waypoint_knots] = traj.waypoints
    coeffs = spline_coefficients('555', positions, widths, (np.zeros(traj.n_joints),) * 4)
    units = unit_splines(times.size, free, widths)                  # (S, 6, m)
    ends = np.concatenate([coeffs[1:, 0, :], traj.waypoints[-1:]])
    q_low, q_high = position_extrema(coeffs, widths, ends)[:2]     # (S, n) a piece
    out = (q_low < low - slack[0]) | (q_high > high + slack[1])
    leaving = np.flatnonzero(out.any(axis=0))
    if leaving.size == 0:
        return None
    rows = _Rows(coeffs, units, widths, waypoint_knots, free, points[-1])
    if mode:
        rows.content = spline_content(units, times, (mode,))
    moves = np.zeros((free.size, traj.n_joints))
    for j in leaving:
        move = _joint_move(rows, j, low[j], high[j], slack[:, j], np.flatnonzero(out[:, j]))
        if move is None:
            return None
        moves[:, j] = move
    found = moved_trajectory(traj, widths, positions, waypoint_knots, coeffs, units, free, moves)
    if found is None:
        return None
    inserted = np.flatnonzero(np.diff(np.searchsorted(traj.breakpoints,
                                                      traj.waypoint_times)) == 1) if insert else []
    return found, leaving, np.asarray(inserted, dtype=int)


def knot_layout(traj, insert):
    """
    Return the pieces' widths and the waypoints' knot indices, a knot in every segment.

    ``traj``'s knots, with (``insert``) one more at the middle of each
    segment between two waypoints that has none; widths None when a piece
    is below the resolution of the time axis.
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
    """
    The LP rows of one joint: its position at a piece's local time, linear in the moves.

    A row in the half of a piece next to a rest end, or next to an inner
    waypoint, is written relative to that fixed position and scaled
    (module docstring): ``(q - q_a) (h / s)**k`` with ``s`` the time from
    the anchor ``a``, ``h`` half the piece, ``k`` 3 at a rest end (the terms
    in s and s**2 are 0 there) and 2 at a waypoint (from its term in s).
    """

    def __init__(self, coeffs, units, widths, waypoint_knots, free, last_point):
        self.coeffs, self.units, self.widths = coeffs, units, widths
        self.last = widths.size - 1
        self.waypoint = np.zeros(widths.size + 1, dtype=bool)
        self.waypoint[waypoint_knots] = True
        # The segment (between two waypoints) of every piece and free knot.
        before = np.cumsum(self.waypoint) - 1
        self.segment_of_piece = before[:-1]
        self.segment_of_free = before[free]
        self.last_point = last_point
        self.content = None     # (2, m) rows of a mode's content to keep, or None
        self._from_end = {}

    def from_end(self, piece):
        """Return the piece's terms (6, n) and units' (6, m) in the time back from its end."""
        if piece not in self._from_end:
            w = self.widths[piece]
            shift = np.array([[comb(i, k) * w ** (i - k) * (-1.0) ** k if i >= k else 0.0
                               for i in range(6)] for k in range(6)])
            self._from_end[piece] = (shift @ self.coeffs[piece], shift @ self.units[piece])
        return self._from_end[piece]

    def samples(self, near):
        """
        Return the (piece, local time) pairs of the first LP.

        :data:`SAMPLES_PER_PIECE` a piece, and :data:`END_SAMPLES` next to
        both rest ends and on both sides of the waypoint knots ``near``.
        """
        share = np.arange(1, SAMPLES_PER_PIECE + 1) / (SAMPLES_PER_PIECE + 1.0)
        pairs = [(s, t) for s, w in enumerate(self.widths) for t in w * share]
        for knot in sorted({0, self.last + 1} | {int(k) for k in near}):
            if knot <= self.last:
                pairs += [(knot, t) for t in self.widths[knot] * 0.5 * END_SAMPLES]
            if knot >= 1:
                w = self.widths[knot - 1]
                pairs += [(knot - 1, t) for t in w * (1.0 - 0.5 * END_SAMPLES)]
        return pairs

    def row(self, piece, tau, j, low, high):
        """Return (a (m,), value, lower, upper): ``lower <= value + a @ d <= upper``, or None."""
        w = self.widths[piece]
        at_start = tau <= 0.5 * w
        knot = piece if at_start else piece + 1
        if not self.waypoint[knot]:
            p = tau ** np.arange(6)
            return p @ self.units[piece], p @ self.coeffs[piece, :, j], low, high
        if at_start:
            s, c, u = tau, self.coeffs[piece, :, j], self.units[piece]
            anchor = self.coeffs[piece, 0, j]
        else:
            c, u = self.from_end(piece)
            s, c = w - tau, c[:, j]
            anchor = self.last_point[j] if knot == self.last + 1 else self.coeffs[knot, 0, j]
        if not s > 0.0:
            return None
        # At a rest end q - q_a starts with s**3 (velocity and acceleration 0).
        k, first = (3, 3) if knot in (0, self.last + 1) else (2, 1)
        scale = (0.5 * w / s) ** k
        p = scale * s ** np.arange(first, 6)
        return (p @ u[first:], p @ c[first:], (low - anchor) * scale,
                (high - anchor) * scale)


def _joint_move(rows, j, low, high, slack, out):
    """
    Return the least total move (m,) of joint ``j``'s free knots into [low, high], or None.

    ``out``: the pieces where the joint leaves them before any move.  Only
    the knots of the segments where the joint leaves, and of
    :data:`WINDOW` segments on either side, move, held by the rows of one
    segment more; a round whose exact extrema leave elsewhere widens the
    window there.  A knot's unit response decays by about 2.3 a knot (on
    equal pieces), so the window keeps the LPs small for the same moves:
    30 waypoints, 6 joints, five of them cut, planned in 0.14 s against
    1.5 s over every knot, to the same durations.
    """
    position = np.append(rows.coeffs[:, 0, j], rows.last_point[j])
    near = np.flatnonzero(rows.waypoint & ((position - low < NEAR_LIMIT)
                                           | (high - position < NEAR_LIMIT)))
    pairs = rows.samples(near)
    cache = {}
    window = set(rows.segment_of_piece[out].tolist())
    last_segment = int(rows.segment_of_piece[-1])
    for _ in range(ROUNDS):
        cols = np.flatnonzero(np.isin(rows.segment_of_free, list(_widened(window, WINDOW,
                                                                          last_segment))))
        held = _widened(window, WINDOW + 1, last_segment)
        table = []
        for pair in pairs:
            if rows.segment_of_piece[pair[0]] in held:
                if pair not in cache:
                    cache[pair] = rows.row(pair[0], pair[1], j, low, high)
                if cache[pair] is not None:
                    table.append(cache[pair])
        a = np.array([r[0][cols] for r in table])
        value = np.array([r[1] for r in table])
        lower = np.array([r[2] for r in table])
        upper = np.array([r[3] for r in table])
        # A row far from its limit (or with none) cannot bind: left out.
        above = np.isfinite(upper) & (upper - value < 1e9)
        below = np.isfinite(lower) & (value - lower < 1e9)
        a_ub = np.concatenate([a[above], -a[below]])
        b_ub = np.concatenate([upper[above] - value[above], value[below] - lower[below]]) - MARGIN
        # |d| = d+ + d-, both >= 0.
        result = None
        equal = {}
        if rows.content is not None:
            keep = rows.content[:, cols]
            equal = {'A_eq': np.hstack([keep, -keep]), 'b_eq': np.zeros(2)}
        if cols.size:
            result = linprog(np.ones(2 * cols.size), A_ub=np.hstack([a_ub, -a_ub]),
                             b_ub=b_ub, bounds=(0.0, None), method='highs', **equal)
        if result is None or result.status != 0:
            if len(window) > last_segment:
                return None
            # No move within the window: every segment's knots, once more.
            window = set(range(last_segment + 1))
            continue
        move = np.zeros(rows.units.shape[2])
        move[cols] = result.x[:cols.size] - result.x[cols.size:]
        out, times = _leaving_pieces(rows, j, move, low, high, slack)
        if out.size == 0:
            return move
        pairs = pairs + [(int(s), float(t)) for s, ts in zip(out, times) for t in ts]
        window |= set(rows.segment_of_piece[out].tolist())
    return None


def _widened(segments, by, last):
    """Return the set of ``segments`` and those within ``by`` of one, in 0..``last``."""
    return {k for s in segments for k in range(max(0, s - by), min(last, s + by) + 1)}


def _leaving_pieces(rows, j, move, low, high, slack):
    """Return the pieces where joint ``j`` moved by ``move`` leaves [low, high], and the times."""
    c = rows.coeffs[:, :, j] + rows.units @ move
    ends = np.concatenate([c[1:, 0], [rows.last_point[j]]])
    q_low, q_high, t_low, t_high = (x[:, 0] for x in position_extrema(
        c[:, :, None], rows.widths, ends[:, None]))
    out = np.flatnonzero((q_low < low - slack[0]) | (q_high > high + slack[1]))
    return out, np.stack([t_low[out], t_high[out]], axis=1)
