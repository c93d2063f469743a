"""
A C4 555 spline timed along a given joint path (issue 24): the inner-knot construction on any path.

:mod:`inner_knots` builds its own path (the 555 spline through the
waypoints).  Here the caller gives the path: joint positions ``q`` at
increasing path coordinates ``s`` (e.g. the inverse kinematics of a tool's
straight lines, ``s`` the tool's arc length), with some of them the
waypoints that must be passed exactly.  The rest is the same construction
(module docstring of :mod:`inner_knots`, steps 2-6):

1. Path.  A C2 cubic spline through the samples, ``q(s)``; its grid has
   :data:`GRID_PER_SAMPLE` steps per sample interval.
2. Speed along it.  The fastest path speed under the caller's constraint
   objects (:mod:`constraints`: joint velocity and acceleration always,
   tool speed or torque when given), times the local factors, averaged over
   the smoothing windows; rest to rest.
   A waypoint where that profile nearly stops (a sharp corner of the path)
   is made a stop, and each span between stops is averaged on its own.
   From rest at the start and to rest at the end the profile's path jerk
   is bounded (:meth:`JointPathSamples._ramps`), so the first and last
   knots lie where a jerk-limited spline can reach them.  Without windows
   and with ``round_corners`` (a tool speed) the corners where the profile
   meets its speed caps are rounded instead (:class:`_RoundedTiming`).
3. Knots.  Per segment between waypoints, knots at given time fractions of
   the segment (``fractions``) or at equal ones, as many as the jerk ramp
   and the caller's shortest piece allow, up to the caller's count
   (:func:`inner_knots.knots_per_segment`), each at the path's position at
   its time; the waypoints exactly.  With rounded corners the pieces
   around them are split from the start (:func:`_transition_fractions`).
4-6. The C4 quintic spline through them (eqs. 13-23, :mod:`continuity_system`),
   its exact v/a/j factors (and the caller's ``piece_factors`` for limits the
   polynomials do not show, a tool speed), scaled to its limits, and the
   iteration on the local factors; the shortest spline is kept, then its
   few pieces over their limits are slowed down harder (:func:`_polish`),
   since one of them slows the whole rest-to-rest spline down.

The caller decides where more knots are needed (:func:`midpoint_fractions`
splits pieces at their time midpoints): the spline passes through its
knots, which lie on the path, so more knots bring it closer to the path
between them.  This module knows nothing of tools: the tool-path module
measures the deviation and asks again.
"""

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from .inner_knots import (end_ramps, iterate_knots, IterationBudget, kept_trajectory,
                          KnotCandidate, SpeedProfile, TimingProblem)
from .knot_pieces import (equal_fractions, knot_times, knots_per_segment, ramp_accelerations,
                          shortest_piece)
from ..constraints import GriddedPath, JointAcceleration, JointTorque, JointVelocity
from ..plan_options import DEFAULT_SMOOTHING
from ..speed_profile.averaged_timing import AveragedTiming, regula_falsi
from ..speed_profile.path_velocity import path_position, PathLimits
from ..speed_profile.residual_vibration import remeasure_residual

# The constants of the timing along a path, each with its reason in one line;
# the measurements behind them are in doc/inner_knots.md ("Where the
# constants come from").
# Grid steps of the speed profile per interval between two path samples.
GRID_PER_SAMPLE = 2
# Most knots per segment between waypoints (inner knots plus the waypoint).
MAX_SEGMENT_KNOTS = 256
# Most inner knots per segment of the first spline (more are inserted where needed).
PATH_START_KNOTS = 8
# A waypoint where the fastest profile's speed is below this share of both
# neighbouring segments' top speeds is a stop (JointPathSamples).
STOP_RATIO = 0.2
# A piece lasts at least this many jerk ramp times a / j (inner_knots' step 3
# keeps 1.5 on its coarser knots; along a sampled path 1 is shorter and as smooth).
PATH_RAMP_PIECES = 1.0
# Start and end ramps (JointPathSamples): from rest the profile's path jerk
# is at most this share of the joints' (q' s''' alone; the spline's exact
# factors hold the rest), so the first knots lie where the jerk limit reaches them.
RAMP_SHARE = 0.7
# Iterations of the local factors and step 6's exponent per timing: more
# iterations, each dividing the factor out fully, shorten a seam further.
PATH_ITERATIONS = 30
PATH_RELAX = 1.0
# The iteration along a path stops after two candidates in a row that gain
# less than this share (inner_knots.MIN_GAIN is 1e-3): later ones gain next to nothing.
PATH_MIN_GAIN = 2e-3
# Polish (_polish): rounds, and the exponent of the factors over 1 that slow
# the binding pieces down (beyond what they need: their neighbours pull them back).
POLISH_ROUNDS = 6
POLISH_RELAX = 4.0
# The polish stops after a round that gains less than this share of the total.
POLISH_GAIN = 1e-4
# Corner rounding (JointPathSamples' ``rounding``, tool lines with a speed
# limit): the centred window in shortest pieces (the larger of the jerk ramp
# and ``min_piece``); the pieces where the first profile crosses CAP_SHARE of
# its first-order bounds, and their neighbours, are split in two from the
# start (:func:`_transition_fractions`), not within SPLIT_CLEARANCE windows
# of a stop: a C4 spline through knots a window apart rings after such a corner.
CORNER_ROUNDING = 1.2
CAP_SHARE = 0.98
SPLIT_CLEARANCE = 0.5
# Samples per piece of the first profile's state (at its cap or not).
TRANSITION_SAMPLES = 8
# Samples of the bracket of _RoundedTiming.time_at, and its regula falsi steps
# (averaged_timing.regula_falsi, Illinois) between the two around the target:
# the fewest that find every position to test_path_constraints' tolerance.
INVERSE_SAMPLES = 17
INVERSE_REFINEMENTS = 4


class JointPathSamples:
    """
    A joint path through samples ``q`` (K, n) at path coordinates ``s`` (K,), for the timing.

    ``waypoint_index`` (N,) are the samples that are waypoints (the first
    and the last sample among them).  ``constraints`` are the path-velocity
    constraint objects beyond the joint velocity and acceleration limits
    (which come from ``limits``); ``piece_factors(coeffs, pieces)``, when
    given, returns per spline piece (P, k) the factors by which the piece
    must be slowed down for limits the polynomials do not show exactly (a
    tool speed), first order: they join the exact v/a/j factors of step 5.

    Stops: a waypoint where the fastest profile nearly stops (its speed
    below :data:`STOP_RATIO` of the slower of the two neighbouring
    segments' top speeds: a sharp corner of the path) is made a stop, and
    the smoothing windows average each span between stops on its own, so
    the averaged profile still stops there.

    What :class:`inner_knots.KnotCandidate` reads: ``s``, ``steps``,
    ``waypoint_s``, ``points``, ``ppoly``, ``limits`` (a :class:`PathLimits`),
    ``start``, ``end``, ``most``, ``min_piece``, ``ramp_pieces``,
    ``ramp_acceleration`` (:func:`knot_pieces.ramp_accelerations`),
    ``piece_factors``, ``torque_neighbours`` (0), ``keep_time_scale``
    (False), ``rounding``, ``windows`` and :meth:`timing`.

    ``round_corners`` (tool lines with a speed limit, no smoothing
    windows): the profile's corners are rounded over a centred window
    ``rounding`` [s] long (0 without; :class:`_RoundedTiming`), the first
    knots are split where the profile meets its first-order bounds
    ``speed_caps`` (:func:`_transition_fractions`), and step 6 lowers the
    local factors over the window's reach
    (:meth:`inner_knots.KnotCandidate.relaxed`).
    """

    def __init__(self, s, q, waypoint_index, limits, constraints=(),
                 windows=DEFAULT_SMOOTHING, piece_factors=None, most=None,
                 min_piece=0.0, jerk_ramps=True, round_corners=False):
        """Interpolate the samples and prepare the constraints on the grid."""
        s = np.asarray(s, float)
        q = np.asarray(q, float)
        if s.ndim != 1 or q.shape[0] != s.size or s.size < 2 or not np.all(np.diff(s) > 0.0):
            raise ValueError('path samples need increasing path coordinates, one per row')
        self.ppoly = CubicSpline(s, q, axis=0)
        fractions = np.arange(GRID_PER_SAMPLE) / GRID_PER_SAMPLE
        self.s = np.concatenate([(s[:-1, None] + fractions * np.diff(s)[:, None]).ravel(),
                                 s[-1:]])
        self.steps = np.diff(self.s)
        index = np.asarray(waypoint_index, int)
        self.waypoint_s = s[index]
        self.points = q[index]
        self.gridded = GriddedPath.of_ppoly(self.ppoly, self.s)
        constraints = (JointVelocity(limits.velocity),
                       JointAcceleration(limits.acceleration)) + tuple(constraints)
        self.limits = PathLimits(self.gridded, constraints)
        self.start = self.end = 0.0
        self.most = PATH_START_KNOTS if most is None else int(most)
        self.min_piece = float(min_piece)
        self.ramp_pieces = PATH_RAMP_PIECES
        self.torque_neighbours = 0.0
        self.keep_time_scale = False
        self.windows = tuple(windows)
        self.piece_factors = piece_factors
        self.stops = self._stops(self.limits.profile(np.ones(self.s.size)))
        self.limits.stop_at(self.stops)
        self.ramp_acceleration = ramp_accelerations(
            self.limits, self.gridded, limits,
            any(isinstance(c, JointTorque) for c in constraints))
        if jerk_ramps:
            self.limits.x_max = np.minimum(self.limits.x_max,
                                           self._ramps(self.gridded.first, limits.jerk))
        # The centred window of the corner rounding [s] (0: none).
        self.rounding = 0.0
        self.speed_caps = None
        # Step 2's profile is second order here (inner_knots._Path.third_order).
        self.third_order = None
        if round_corners and not self.windows:
            # The first-order bounds alone (no stops, no ramps from rest, no
            # acceleration's speed bounds): the caps whose corners are rounded.
            self.speed_caps = np.min([c.squared_speed_limit(self.gridded) for c in constraints
                                      if c.order == 1], axis=0)
            self.rounding = CORNER_ROUNDING * shortest_piece(
                limits, self.min_piece, self.ramp_pieces, self.ramp_acceleration)

    def _ramps(self, first, jerk):
        """
        Return the squared speeds (M + 1,) of a constant path jerk from the start and to the end.

        :func:`inner_knots.end_ramps` with :data:`RAMP_SHARE`.  As a bound
        on ``x`` it makes the profile leave rest like that until its path
        acceleration reaches the acceleration limit, where the ordinary
        profile takes over (the bound's acceleration ``J t`` grows past it).
        """
        return end_ramps(self.s, first, jerk, RAMP_SHARE)

    def _stops(self, x):
        """Grid indices (first, stops, last) where the profile ``x`` nearly stops."""
        grid = np.searchsorted(self.s, self.waypoint_s)
        top = np.array([np.max(x[a:b + 1]) for a, b in zip(grid[:-1], grid[1:])])
        slower = np.minimum(top[:-1], top[1:])
        inner = grid[1:-1][x[grid[1:-1]] < STOP_RATIO ** 2 * slower]
        return np.concatenate([grid[:1], inner, grid[-1:]])

    def timing(self, times, x):
        """Return the averaged path position in time (step 2), span by span between stops."""
        return _SpanTiming(times, x, self.s, self.windows, self.stops, self.rounding)


class _SpanTiming:
    """
    :class:`averaged_timing.AveragedTiming` of every span between stops, one after the other.

    Each span starts and ends at rest, so each is averaged on its own and
    lasts its windows longer; ``time_at`` and ``position_at`` as there.
    """

    def __init__(self, times, x, s, windows, stops, rounding=0.0):
        self.spans, offsets = [], [0.0]
        for a, b in zip(stops[:-1], stops[1:]):
            args = (times[a:b + 1] - times[a], x[a:b + 1], s[a:b + 1] - s[a])
            span = _RoundedTiming(*args, rounding) if rounding else AveragedTiming(*args, windows)
            self.spans.append(span)
            offsets.append(offsets[-1] + span.duration)
        self.offsets = np.array(offsets)
        self.s_start = s[stops]
        self.duration = offsets[-1]

    def time_at(self, s):
        """Return the times at which the path positions ``s`` are passed."""
        def of_span(j, span, mine):
            return self.offsets[j] + span.time_at(np.clip(mine - self.s_start[j], 0.0, span.s[-1]))

        return self._by_span(s, self.s_start, of_span)

    def position_at(self, t):
        """Return the path position at the times ``t``."""
        def of_span(j, span, mine):
            return self.s_start[j] + span.position_at(mine - self.offsets[j])

        return self._by_span(t, self.offsets, of_span)

    def _by_span(self, values, starts, of_span):
        """Map ``values`` by ``of_span(j, span, values in span j)``, span j from ``starts[j]``."""
        values = np.asarray(values, float)
        k = np.clip(np.searchsorted(starts, values, side='right') - 1, 0, len(self.spans) - 1)
        out = np.empty_like(values)
        for j in np.unique(k):
            mine = k == j
            out[mine] = of_span(j, self.spans[j], values[mine])
        return out


class _RoundedTiming(AveragedTiming):
    """
    A span's path position in time with its corners rounded: a centred average, blended.

    ``position_at(t)`` is ``p + w(t) (a(t) - p)``: ``p`` the plain
    profile's position, ``a`` its average over ``[t - W / 2, t + W / 2]``
    (the one-window :class:`averaged_timing.AveragedTiming` at
    ``t + W / 2``, the span's ends held beyond it) and ``w`` a blend from 0 at each end of the
    span (a stop, where the profile rests) to 1 one window ``W`` inside it,
    so the stops keep their times and their rest.  The blend
    ``d**3 (10 - 15 d + 6 d**2)`` (``d`` the distance in windows) has no
    first or second derivative at either end, so it adds no jump to the
    acceleration (a smoothstep ``d**2 (3 - 2 d)`` jumped it by ``6 (a - p)
    / W**2`` one window from every stop).  The span keeps its duration (a
    centred window).
    """

    def __init__(self, times, x, s, width):
        """Prepare the average of the profile ``x`` at ``times``, ``s`` over ``width`` [s]."""
        self.width = width
        super().__init__(times, x, s, (width,))
        self.duration = times[-1]

    def time_at(self, s):
        """
        Return the times at which the path positions ``s`` are passed (the ends: at rest).

        An average over ``[t - W / 2, t + W / 2]`` of an increasing ``s(t)``
        lies between its values at the ends, and so does the blend with
        ``s(t)`` itself: the rounded profile passes ``s`` within half a window
        of the plain one.  That bracket is sampled at
        :data:`INVERSE_SAMPLES` times in one call and the crossing found by
        :func:`averaged_timing.regula_falsi` between the two samples around it,
        :data:`INVERSE_REFINEMENTS` steps (five calls of :meth:`position_at`
        where :class:`averaged_timing.AveragedTiming`'s table and regula falsi
        make six, on a longer table).
        """
        s = np.asarray(s, float)
        out = np.where(s >= self.s[-1], self.duration, 0.0)
        inner = np.flatnonzero((s > 0.0) & (s < self.s[-1]))
        if inner.size == 0:
            # Only the span's ends (stops), as the waypoints mostly are.
            return out
        target = s[inner]
        plain = np.interp(target, self.s, self.times)
        lo = np.maximum(plain - 0.5 * self.width, 0.0)
        hi = np.minimum(plain + 0.5 * self.width, self.duration)
        grid = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, INVERSE_SAMPLES)
        values = np.maximum.accumulate(self.position_at(grid.ravel()).reshape(grid.shape),
                                       axis=1) - target[:, None]
        j = np.clip(np.sum(values < 0.0, axis=1) - 1, 0, INVERSE_SAMPLES - 2)
        rows = np.arange(target.size)
        out[inner] = regula_falsi(self.position_at, target, grid[rows, j], grid[rows, j + 1],
                                  values[rows, j], values[rows, j + 1], INVERSE_REFINEMENTS)
        return out

    def position_at(self, t):
        """Return the path position at the times ``t``."""
        t = np.clip(np.asarray(t, float), 0.0, self.duration)
        plain = path_position(self.times, self.x, self.s, t)
        mean = AveragedTiming.position_at(self, t + 0.5 * self.width)
        d = np.clip(np.minimum(t, self.duration - t) / self.width, 0.0, 1.0)
        blend = d * d * d * (10.0 + d * (6.0 * d - 15.0))
        return np.clip(plain + blend * (mean - plain), 0.0, self.s[-1])


@dataclass
class PathTiming:
    """
    The spline timed along a path: ``trajectory`` and its knots.

    ``trajectory`` passes the waypoints at ``trajectory.waypoint_times``;
    ``knot_s`` (K,) are the knots' path coordinates, ``fractions`` the time
    fractions of the knots per segment (for :func:`midpoint_fractions`),
    ``iterations`` the splines built.
    """

    trajectory: object
    knot_s: np.ndarray
    fractions: list
    iterations: int
    local: np.ndarray


def plan_along_path(path, limits, fractions=None, local=None, iterations=None):
    """
    Return the :class:`PathTiming` of the C4 spline along ``path`` (a :class:`JointPathSamples`).

    ``fractions``: knots per segment as time fractions (None: equal ones, as
    many as the jerk ramp allows).  ``local``: the local factors to start
    from (a previous :attr:`PathTiming.local`).  ValueError when no spline
    within the limits is found.
    """
    problem = TimingProblem(path, [np.zeros(path.points.shape[1])] * 4, limits, True)
    start = np.ones(path.s.size) if local is None else local
    budget = IterationBudget(PATH_ITERATIONS if iterations is None else iterations,
                             PATH_RELAX, PATH_MIN_GAIN)
    profile = None
    if fractions is None and path.rounding:
        fractions, profile = _transition_fractions(problem, start)
    best, count = iterate_knots(problem, start, None, None, budget, fractions, profile)
    if best is None:
        raise ValueError('no spline along the path meets the limits')
    best, more = _polish(problem, best, fractions)
    count += more
    traj = kept_trajectory(problem, best, (),
                           {'knots': int(best.pieces.size + 1), 'iterations': count,
                           'smoothing_windows': list(path.windows)})
    if traj is None:
        raise ValueError('no spline along the path meets the limits')
    times = best.knot_times
    ends = best.waypoint_knots
    found = [(times[ends[k]:ends[k + 1]] - times[ends[k]]) / (times[ends[k + 1]] - times[ends[k]])
             for k in range(ends.size - 1)]
    return PathTiming(traj, best.knot_s, found, count, best.local)


def _transition_fractions(problem, local):
    """
    Return the first knots' fractions per segment, split at the speed caps' corners, and a profile.

    The profile is the :class:`inner_knots.SpeedProfile` of ``local`` on
    ``problem``'s path (the first candidate's: the iteration starts from it).

    The knots step 3 places on the profile of ``local`` (equal fractions, as
    many as the jerk ramp allows); a piece where the profile is at
    :data:`CAP_SHARE` of its first-order bounds (``speed_caps``) at some of
    its :data:`TRANSITION_SAMPLES` samples and below it at others, and its
    two neighbours, get a knot at their time midpoints (module constants:
    the spline follows the rounded corner there), each unless it comes
    within :data:`SPLIT_CLEARANCE` rounding windows of a stop or lasts less
    than two shortest pieces.  A crossing next to a stop still has its other
    neighbour split: the local factors usually slow the ramp from rest and
    move the corner out (doc/inner_knots.md, "Where the constants come
    from").
    """
    path, limits = problem.path, problem.limits
    profile = SpeedProfile(path, local)
    if not profile.valid:
        return None, profile
    passed = profile.passed
    counts = knots_per_segment(passed[1:] - passed[:-1], limits, path.most, path.min_piece,
                               path.ramp_pieces, path.ramp_acceleration)
    fractions = equal_fractions(counts)
    times = knot_times(passed, fractions)
    pieces = np.diff(times)
    at = times[:-1, None] + pieces[:, None] * np.linspace(0.0, 1.0, TRANSITION_SAMPLES)
    s = profile.timing.position_at(at.ravel())
    cap = np.interp(s, path.s, path.speed_caps * local * local)
    capped = (np.interp(s, path.s, profile.x) >= CAP_SHARE * cap).reshape(at.shape)
    stops = profile.timing.offsets
    near = np.min(np.abs(at.ravel()[:, None] - stops[None, :]), axis=1).reshape(at.shape)
    clear = np.all(near >= SPLIT_CLEARANCE * path.rounding, axis=1) & \
        (pieces >= 2.0 * path.min_piece)
    crossing = np.any(capped, axis=1) & ~np.all(capped, axis=1)
    split = crossing.copy()
    split[1:] |= crossing[:-1]
    split[:-1] |= crossing[1:]
    split &= clear
    return midpoint_fractions(fractions, np.flatnonzero(split)), profile


def _polish(problem, best, fractions):
    """
    Return (candidate, splines built): ``best`` with its few binding pieces slowed down harder.

    A rest-to-rest spline is slowed down as a whole by its largest factor:
    a piece by a stop that needs 0.5 % more time takes 0.5 % off every
    line's tool speed.  The iteration stalls with a few such pieces, each
    of its steps lowering every piece to its own factor; here only the
    pieces over 1 are lowered, by their factor to :data:`POLISH_RELAX`
    (beyond what they need: their neighbours pull them back), while the
    spline gets shorter by at least :data:`POLISH_GAIN` a round.
    """
    count = 0
    for _ in range(POLISH_ROUNDS):
        if float(np.max(best.factors)) <= 1.0:
            break
        local = best.relaxed(best.local, POLISH_RELAX, floor=1.0)
        candidate = KnotCandidate(problem, local, None, fractions)
        count += 1
        if not (candidate.valid and candidate.better_than(best)):
            break
        gain = best.score - candidate.score
        best = candidate
        if gain < POLISH_GAIN * best.score:
            break
    return best, count


def midpoint_fractions(fractions, pieces, most=MAX_SEGMENT_KNOTS):
    """
    Return ``fractions`` with the pieces ``pieces`` (indices over all segments) split in two.

    A piece is split at the midpoint of its time fractions; a segment keeps
    at most ``most`` knots (None: no bound; :mod:`time_optimal`'s knots
    follow a profile in time, a segment as many as its duration needs).
    """
    out, first = [], 0
    pieces = np.asarray(pieces, int)
    for f in fractions:
        mine = pieces[(pieces >= first) & (pieces < first + f.size)] - first
        ends = np.append(f, 1.0)
        added = 0.5 * (ends[mine] + ends[mine + 1])
        if most is not None:
            added = added[:max(most - f.size, 0)]
        out.append(np.sort(np.concatenate([f, added])))
        first += f.size
    return out


def rescaled(traj, factor):
    """Return the rest-to-rest ``traj`` slowed down by ``factor`` >= 1 (same knots)."""
    if not factor > 1.0:
        return traj
    candidate = _Scaled(traj, factor)
    problem = TimingProblem(candidate, [np.zeros(traj.waypoints.shape[1])] * 4, traj.limits, True)
    scaled = kept_trajectory(problem, candidate, traj.dropped_waypoints,
                             dict(traj.optimizer, time_scale=float(factor)))
    if scaled is None:
        raise ValueError('slowing the spline down failed')
    remeasure_residual(scaled)
    return scaled


class _Scaled:
    """
    The knots of ``traj`` on pieces ``factor`` times longer: what kept_trajectory reads.

    Both of the path (its ``points``) and of the kept candidate.
    """

    def __init__(self, traj, factor):
        self.points = traj.waypoints
        self.pieces = np.diff(traj.breakpoints) * factor
        self.positions = traj.ppoly(traj.breakpoints)
        self.positions[-1] = traj.waypoints[-1]
        self.waypoint_knots = np.searchsorted(traj.breakpoints, traj.waypoint_times)
        self.positions[self.waypoint_knots] = traj.waypoints
        self.coeffs = self.ratios = None      # solved on the pieces by kept_trajectory


__all__ = ['GRID_PER_SAMPLE', 'JointPathSamples', 'midpoint_fractions', 'PathTiming',
           'plan_along_path', 'rescaled']
