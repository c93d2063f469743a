"""
A mode's ringing after the stop cancelled by moving the knots of a rest-to-rest 555 plan.

With a ``vibration_frequency`` f the default plan averages its speed profile
over two windows of 1/f (:mod:`inner_knots`, step 2), which puts spectral
zeros at f and 2 f in the *path* acceleration.  A joint's acceleration is
``q'(s) s'' + q''(s) s'**2``: the path's curvature modulates the profile, so
on the vendor arms' curved paths the ringing after the stop stayed at up to
0.6 of TOPP-RA's (the Panda; 0.17 at the median), where the target is 0.1.

The ringing after the stop is one complex number a joint, the mode's content
``Z = int qdd(t) exp(lambda (T - t)) dt`` (:mod:`residual_vibration`), and
with the knot times fixed the 555 spline is linear in its knot positions
(eq. 7 at rest; :func:`inner_knots.unit_splines`).  So ``Z`` is linear in
the moves ``d`` of the free knots (every knot but the waypoints):
``Z(d) = Z0 + C d``, ``C`` the unit splines' contents
(:func:`residual_vibration.spline_content`).  Per joint, the move of least
weighted norm (each knot weighted by its room, ``(1 - r)**2`` for the
largest v/a/j peak ratio ``r`` next to it) meets the rows:

* ``Z`` at f cancelled (two rows);
* ``Z`` at 2 f, the windows' second zero, unchanged (two rows);
* the end jerks and snaps unchanged (four rows): each joint still leaves its
  start and reaches its goal along its move (step 4 of :mod:`inner_knots`).

The move is then scaled by the largest share ``alpha`` in [0, 1] (bisected)
that keeps, exactly, the joint's v/a/j peaks within what the plan reached
(no stretch: a stretch would move the cancellation off the mode), its
position within the position limits and, in the first and last segment, on
its side of the start and the goal (it was; or no further past), and its
content during the motion, ``|Z(t)|`` at f and 2 f, below the plan's largest
share over its joints (the ringing during the motion is not traded for the
ringing after the stop).  ``Z`` of the moved joint is ``(1 - alpha) Z0``.
Whatever stopped ``alpha`` below 1 (a peak, a position, the content up to
some time) is held where it is by one more row, and the move solved again:
:data:`ROUNDS` rounds, the largest share kept.  The waypoints keep their
times, the other joints are untouched and C4 holds at every knot.

A segment with no knot of its own between two waypoints gets one at its
middle, placed on the spline (:func:`position_limit_knots.knot_layout`);
a request with fewer free knots than rows is left as it is, and so is one
whose samples times splines exceed ``MAX_SPLINE_SAMPLE_VALUES`` (checked
before anything is allocated).
"""

import numpy as np
from scipy.special import factorial

from .inner_knots import end_jerks, end_snaps, moved_trajectory, unit_splines
from .position_limit_knots import knot_layout
from ..speed_profile.residual_vibration import (
    content_envelope, content_weights, MAX_SPLINE_SAMPLE_VALUES, sampled_content,
    spline_sample_count, spline_samples, SPLINE_SAMPLES_PER_PERIOD, static_scale)
from ..spline.continuity_system import spline_coefficients
from ..spline.limits import limit_ratios
from ..spline.peaks import position_extrema, segment_peak_times

# Bisection steps of each joint's share alpha of its cancelling move a round:
# the ringing left is (1 - alpha) of the plan's, so the search leaves 2**-6 of
# it at most; 8 steps left the same medians on random requests, in more time.
ALPHA_STEPS = 6
# Rounds a joint: each holds the peaks that stopped the last move where they
# are (a row each) and solves again; the largest share over the rounds is kept.
# 3 rounds left the Panda's residual at 0.14 of TOPP-RA's (median), 6 at 0.00, 10 as 6.
ROUNDS = 6
# Pieces on either side of a free knot whose peak ratios set its room to move.
ROOM_PIECES = 2
# The least room (weight) of a knot next to a binding peak: it moves, a little.
ROOM_FLOOR = 1e-6
# Samples of each piece at least, whatever the mode: a piece's acceleration is a
# cubic, and 2-3 samples of a 35 ms piece (a 0.8 Hz mode) misjudged the ringing
# during the motion by 4 % (helper-40).
PIECE_SAMPLES = 8
# How far above the plan's own largest content a moved joint's may go: round-off.
ENVELOPE_RTOL = 1e-9
# How closely a move must meet its rows (unit rows), relative to the largest target.
ROWS_RTOL = 1e-9
# A joint whose residual share (the ringing over the static deflection at
# its acceleration limit, residual_vibration) is below this is not moved: 5 %
# of what a time-optimal stop leaves (about 1-1.5), half the target of 0.1 of
# TOPP-RA's.  At 8 Hz, where the windows leave shares of 0.03-0.07, moving
# every joint from 0.02 on cost 7.5 times TOPP-RA's planning for 0.04 -> 0.03.
NEGLIGIBLE_SHARE = 0.05


def cancelled_residual(traj, frequency, low, high):
    """
    Return the rest-to-rest 555 ``traj`` with its knots moved to cancel its ringing, or None.

    ``frequency`` [Hz] is the mode's (damping :data:`residual_vibration.DAMPING`);
    ``low``, ``high`` (n,) the position limits (+-inf where unbounded): a
    joint within them stays within them exactly, one past them (by
    round-off, or a plan that the caller pulls within next) goes no
    further.
    Returns None when no joint's ringing is above :data:`NEGLIGIBLE_SHARE`
    or none can move; else ``(trajectory, joints, before, after)``: the
    moved trajectory (a copy of ``traj.optimizer``; not longer than
    ``traj``), the joints moved, and the largest residual share over the
    joints before and after the moves (the trapezoid sums of
    :func:`residual_vibration.spline_content`).
    """
    built = knot_layout(traj, insert=True)
    if built is None:
        return None
    widths, waypoint_knots = built
    times = np.concatenate([[0.0], np.cumsum(widths)])
    free = np.setdiff1d(np.arange(times.size), waypoint_knots)
    if free.size < 8:
        return None     # fewer free knots than the rows below
    n = traj.n_joints
    positions = traj.evaluate(times)
    positions[waypoint_knots] = traj.waypoints
    coeffs = spline_coefficients('555', positions, widths, (np.zeros(n),) * 4)
    step = 1.0 / (SPLINE_SAMPLES_PER_PERIOD * 2.0 * frequency)
    columns = n + free.size
    if (spline_sample_count(times, step, PIECE_SAMPLES) * columns > MAX_SPLINE_SAMPLE_VALUES
            or 6 * widths.size * free.size > MAX_SPLINE_SAMPLE_VALUES):
        return None     # a long plan, or a high mode: left as it is, before allocating
    units = unit_splines(times.size, free, widths)                     # (S, 6, m)
    # The windows' second zero (2 f) stays where it is: the moves add no content there.
    steps, accelerations = spline_samples(np.concatenate([coeffs, units], axis=2), times,
                                          step, PIECE_SAMPLES)           # (T, n + m)
    contents = sampled_content(steps, accelerations, (frequency, 2.0 * frequency))
    content = contents[:2, :n]
    # The end jerks and snaps stay as they are: each joint leaves its start and
    # reaches its goal the way step 4 of inner_knots turned it (along its move;
    # where it zeroed a jerk, the snap sets the way).  The Panda's worst residual
    # at 4 Hz was 0.57 of TOPP-RA's with the jerks alone, 0.22 with both (seed 7001).
    rows = np.vstack([contents[:, n:], end_jerks(units, widths[-1]),
                      end_snaps(units, widths[-1])])                        # (8, m)
    shares = np.hypot(content[0], content[1]) * static_scale(frequency, traj.limits.acceleration)
    joints = np.flatnonzero(shares > NEGLIGIBLE_SHARE)
    if joints.size == 0:
        return None
    mode = _Envelope(steps, accelerations[:, :n], accelerations[:, n:],
                     (frequency, 2.0 * frequency), traj.limits)
    search = _ShareSearch(traj, coeffs, widths, units, (low, high), waypoint_knots, mode)
    weights = _room_weights(search.ratios.max(axis=2), free)          # (m, n)
    held = {j: (rows, np.concatenate([-content[:, j], np.zeros(rows.shape[0] - 2)]))
            for j in joints}
    moves, alpha = np.zeros((free.size, n)), np.zeros(n)
    for _ in range(ROUNDS):
        trial = np.zeros_like(moves)
        for j in list(held):
            move = _least_move(*held[j], weights[:, j])
            if move is None:
                del held[j]
            else:
                trial[:, j] = move
        searched = np.array(sorted(held), dtype=int)
        if searched.size == 0:
            break
        shares_of, over = search.largest(trial, searched)
        better = shares_of > alpha[searched]
        moves[:, searched[better]] = trial[:, searched[better]]
        alpha[searched[better]] = shares_of[better]
        for j in searched:
            if over.get(j) is None:
                del held[j]
            else:
                a, b = held[j]
                held[j] = (np.vstack([a, over[j]]), np.append(b, np.zeros(len(over[j]))))
        if not held:
            break
    moved = np.flatnonzero(alpha > 0.0)
    if moved.size == 0:
        return None
    found = moved_trajectory(traj, widths, positions, waypoint_knots, coeffs, units, free,
                             moves * alpha)
    if found is None or found.duration > traj.duration:
        return None
    return found, moved, float(np.max(shares)), float(np.max(shares * (1.0 - alpha)))


def _least_move(rows, target, weights):
    """
    Return the move d (m,) of least ``sum(d**2 / weights)`` with ``rows @ d = target``, or None.

    Each row is scaled to unit length (the end jerks' rows are 1e6 times
    the contents'), and the weighted system solved by least squares (SVD):
    None where it cannot be met to :data:`ROWS_RTOL` (rows that contradict
    each other: held peaks, say).
    """
    norms = np.linalg.norm(rows, axis=1)
    keep = norms > 0.0
    if not np.all(target[~keep] == 0.0):
        return None
    a, b = rows[keep] / norms[keep, None], target[keep] / norms[keep]
    root = np.sqrt(weights)
    try:
        y = np.linalg.lstsq(a * root, b, rcond=None)[0]
    except np.linalg.LinAlgError:
        return None
    move = root * y
    if not np.all(np.isfinite(move)) or np.max(np.abs(a @ move - b)) > ROWS_RTOL * max(
            1.0, np.max(np.abs(b)) if b.size else 1.0):
        return None
    return move


def _room_weights(ratios, free):
    """
    Return (m, n): how freely each free knot may move, from the peak ratios (S, n).

    ``(1 - r)**2`` with ``r`` the joint's largest v/a/j peak ratio on the
    pieces next to the knot (:data:`ROOM_PIECES` either side), at least
    :data:`ROOM_FLOOR`: knots next to a binding limit hardly move.
    """
    last = ratios.shape[0] - 1
    near = np.zeros((free.size, ratios.shape[1]))
    for offset in range(-ROOM_PIECES, ROOM_PIECES):
        near = np.maximum(near, ratios[np.clip(free + offset, 0, last)])
    return np.clip(1.0 - near, 0.0, 1.0) ** 2 + ROOM_FLOOR


class _Envelope:
    """
    The modes' content during the motion: a move may not make them ring more than the plan.

    ``|Z(t)|`` (:func:`residual_vibration.content_envelope`) of each joint
    moved, at f and at 2 f, at the samples ``steps`` apart of the plan's
    ``accelerations`` (T, n) and of the unit splines' ``units`` (T, m), may
    not rise above the plan's own largest share over its joints (the
    content over each joint's static deflection): the ringing during the
    motion (the benchmark's peak) is not traded for the ringing after the
    stop.
    """

    def __init__(self, steps, accelerations, units, frequencies, limits):
        self.steps, self.accelerations, self.units = steps, accelerations, units
        self.frequencies = frequencies
        self.largest = []
        for f in frequencies:
            scale = static_scale(f, limits.acceleration)
            shares = content_envelope(steps, accelerations, f).max(axis=0) * scale
            self.largest.append(shares.max() / scale)
        self.shift = None

    def move(self, moves):
        """Set the moves (m, k) whose shares :meth:`held` checks."""
        self.shift = self.units @ moves

    def _over(self, alpha, joints):
        """Return [(T, k) a mode]: how far the moved ``joints``' envelope rises above its bound."""
        moved = self.accelerations[:, joints] + self.shift * alpha
        return [content_envelope(self.steps, moved, f)
                - largest[joints] * (1.0 + ENVELOPE_RTOL)
                for f, largest in zip(self.frequencies, self.largest)]

    def held(self, alpha, joints):
        """Whether ``joints`` (k,), moved by their ``alpha`` (k,), ring no more than before."""
        return np.all([over.max(axis=0) <= 0.0 for over in self._over(alpha, joints)], axis=0)

    def rows(self, alpha, joints, k):
        """
        Return the content up to where the ``k``-th joint rises most, a mode that rises.

        Held (no content added up to there), the next round moves the knots after it.
        """
        rows = []
        for f, over in zip(self.frequencies, self._over(alpha, joints)):
            at = int(np.argmax(over[:, k]))
            if over[at, k] > 0.0 and at > 0:
                z = content_weights(self.steps[:at], f) @ self.units[:at + 1]
                rows += [z.real, z.imag]
        return rows


def _position_bounds(points, pieces, waypoint_knots, bounds):
    """
    Return (low, high), each (S, n): the position bounds of every piece and joint.

    The position limits ``bounds`` (low, high (n,)), and on the first and
    last segment's pieces the start and the goal on the side the joint
    moves away from and towards (its chord there): a joint that left its
    start and reached its goal along its move (step 4 of :mod:`inner_knots`)
    does not swing back past them.
    """
    low = np.tile(bounds[0], (pieces, 1)).astype(float)
    high = np.tile(bounds[1], (pieces, 1)).astype(float)
    first, last = slice(0, waypoint_knots[1]), slice(waypoint_knots[-2], pieces)
    for at, end, sign in ((first, points[0], np.sign(points[1] - points[0])),
                          (last, points[-1], np.sign(points[-2] - points[-1]))):
        # From the start the joint moves towards sign; the goal is reached from -sign
        # (the chord before it, seen from the goal, points along sign).
        low[at] = np.where(sign > 0, np.maximum(low[at], end), low[at])
        high[at] = np.where(sign < 0, np.minimum(high[at], end), high[at])
    return low, high


class _ShareSearch:
    """
    The largest share of each joint's move that keeps it within its limits.

    The limits are the v/a/j peaks the plan itself reaches (at least the
    limits: a plan at round-off above one is not pushed further), and the
    position bounds (:func:`_position_bounds`), or, on a piece and side
    where the joint is already past one, its own excess there.
    """

    def __init__(self, traj, coeffs, widths, units, bounds, waypoint_knots, mode):
        self.coeffs, self.widths, self.units, self.limits = coeffs, widths, units, traj.limits
        self.mode = mode        # the _Envelope of the ringing during the motion
        self.ends = np.concatenate([coeffs[1:, 0, :], traj.waypoints[-1:]])
        self.ratios = limit_ratios(coeffs, widths, traj.limits)           # (S, n, 3)
        self.peak = np.maximum(self.ratios.max(axis=(0, 2)), 1.0)
        self.low, self.high = _position_bounds(traj.waypoints, widths.size, waypoint_knots,
                                               bounds)                   # (S, n) each
        self.pieces = np.flatnonzero(np.any(np.isfinite(self.low) | np.isfinite(self.high),
                                            axis=1))
        joints = np.arange(coeffs.shape[2])
        self.below, self.above = self._excess(coeffs, self.ends, joints)[:2]

    def _excess(self, c, ends, joints):
        """
        Return (below, above, t_low, t_high): how far ``joints`` go past each bound, and when.

        ``c`` (S, 6, k) are the pieces of ``joints`` (k,); each is (P, k)
        over :attr:`pieces` (the ones with a bound), 0 within the bound:
        each piece's own excess on each side, so that a joint past one
        bound somewhere may not go past another instead (helper-40).
        """
        if self.pieces.size == 0:
            empty = np.zeros((0, joints.size))
            return empty, empty, empty, empty
        q_low, q_high, t_low, t_high = position_extrema(
            c[self.pieces], self.widths[self.pieces], ends[self.pieces])
        low, high = self.low[np.ix_(self.pieces, joints)], self.high[np.ix_(self.pieces, joints)]
        with np.errstate(invalid='ignore'):
            below = np.nan_to_num(low - q_low, nan=0.0, neginf=0.0).clip(0.0)
            above = np.nan_to_num(q_high - high, nan=0.0, neginf=0.0).clip(0.0)
        return below, above, t_low, t_high

    def _within(self, shifts, shift_ends, alpha, joints):
        """Whether each of ``joints`` moved by ``alpha`` (its share) is within its limits."""
        c = self.coeffs[:, :, joints] + shifts * alpha
        ok = limit_ratios(c, self.widths, self.limits_of(joints)).max(axis=(0, 2)) \
            <= self.peak[joints]
        ok &= self.mode.held(alpha, joints)
        below, above = self._excess(c, self.ends[:, joints] + shift_ends * alpha, joints)[:2]
        ok &= np.all(below <= self.below[:, joints], axis=0)
        ok &= np.all(above <= self.above[:, joints], axis=0)
        return ok

    def limits_of(self, joints):
        """Return the :class:`JointLimits` of ``joints`` alone."""
        return type(self.limits)(self.limits.velocity[joints], self.limits.acceleration[joints],
                                 self.limits.jerk[joints])

    def largest(self, moves, joints):
        """
        Return (alpha (k,), {joint: rows of the peaks that stop its move, or None}).

        ``moves`` (m, n); the shares of ``joints`` (k,), bisected
        (:data:`ALPHA_STEPS`) where the whole move leaves the limits.  The
        rows (r, m) are the unit splines' derivative at each piece's peak
        that the next step up leaves: held there, the next round moves
        around them.
        """
        shifts = np.einsum('skm,mn->skn', self.units, moves[:, joints])   # (S, 6, k)
        self.mode.move(moves[:, joints])
        shift_ends = np.concatenate([shifts[1:, 0, :], np.zeros((1, joints.size))])
        lo, hi = np.zeros(joints.size), np.ones(joints.size)
        whole = self._within(shifts, shift_ends, hi, joints)
        lo[whole] = 1.0
        for _ in range(ALPHA_STEPS if not whole.all() else 0):
            mid = np.where(whole, 1.0, 0.5 * (lo + hi))
            good = self._within(shifts, shift_ends, mid, joints)
            lo = np.where(good, mid, lo)
            hi = np.where(good | whole, hi, mid)
        over = {}
        c = self.coeffs[:, :, joints] + shifts * hi
        ratios = limit_ratios(c, self.widths, self.limits_of(joints))      # (S, k, 3)
        for k, j in enumerate(joints):
            if whole[k]:
                continue
            rows = []
            for piece, quantity in zip(*np.nonzero(ratios[:, k] > self.peak[j])):
                derivative = int(quantity) + 1
                at = segment_peak_times(c[piece:piece + 1, :, k:k + 1],
                                        self.widths[piece:piece + 1], derivative)[0, 0]
                powers = np.zeros(6)
                p = np.arange(derivative, 6)
                powers[derivative:] = factorial(p) / factorial(p - derivative) * at ** (
                    p - derivative)
                rows.append(powers @ self.units[piece])
            rows.extend(self.mode.rows(hi, joints, k))
            rows.extend(self._position_rows(c[:, :, k], shift_ends[:, k] * hi[k], j))
            over[int(j)] = np.array(rows) if rows else None
        return lo, over

    def _position_rows(self, c, shift_ends, j):
        """Return the rows (unit splines' positions) where joint ``j``'s ``c`` passes a bound."""
        if self.pieces.size == 0:
            return []
        ends = (self.ends[:, j] + shift_ends)[:, None]
        below, above, t_low, t_high = (x[:, 0] for x in self._excess(
            c[:, :, None], ends, np.array([j])))
        rows = []
        for past, was, times in ((below, self.below[:, j], t_low),
                                 (above, self.above[:, j], t_high)):
            further = past - was
            worst = int(np.argmax(further))
            if further[worst] > 0.0:
                powers = times[worst] ** np.arange(6)
                rows.append(powers @ self.units[self.pieces[worst]])
        return rows
