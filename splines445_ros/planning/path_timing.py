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
   objects (:mod:`path_constraints`: joint velocity and acceleration always,
   tool speed or torque when given), times the local factors, averaged over
   the smoothing windows; rest to rest.
   A waypoint where that profile nearly stops (a sharp corner of the path)
   is made a stop, and each span between stops is averaged on its own.
   From rest at the start and to rest at the end the profile's path jerk
   is bounded (:meth:`JointPathSamples._ramps`), so the first and last
   knots lie where a jerk-limited spline can reach them.
3. Knots.  Per segment between waypoints, knots at given time fractions of
   the segment (``fractions``) or at equal ones, as many as the jerk ramp
   and the caller's shortest piece allow, up to the caller's count
   (:func:`inner_knots.knots_per_segment`), each at the path's position at
   its time; the waypoints exactly.
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

from .inner_knots import (_Candidate, _iterate, _Timing, _trajectory, DEFAULT_SMOOTHING,
                          end_ramps, ramp_accelerations)
from .path_constraints import GriddedPath, JointAcceleration, JointTorque, JointVelocity
from .path_velocity import PathLimits

# Grid steps of the speed profile per interval between two path samples.
GRID_PER_SAMPLE = 2
# Most knots per segment between waypoints (inner knots plus the waypoint).
MAX_SEGMENT_KNOTS = 256
# Most inner knots per segment of the first spline (more are inserted where needed).
START_KNOTS = 8
# A waypoint where the fastest profile's speed is below this share of both
# neighbouring segments' top speeds is a stop (JointPathSamples).
STOP_RATIO = 0.2
# A piece lasts at least this many jerk ramp times a / j (inner_knots' step 3
# keeps 1.5 on its coarser knots; along a sampled path 1 is shorter and as smooth).
RAMP_PIECES = 1.0
# Start and end ramps (JointPathSamples): from rest the profile's path jerk
# is at most this share of the joints' (q' s''' alone; the spline's exact
# factors hold the rest).  A profile that leaves rest at full acceleration
# puts the first knots where only a jerk over the limit reaches them, and
# the local factors then slow the whole first piece down: on the UR5 seam
# of bench_tool_lines.py (no tool speed) the plan took 3.96 s without the
# ramps, 3.85 s with them at a share of 1.0, 3.84 s at 0.7 and 0.85, 3.86 s
# at 0.6.  At the inner stops (sharp corners) they made it longer (4.03 s):
# there the coarse spline rounds the corner within the tolerance instead.
RAMP_SHARE = 0.7
# Iterations of the local factors and step 6's exponent per timing: on the
# same seam 3.84 s with (15, 0.8), 3.80 s with (30, 1.0).
PATH_ITERATIONS = 30
PATH_RELAX = 1.0
# Polish (_polish): rounds, and the exponent of the factors over 1 that slow
# the binding pieces down; the UR5 seam at 0.25 m/s went from a largest
# factor of 1.0046 (the whole spline slowed down by it) to 1.0002 in 4 rounds.
POLISH_ROUNDS = 6
POLISH_RELAX = 2.0


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

    What :class:`inner_knots._Candidate` reads: ``s``, ``steps``,
    ``waypoint_s``, ``points``, ``ppoly``, ``limits`` (a :class:`PathLimits`),
    ``start``, ``end``, ``most``, ``min_piece``, ``ramp_pieces``,
    ``ramp_acceleration`` (:func:`inner_knots.ramp_accelerations`),
    ``piece_factors``, ``torque_neighbours`` (0), ``keep_time_scale`` (False)
    and :meth:`timing`.
    """

    def __init__(self, s, q, waypoint_index, limits, constraints=(),
                 windows=DEFAULT_SMOOTHING, piece_factors=None, most=None,
                 min_piece=0.0, jerk_ramps=True):
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
        self.most = START_KNOTS if most is None else int(most)
        self.min_piece = float(min_piece)
        self.ramp_pieces = RAMP_PIECES
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
        return _SpanTiming(times, x, self.s, self.windows, self.stops)


class _SpanTiming:
    """
    :class:`inner_knots._Timing` of every span between stops, one after the other.

    Each span starts and ends at rest, so each is averaged on its own and
    lasts its windows longer; ``time_at`` and ``position_at`` as there.
    """

    def __init__(self, times, x, s, windows, stops):
        self.spans, offsets = [], [0.0]
        for a, b in zip(stops[:-1], stops[1:]):
            span = _Timing(times[a:b + 1] - times[a], x[a:b + 1], s[a:b + 1] - s[a], windows)
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
    boundary = [np.zeros(path.points.shape[1])] * 4
    start = np.ones(path.s.size) if local is None else local
    kwargs = {'iterations': PATH_ITERATIONS if iterations is None else iterations,
              'relax': PATH_RELAX}
    best, count = _iterate(path, start, None, boundary, limits, True, None, fractions, **kwargs)
    if best is None:
        raise ValueError('no spline along the path meets the limits')
    best, more = _polish(path, best, boundary, limits, fractions)
    count += more
    traj = _trajectory(path.points, boundary, limits, True, best, (),
                       {'knots': int(best.pieces.size + 1), 'iterations': count,
                        'smoothing_windows': list(path.windows)})
    if traj is None:
        raise ValueError('no spline along the path meets the limits')
    times = best.knot_times
    ends = best.waypoint_knots
    found = [(times[ends[k]:ends[k + 1]] - times[ends[k]]) / (times[ends[k + 1]] - times[ends[k]])
             for k in range(ends.size - 1)]
    return PathTiming(traj, best.knot_s, found, count, best.local)


def _polish(path, best, boundary, limits, fractions):
    """
    Return (candidate, splines built): ``best`` with its few binding pieces slowed down harder.

    A rest-to-rest spline is slowed down as a whole by its largest factor:
    a piece by a stop that needs 0.5 % more time takes 0.5 % off every
    line's tool speed.  The iteration stalls with a few such pieces, each
    of its steps lowering every piece to its own factor; here only the
    pieces over 1 are lowered, by their factor to :data:`POLISH_RELAX`
    (beyond what they need: their neighbours pull them back), while the
    spline gets shorter.
    """
    count = 0
    for _ in range(POLISH_ROUNDS):
        if float(np.max(best.factors)) <= 1.0:
            break
        local = best.relaxed(best.local, POLISH_RELAX, floor=1.0)
        candidate = _Candidate(path, local, None, boundary, limits, True, fractions)
        count += 1
        if not (candidate.valid and candidate.better_than(best)):
            break
        best = candidate
    return best, count


def midpoint_fractions(fractions, pieces):
    """
    Return ``fractions`` with the pieces ``pieces`` (indices over all segments) split in two.

    A piece is split at the midpoint of its time fractions; a segment keeps
    at most :data:`MAX_SEGMENT_KNOTS` knots.
    """
    out, first = [], 0
    pieces = np.asarray(pieces, int)
    for f in fractions:
        mine = pieces[(pieces >= first) & (pieces < first + f.size)] - first
        ends = np.append(f, 1.0)
        added = 0.5 * (ends[mine] + ends[mine + 1])
        room = MAX_SEGMENT_KNOTS - f.size
        out.append(np.sort(np.concatenate([f, added[:max(room, 0)]])))
        first += f.size
    return out


def rescaled(traj, factor):
    """Return the rest-to-rest ``traj`` slowed down by ``factor`` >= 1 (same knots)."""
    if not factor > 1.0:
        return traj
    candidate = _Scaled(traj, factor)
    scaled = _trajectory(traj.waypoints, [np.zeros(traj.waypoints.shape[1])] * 4, traj.limits,
                         True, candidate, (), dict(traj.optimizer, time_scale=float(factor)))
    if scaled is None:
        raise ValueError('slowing the spline down failed')
    return scaled


class _Scaled:
    """The knots of ``traj`` on pieces ``factor`` times longer: what _trajectory reads."""

    def __init__(self, traj, factor):
        self.pieces = np.diff(traj.breakpoints) * factor
        self.positions = traj.ppoly(traj.breakpoints)
        self.positions[-1] = traj.waypoints[-1]
        self.waypoint_knots = np.searchsorted(traj.breakpoints, traj.waypoint_times)
        self.positions[self.waypoint_knots] = traj.waypoints


__all__ = ['GRID_PER_SAMPLE', 'JointPathSamples', 'midpoint_fractions', 'PathTiming',
           'plan_along_path', 'rescaled']
