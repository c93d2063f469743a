"""
Free inner knots for 555 optimal timing (issue 17).

With knots at the waypoints only, the durations alone fix the whole C4
quintic spline of 555 (the quintic of eqs. 13-23 on every segment, jerk and
snap continuous): a segment cannot shape its own accelerate, cruise and
decelerate phases.  Here every segment is split into pieces whose inner
knots are passed at chosen positions, and the result is still one C4
quintic spline through all knots (waypoints and inner knots).

Construction (:func:`plan_with_inner_knots`):

1. Path.  A spline through the waypoints on each segment's jerk-limited
   rest-to-rest time of its slowest joint
   (:func:`timing.rest_to_rest_durations`): a well-scaled path ``q(s)`` in
   its own time ``s``.  Rest to rest, the natural cubic spline: with it the
   plans of bench_inner_knots.py were 1.5 % shorter (median; the worst 2.8 %)
   than on the 555 spline, which bends further from the chords between
   waypoints, and shook less.  The final spline (step 4) is C4 whatever the
   path: it passes only through knots on it.  With boundary values, the
   555 spline with them (eqs. 13-23): the path's own time is then the
   time scale of the boundary values.
2. Speed along it.  The fastest path speed under the velocity and
   acceleration limits, each times a local factor ``lambda(s)``
   (:class:`path_velocity.PathLimits`, :data:`GRID_STEPS` grid steps per
   segment).  Rest to rest, the path position ``s(t)`` of that profile is
   then averaged over moving windows (:func:`plan_options.smoothing_windows`,
   :mod:`averaged_timing`; issue 23):
   a box of width ``W`` turns every jump of the path acceleration into a
   ramp lasting ``W`` and removes the frequencies ``k / W`` (k = 1, 2, ...)
   from the path acceleration, so the spline built on it does not ring and
   does not shake an arm whose lowest mode is near them; the profile stays
   on the path, still starts and ends at rest and lasts ``W`` longer.  It
   gives the time at which every waypoint is passed.
3. Knots.  Each segment gets ``m`` inner knots at equal time fractions, ``m``
   up to the requested count and fewer on short segments: a piece lasts at
   least :data:`RAMP_PIECES` jerk ramp times ``a / j`` (a C4 spline that
   follows an acceleration change within a shorter piece needs more jerk).
   Every knot is placed at the path's position at its time.
4. Spline.  The C4 quintic spline through those positions at those times:
   the banded jerk and snap continuity system of 555
   (:mod:`continuity_system`) over all knots, with the request's boundary
   values; every piece is the quintic of eqs. (13)-(23) between its knots'
   position, velocity and acceleration.  Rest to rest with windows, the
   inner knots next to the ends are then moved where a joint's jerk at a
   rest end points against the path, so that no joint starts or stops the
   wrong way where such a knot sits next to that end
   (:meth:`KnotCandidate._end_jerks_along_path`); step 7's
   knots-only candidate, with no inner knot to move, does not replace a
   spline that runs along the path if it does not.
5. Exact limits.  The peaks are exact (:mod:`peaks`, roots of the derivative
   polynomials).  A rest-to-rest spline whose durations are all multiplied
   by ``f`` has peaks ``v / f``, ``a / f**2``, ``j / f**3``, so the factor
   ``max(r_v, r_a**(1/2), r_j**(1/3))`` of its exact ratios brings it exactly to
   its limits, one of them binding.  With non-zero boundary values that
   scaling would change them: such a spline counts only when every ratio
   is already at most 1, and when the iteration ends without one, the local
   factors are multiplied by a common margin, bisected for the largest
   that meets every limit (:func:`_with_margin`).
6. Iteration.  Where a piece needs the factor ``f_p`` (its own exact
   factor), ``lambda`` is divided by ``f_p ** RELAX`` on that piece's grid
   points (at most 1: where the speed is at the limits already the spline
   cannot gain) and steps 2-5 are repeated (at most :data:`ITERATIONS`
   times; :data:`REST_RELAX` and :data:`REST_ITERATIONS` rest to rest); the
   shortest spline is kept.
7. Outliers.  A piece that keeps needing more than :data:`OUTLIER` (the
   spline rings where the path turns sharply between close knots) sets the
   time of the whole spline; the segments holding one get half their inner
   knots and step 6 goes on (:data:`RECOUNTS` rounds).  Last, the same
   timing with knots at the waypoints only is a candidate too.
8. Long segments.  With ``inner_knots`` left to plan(), rest to rest,
   without torque limits or a vibration frequency: a segment several times
   the shortest ``v / a`` long gets up to one inner knot every
   :data:`LONG_PIECE` of them (at most :data:`LONG_MOST`), steps 2-6 run
   again from the best candidate's factors, and the better spline is kept
   (:func:`_with_long_segments`): four knots could not hold a cruise.

The spline interpolates a time-optimal (bang-bang) profile that has
acceleration jumps, so it overshoots a little near them; steps 6 and 7 pull
the profile back there.  That, and the path, which is not TOPP-RA's, is
what separates it from TOPP-RA's duration (doc/inner_knots.md).

Every step is linear in the number of waypoints: the passes of step 2 are
two sweeps over the grid, step 4 is a banded solve, step 5 evaluates the
pieces.  This is not started from the knots-only optimum of
:mod:`optimal` (that optimisation alone costs about as much as TOPP-RA on
100 waypoints); ``plan()`` compares with a cheap knots-only plan instead
(``planner._with_knots_only_rival``) and falls back to knots only when no
spline is found.
"""

from dataclasses import dataclass
from functools import cached_property
from math import isfinite
from typing import Optional

import numpy as np

from .knot_pieces import (equal_knot_times, exact_factors, knot_times, knots_per_segment,
                          ramp_accelerations, RAMP_PIECES)
from ..constraints import GravityOverload, GriddedPath, JointAcceleration, JointJerk, JointVelocity
from ..durations.timing import closed_form_scale, rest_to_rest_durations
from ..plan_options import DEFAULT_SMOOTHING, torque_without_windows
from ..speed_profile.averaged_timing import AveragedTiming
from ..speed_profile.jerk_profile import ThirdOrderProfile
from ..speed_profile.path_velocity import PathLimits, traversal_times
from ..spline.continuity_system import ContinuitySystem, spline_coefficients
from ..spline.limits import limit_ratios
from ..spline.natural_cubic import natural_cubic_spline
from ..spline.trajectory import REBUILD_RTOL, representable_durations, require_finite, Trajectory

# The constants of the construction, each with its reason in one line; the
# measurements behind them are in doc/inner_knots.md ("Where the constants
# come from").
# Torque limits without windows: coarser grid and stop pay for 6 inner knots.
TORQUE_GRID_STEPS = 20
TORQUE_MIN_GAIN = 1e-2
# Step 4 with windows: no joint's jerk at a rest end against the path
# (:meth:`KnotCandidate._end_jerks_along_path`; False: as the fit gives it,
# and step 7's knots-only candidate may replace a spline that runs along it).
END_JERK_SIGN = True
# Grid steps per segment of the speed profile (step 2).
GRID_STEPS = 24
# Torque limits without windows: shorter pieces follow the profile's jumps
# (step 3), the profile leaves and reaches rest at this share of the jerk
# (end_ramps), and a slowed piece slows its neighbours by its factor to this
# power (step 6; without it the iteration oscillated near gravity's limit).
TORQUE_RAMP_PIECES = 0.5
TORQUE_END_RAMPS = 0.5
TORQUE_NEIGHBOURS = 0.5
# Most iterations of steps 2-5, and the stop after STALL of them without a
# relative gain of MIN_GAIN.
ITERATIONS = 15
STALL = 2
MIN_GAIN = 1e-3
# Exponent of the local factor's update and its range (step 6).
RELAX = 0.8
MIN_LOCAL_FACTOR = 0.2
# Rest to rest: a piece's factor divided out fully converges in fewer iterations.
REST_ITERATIONS = 8
REST_RELAX = 1.0
# With the default windows: overshooting the update a little converges sooner.
WINDOWS_RELAX = 1.3
# Requests this small (rest to rest, default windows) stop early: their
# planning time was above TOPP-RA's, for plans 0.1-0.2 % longer.
FEW_WAYPOINTS = 5
FEW_ITERATIONS = 2
FEW_RECOUNTS = 1
# With a total to beat: the construction stops once its best after k
# candidates is above it by more than the k-th share (no later one won).
GIVE_UP_GAINS = (0.3, 0.1, 0.08, 0.05)
# With non-zero boundary values: the smallest common margin on the local
# factors tried, and the bisection steps towards the largest feasible one.
MIN_MARGIN = 0.5
MARGIN_STEPS = 6
# With non-zero boundary values: the shares of their rest-to-rest time the
# path's end segments get when their own time gives no spline (the path
# leaves a moving end at the end's velocity, so its time sets the path's
# shape there).
END_SEGMENT_SHARES = (0.5, 2.0, 0.25)
# Step 7: rounds of halving the inner knots of segments whose worst piece
# still needs a factor above OUTLIER, each followed by up to ITERATIONS
# (REST_ITERATIONS) more.
RECOUNTS = 2
OUTLIER = 1.01
# With corner rounding (path_timing): step 6 lowers a grid point by the
# largest factor of the pieces within this many rounding windows of it.
ROUNDED_REACH = 0.1
# Step 8, rest to rest without torque limits or a vibration_frequency: a long
# segment (a cruise) is also tried with an inner knot every LONG_PIECE times
# the shortest v/a of the joints (their time to reach the velocity limit), at
# most LONG_MOST: four knots on it could not hold a cruise, and a 10 rad move
# took 1.29 times its rest-to-rest bound (1.07 with 8).
LONG_PIECE = 2.0
LONG_MOST = 32
# Safety factor on exact restoring factors against round-off.
_ROUNDOFF = 1.0 + 1e-12


@dataclass(frozen=True)
class TimingProblem:
    """
    What the construction times: a path with its boundary values and limits.

    ``path`` is step 1's path on step 2's grid (this module's own, or a
    :class:`path_timing.JointPathSamples`: what :class:`KnotCandidate`
    reads of it is listed there); ``boundary`` the four boundary vectors
    (start velocity and acceleration, end velocity and acceleration);
    ``limits`` the :class:`limits.JointLimits`; ``rest`` whether all four
    are zero, so that step 5 scales every spline to its limits.
    """

    path: object
    boundary: tuple
    limits: object
    rest: bool

    @property
    def points(self):
        """Return the path's waypoints, which the spline passes: an (N, n) array."""
        return self.path.points

    @cached_property
    def end_tangent_signs(self):
        """
        Return the signs (2, n) of the path's tangent ``q'(s)`` at its start and at its end.

        What step 4 holds a joint's jerk at a rest end against
        (:meth:`KnotCandidate._end_jerks_along_path`): the path's alone, so
        every candidate of the problem reads the same (found once).
        """
        path = self.path
        return np.sign(np.stack([path.ppoly(path.s[0], 1), path.ppoly(path.s[-1], 1)]))


@dataclass(frozen=True)
class IterationBudget:
    """
    How steps 2-6 iterate (:func:`iterate_knots`).

    At most ``iterations`` candidates; a stop after ``stall`` of them in a
    row without a relative gain of ``min_gain``; ``relax`` is step 6's
    exponent.  ``give_up``, a total to beat (None: none): the iteration
    ends without a result once it shows that it will not beat it
    (:data:`GIVE_UP_GAINS`).
    """

    iterations: int = ITERATIONS
    relax: float = RELAX
    min_gain: float = MIN_GAIN
    stall: int = STALL
    give_up: Optional[float] = None


class _Path:
    """
    The path of step 1 on the grid of step 2.

    The grid ``s`` and its ``steps``, the path's velocity and acceleration
    limits along it (``limits``, a :class:`PathLimits`), the ``ppoly``, the
    ``points``, the squared path speeds at the ends (``start``, ``end``: 0
    at rest, 1 with boundary values, which the path has in its own time),
    the ``most`` inner knots per segment, step 3's shortest piece
    (``min_piece``, ``ramp_pieces`` and ``ramp_acceleration``:
    :func:`knots_per_segment`, :func:`ramp_accelerations`), the torque's
    ``piece_factors`` (or None) and ``torque_neighbours`` (step 6's power of
    them for the neighbours, 0: none), ``keep_time_scale`` (:func:`plan_with_inner_knots`),
    step 6's stop ``min_gain`` (:func:`iterate_knots`), step 2's ``windows``
    and its averaged :meth:`timing`.  :class:`path_timing.JointPathSamples`
    has the same, for a path the caller gives.
    """

    def __init__(self, points, boundary, limits, most, windows, end_share=1.0, torque=None,
                 keep_time_scale=False, third_order=False):
        """
        Build the path through ``points`` with ``boundary`` values (and torque limits).

        ``third_order``: rest to rest with jerk limits, step 2's profile holds
        the jerk too (:mod:`jerk_profile`; ``third_order`` is then its LPs).
        """
        self.points = points
        self.most = most
        self.windows = windows
        self.min_piece = 0.0
        # A torque-limited profile not averaged over windows has jumps of
        # acceleration: shorter pieces follow them (TORQUE_RAMP_PIECES), on a
        # coarser grid with a coarser stop (TORQUE_GRID_STEPS, TORQUE_MIN_GAIN).
        sharp = torque_without_windows(torque, windows)
        self.ramp_pieces = TORQUE_RAMP_PIECES if sharp else RAMP_PIECES
        self.torque_neighbours = 0.0 if torque is None else TORQUE_NEIGHBOURS
        self.keep_time_scale = keep_time_scale
        self.rounding = 0.0     # no corner rounding (path_timing.JointPathSamples)
        self.start = 1.0 if np.any(boundary[0]) or np.any(boundary[1]) else 0.0
        self.end = 1.0 if np.any(boundary[2]) or np.any(boundary[3]) else 0.0
        durations = rest_to_rest_durations(points, limits)
        # A segment next to a moving end at end_share of its time.
        if self.start:
            durations[0] *= end_share
        if self.end:
            durations[-1] *= end_share
        grid = TORQUE_GRID_STEPS if sharp else GRID_STEPS
        self.min_gain = TORQUE_MIN_GAIN if sharp else MIN_GAIN
        self.ppoly, self.s = first_path(points, durations, boundary, grid)
        self.steps = np.diff(self.s)
        self.waypoint_s = self.s[::grid]
        constraints = (JointVelocity(limits.velocity), JointAcceleration(limits.acceleration))
        if torque is not None:
            # Held between the grid points too (path_velocity): at the grid
            # points alone the profile passed the torque limit between them,
            # and the spline inherited it.
            constraints += (torque.constraint(interpolated=True),)
        third_order = (third_order and not (self.start or self.end)
                       and bool(np.any(np.isfinite(limits.jerk))))
        gridded = GriddedPath.of_ppoly(self.ppoly, self.s, third=third_order)
        self.limits = PathLimits(gridded, constraints)
        self.third_order = None
        if third_order:
            self.third_order = ThirdOrderProfile(gridded,
                                                 constraints + (JointJerk(limits.jerk),))
        if torque is not None and TORQUE_END_RAMPS and not (self.start or self.end):
            self.limits.x_max = np.minimum(self.limits.x_max, end_ramps(
                self.s, gridded.first, limits.jerk, TORQUE_END_RAMPS))
        # The torque of each piece (step 5): a factor like the exact v/a/j ones.
        self.piece_factors = None if torque is None else torque.piece_factors
        self.ramp_acceleration = ramp_accelerations(self.limits, gridded, limits,
                                                    torque is not None)

    def timing(self, times, x):
        """Return the path position in time of the profile ``x`` (step 2's average, at rest)."""
        rest = not (self.start or self.end)
        return AveragedTiming(times, x, self.s, self.windows if rest else ())


def end_jerks(coeffs, last_width):
    """Return (2, n): the jerk of quintic pieces ``coeffs`` at the start and at the end."""
    h = last_width
    out = np.empty((2, coeffs.shape[-1]))     # (np.stack's values, without its wrapper)
    out[0] = 6.0 * coeffs[0, 3]
    out[1] = 6.0 * coeffs[-1, 3] + 24.0 * coeffs[-1, 4] * h + 60.0 * coeffs[-1, 5] * h * h
    return out


def end_snaps(coeffs, last_width):
    """Return (2, n): the snap of quintic pieces ``coeffs`` at the start and at the end."""
    return np.stack([24.0 * coeffs[0, 4], 24.0 * coeffs[-1, 4] + 120.0 * coeffs[-1, 5]
                     * last_width])


def unit_splines(count, knots, pieces):
    """
    Return (S, 6, len(knots)): how a move of the ``knots`` moves the 555 spline at rest.

    The spline through ``count`` knots on ``pieces``, at rest, is linear in
    its knot positions: these are the splines through a unit position at
    each of ``knots`` (0 at every other knot).
    """
    unit = np.zeros((count, len(knots)))
    unit[knots, np.arange(len(knots))] = 1.0
    return spline_coefficients('555', unit, pieces, (np.zeros(len(knots)),) * 4)


def unit_end_jerks(count, knots, pieces):
    """Return :func:`unit_splines` and their end jerks (2, len(knots)) (step 4)."""
    units = unit_splines(count, knots, pieces)
    return units, end_jerks(units, pieces[-1])


def spline_and_units(positions, pieces, boundary, knots):
    """
    Return the 555 spline through ``positions`` (K, n) and the :func:`unit_splines` of ``knots``.

    One banded solve for both (step 4): the unit positions are more
    right-hand-side columns of the system of ``pieces``, and every column
    of a banded solve is solved on its own, so the spline is
    :func:`spline_coefficients` ``('555', positions, pieces, boundary)``
    and the units are :func:`unit_splines` ``(K, knots, pieces)``, bit for
    bit (their boundary values are 0).  Raises ValueError as
    :func:`spline_coefficients` does.
    """
    n, k = positions.shape[1], len(knots)
    columns = np.zeros((positions.shape[0], n + k))
    columns[:, :n] = positions
    columns[knots, n + np.arange(k)] = 1.0
    system = ContinuitySystem('555', pieces)
    dP = columns[1:] - columns[:-1]
    zero = np.zeros(k)
    vel, acc = system.solve(dP, *(np.concatenate([b, zero]) for b in boundary))
    # The coefficients of each set of columns as they were found alone (a
    # matrix product's bits could depend on how many columns it has).
    return (system.coefficients(positions[:-1], dP[:, :n], vel[:, :n], acc[:, :n]),
            system.coefficients(columns[:-1, n:], dP[:, n:], vel[:, n:], acc[:, n:]))


def first_path(points, durations, boundary, steps=GRID_STEPS):
    """
    Return step 1's path ``q(s)`` (a PPoly) through ``points`` at ``durations``, and its grid.

    With a moving end (any of the four ``boundary`` vectors non-zero) the
    555 spline that has the boundary values in its own time; rest to rest
    the natural cubic spline (its end derivatives are free: its speed is 0
    there).  The grid has ``steps`` equal steps a segment.
    """
    if any(np.any(b) for b in boundary):
        traj = Trajectory.build('555', 'fixed', points, durations, boundary)
        ppoly, knots = traj.ppoly, traj.breakpoints
    else:
        knots = np.concatenate([[0.0], np.cumsum(durations)])
        ppoly = natural_cubic_spline(knots, points)
    fractions = np.arange(steps) / steps
    grid = np.concatenate([(knots[:-1, None] + fractions * np.diff(knots)[:, None]).ravel(),
                           knots[-1:]])
    return ppoly, grid


def end_ramps(s, first, jerk, share):
    """
    Return the squared speeds (M + 1,) of a constant path jerk from the start and to the end.

    On the grid ``s`` (M + 1,): at path distance ``d`` from rest, a path
    jerk ``J`` held from rest has reached ``sdot**2 = J**(2/3) (6 d)**(4/3)
    / 4`` (``s = J t**3 / 6``).  ``J`` is ``share`` of the slowest joint's
    ``j_j / |q'_j|`` at each grid point (``first`` (M + 1, n) is ``q'``); it
    scales with the local factor as ``x`` does (``J**(2/3)``, a time
    scaling), so the factors keep it.  As a bound on ``x`` it makes a
    profile leave rest like that until its path acceleration reaches what
    the other limits allow.
    """
    ends = s[[0, -1]]
    d = np.min(np.abs(s[:, None] - ends[None, :]), axis=1)
    with np.errstate(divide='ignore', over='ignore', invalid='ignore'):
        path_jerk = share * np.min(jerk[None, :] / np.abs(first), axis=1)
        cap = 0.25 * path_jerk ** (2.0 / 3.0) * (6.0 * d) ** (4.0 / 3.0)
    return np.where(np.isnan(cap), np.inf, cap)


class SpeedProfile:
    """
    Step 2 for the local limit factors ``local``: the speed profile and its timing.

    The squared path speed ``x`` on the grid, its (averaged) path position
    in time ``timing`` (the path's :meth:`timing`) and the times ``passed``
    at the waypoints; ``valid`` is False when the profile does not get to
    the end.  None of it depends on
    the knots, so candidates with other knots on the same factors share it
    (:func:`_construct`: the two profiles the knots-only candidates need
    are computed already).
    """

    def __init__(self, path, local):
        """Build the profile of ``path`` under ``local``."""
        self.local = local
        self.x = path.limits.profile(local, path.start, path.end)
        if path.third_order is not None:
            held = path.third_order.profile(local, self.x)
            if held is not None:
                self.x = held
        self.times = times = traversal_times(self.x, path.steps)
        self.valid = bool(np.isfinite(times).all() and times[-1] > 0.0)
        if not self.valid:
            return
        self.timing = path.timing(times, self.x)
        self.passed = self.timing.time_at(path.waypoint_s)


class KnotCandidate:
    """
    One spline of steps 2-5 for the local limit factors ``local``.

    ``pieces`` (P,), the knot ``positions`` (K, n), the exact ``factors``
    (P,) before scaling (each piece's, :func:`exact_factors`, and the
    path's ``piece_factors``), ``feasible`` and the ``total`` time (inf when
    not feasible); ``score`` ranks candidates while none is feasible yet
    (the total it would have if scaled as a rest-to-rest one).  The spline
    is the C4 one through the positions (step 4), so they and the pieces
    define it; ``profile`` is its :class:`SpeedProfile`.
    """

    def __init__(self, problem, local, counts, fractions=None, profile=None):
        """
        Build the candidate; ``counts`` (S,) inner knots per segment, or None to choose them.

        ``problem`` is the :class:`TimingProblem`.  ``fractions``, when
        given, replaces ``counts``: per segment, the increasing time
        fractions in [0, 1) of its knots (the first 0, its waypoint), for
        knots not at equal fractions (:mod:`path_timing`).
        ``profile``, when given, is the :class:`SpeedProfile` of ``local``,
        computed already.
        """
        path, boundary, limits, rest = (problem.path, problem.boundary, problem.limits,
                                        problem.rest)
        self.valid = False
        self.local = local
        self.grid_s = path.s
        self.rounding = path.rounding
        self.profile = SpeedProfile(path, local) if profile is None else profile
        if not self.profile.valid:
            return
        timing, passed = self.profile.timing, self.profile.passed
        if fractions is None:
            if counts is None:
                counts = knots_per_segment(passed[1:] - passed[:-1], limits, path.most,
                                           path.min_piece, path.ramp_pieces,
                                           path.ramp_acceleration)
            # knot_times(passed, equal_fractions(counts)), without a list a segment.
            self.knot_times = equal_knot_times(passed, counts)
        else:
            counts = np.array([f.size - 1 for f in fractions])
            self.knot_times = knot_times(passed, fractions)
        self.counts = counts
        self.waypoint_knots = np.concatenate([[0], np.cumsum(counts + 1)])
        # (Differences, clips and reductions here without numpy's wrappers:
        # the same values; a candidate is a few dozen numpy calls on small
        # arrays.)
        pieces = self.knot_times[1:] - self.knot_times[:-1]
        if not (pieces > 0.0).all():
            return
        self.knot_s = timing.position_at(self.knot_times)
        self.positions = path.ppoly(self.knot_s)
        self.positions[self.waypoint_knots] = path.points
        self.against_path = False
        along = rest and path.windows and END_JERK_SIGN
        # Step 4's inner knots next to the ends (None: its segment has none),
        # whose unit splines join the spline's solve.
        near = [1 if counts[0] > 0 else None,
                self.positions.shape[0] - 2 if counts[-1] > 0 else None] if along else []
        knots = sorted({k for k in near if k is not None})
        try:
            if knots:
                coeffs, units = spline_and_units(self.positions, pieces, boundary, knots)
            else:
                coeffs = spline_coefficients('555', self.positions, pieces, boundary)
        except ValueError:
            return
        if along:
            coeffs = self._end_jerks_along_path(coeffs, pieces, problem, near, knots,
                                                units if knots else None)
        self.factors, self.ratios = exact_factors(coeffs, pieces, limits)
        self.neighbours = None
        if path.piece_factors is not None:
            # The path's own limits beyond v/a/j (a tool speed, the torque): first order.
            own = np.max(path.piece_factors(coeffs, pieces), axis=1, initial=-np.inf)
            if path.torque_neighbours:
                # What a piece held back by its torque asks of its neighbours (relaxed).
                self.neighbours = (np.where(own >= self.factors, own, 1.0)
                                   ** path.torque_neighbours)
            self.factors = np.maximum(self.factors, own)
        f = float(self.factors.max()) * _ROUNDOFF
        if not (isfinite(f) and f > 0.0):
            return
        if rest and path.keep_time_scale:
            f = max(f, _ROUNDOFF)
        self.valid = True
        self.score = float(pieces.sum()) * f
        # A rest-to-rest spline through the same positions on pieces * f is
        # this one slowed down by f: exactly at its limits.
        self.pieces = pieces * f if rest else pieces
        # Its terms and ratios, for the kept candidate's trajectory: those of
        # pieces * f are these times f**-k and f**-q (time scaling).
        self.coeffs, self.scale = coeffs, (f if rest else 1.0)
        self.feasible = rest or f <= _ROUNDOFF
        self.total = float(self.pieces.sum()) if self.feasible else np.inf

    def _end_jerks_along_path(self, coeffs, pieces, problem, near, knots, units):
        """
        Return ``coeffs`` with no joint's jerk at a rest end against the path's direction.

        Step 4 with windows, rest to rest.  The spline's jerk at a rest end
        follows from the whole spline; the averaged profile's is 0 there
        (its acceleration ramps in over a window), so its sign is an
        accident of the fit (a few % of the limit), and a joint whose jerk
        points against the path's tangent starts (or ends) the wrong way:
        1e-7-1e-3 rad, past a start on a position limit
        (``benchmarks/bench_position_limits.py``).  The inner knot next to
        each such end is moved, per joint, to set that jerk to 0: the spline
        is linear in its knot positions, so one solve with unit positions
        gives the move (up to 1e-2 rad at a knot tens of milliseconds from
        the end).  With an inner knot next to both ends both are set at
        once; with one, it sets its own end where that does not turn the
        other against the path.  The spline still passes every waypoint and
        the path's ends, and step 5 scales it to its limits as before.
        ``against_path`` says whether a joint still starts or stops the wrong
        way (no inner knot to move).  ``near`` is the inner knot next to
        each end (None: its segment has none), ``knots`` those there are and
        ``units`` their :func:`unit_splines` (None without one), solved with
        the spline (:func:`spline_and_units`).
        """
        jerks = end_jerks(coeffs, pieces[-1])                       # (2 ends, n)
        sign = problem.end_tangent_signs
        wrong = jerks * sign < 0.0
        if not wrong.any():
            return coeffs
        if not knots:
            self.against_path = True
            return coeffs
        sensitivity = end_jerks(units, pieces[-1])                  # (2 ends, len(knots))
        if len(knots) == 2:
            moves = np.linalg.solve(sensitivity, -np.where(wrong, jerks, 0.0))
            wrong[:] = False
        else:
            # One knot: per joint, the one wrong end it is next to.
            serves = np.array([near[e] == knots[0] for e in (0, 1)])[:, None] & wrong
            end = np.argmax(serves, axis=0)                         # (n,)
            n = np.arange(jerks.shape[1])
            move = np.where(serves.sum(axis=0) == 1, -jerks[end, n] / sensitivity[end, 0], 0.0)
            other = 1 - end
            turned = ((jerks[other, n] + sensitivity[other, 0] * move) * sign[other, n] < 0.0
                      ) & ~wrong[other, n]
            move = np.where(turned, 0.0, move)
            moves = move[None, :]
            wrong[end, n] &= move == 0.0
        self.against_path = bool(np.any(wrong))
        self.positions[knots] += moves
        return coeffs + np.einsum('skm,mn->skn', units, moves)

    def better_than(self, other):
        """Whether this candidate is to be kept over ``other`` (None or a candidate)."""
        if other is None:
            return True
        if self.feasible != other.feasible:
            return self.feasible
        return self.score < other.score

    def relaxed(self, local, relax=RELAX, floor=None):
        """
        Step 6: ``local`` divided by each piece's factor to the ``relax`` on its grid points.

        With a ``floor``, factors below it count as it (1: only the pieces
        over their limits are lowered, :func:`path_timing._polish`).  With
        torque limits a piece's factor is at least its neighbours'
        :attr:`neighbours` (:data:`TORQUE_NEIGHBOURS`).  With corner
        rounding (tool lines with a tool speed) a grid point takes the
        largest factor within reach of its rounding window
        (:meth:`_rounded_factors`).
        """
        factors = self.factors if floor is None else np.maximum(self.factors, floor)
        if self.neighbours is not None and factors.size > 1:
            factors = factors.copy()
            factors[1:] = np.maximum(factors[1:], self.neighbours[:-1])
            factors[:-1] = np.maximum(factors[:-1], self.neighbours[1:])
        if self.rounding:
            mine = self._rounded_factors(factors)
        else:
            piece_of = np.searchsorted(self.knot_s, self.grid_s, side='right') - 1
            np.minimum(np.maximum(piece_of, 0, out=piece_of), factors.size - 1, out=piece_of)
            mine = factors[piece_of]
        return np.minimum(np.maximum(local / mine ** relax, MIN_LOCAL_FACTOR), 1.0)

    def _rounded_factors(self, factors):
        """
        Return per grid point the largest factor of the pieces its rounding window reaches.

        With corner rounding (``path.rounding`` = W) a piece's position is
        the profile averaged over W around it: the local factors of the grid
        points within W / 2 of the piece in time shape it, and lowering only
        the piece's own grid points moves it by less than its factor.  Each
        grid point takes the largest factor of the pieces within
        :data:`ROUNDED_REACH` W of its time (on the plain profile's clock,
        which the centred average keeps).
        """
        half = ROUNDED_REACH * self.rounding
        last = factors.size - 1
        lo = np.clip(np.searchsorted(self.knot_times, self.profile.times - half, side='right') - 1,
                     0, last)
        hi = np.clip(np.searchsorted(self.knot_times, self.profile.times + half, side='left') - 1,
                     0, last)
        mine = factors[lo]
        k = lo + 1
        while np.any(k <= hi):
            mine = np.where(k <= hi, np.maximum(mine, factors[np.minimum(k, last)]), mine)
            k = k + 1
        return mine


def plan_with_inner_knots(points, boundary, limits, most, dropped_waypoints=(),
                          windows=DEFAULT_SMOOTHING, torque=None, knots_only=True,
                          keep_time_scale=False, give_up=None, third_order=False,
                          long_segments=False):
    """
    Return the 555 optimal Trajectory with up to ``most`` inner knots per segment, or None.

    ``points`` (N, n) are the merged waypoints, ``boundary`` the four
    boundary vectors, ``limits`` the :class:`JointLimits`.  The trajectory
    passes through every waypoint at ``waypoint_times``, is C4 at every knot
    and meets every limit exactly (steps 1-7 of the module docstring).  With
    non-zero boundary values the path's end segments are also tried at
    :data:`END_SEGMENT_SHARES` of their time when its own is not kept.  None
    when no spline within the limits is found (boundary values the
    construction cannot keep, or a request without motion): plan() then
    keeps knots at the waypoints.  ``torque`` (a :class:`torque.TorqueLimit`)
    adds the joint torque to step 2's constraints and to step 5's factors
    (sampled per piece; the caller checks the result at 1 kHz).
    ``knots_only`` False leaves out step 7's knots-only candidates (the
    caller computes the knots-only optimum).  ``keep_time_scale``: step 5
    never speeds the spline up (a factor below 1 would move the windows'
    spectral zeros up by its inverse: on a short move, far from the
    ``vibration_frequency`` they were chosen for).  ``give_up``, a total
    to beat (another plan's, rest to rest): None also when the construction
    shows that it will not beat it (:data:`GIVE_UP_GAINS`).  ``third_order``:
    step 2's profile holds the jerk limits too (:mod:`jerk_profile`, rest to
    rest; issue 38's profile, not yet plan()'s).  ``long_segments``: step 8
    may give a long segment more than ``most`` inner knots (``inner_knots``
    left to plan(): :func:`_with_long_segments`).
    """
    if np.all(points == points[0]):
        return None
    rest = not any(np.any(b) for b in boundary)
    for share in (1.0,) if rest else (1.0,) + END_SEGMENT_SHARES:
        try:
            path = _Path(points, boundary, limits, most, windows, share, torque,
                         keep_time_scale, third_order)
        except GravityOverload:
            raise
        except ValueError:
            continue
        problem = TimingProblem(path, boundary, limits, rest)
        best, iterations = _construct(problem, knots_only, give_up, long_segments)
        if best is None:
            continue
        traj = kept_trajectory(problem, best, dropped_waypoints,
                               {'inner_knots': most, 'knots': int(best.pieces.size + 1),
                                'inner_knots_per_segment': best.counts.tolist(),
                                'iterations': iterations, 'end_segment_share': share,
                                'smoothing_windows': list(windows) if rest else []})
        if traj is not None:
            return traj
    return None


def _construct(problem, knots_only=True, give_up=None, long_segments=False):
    """
    Run steps 2-8 on ``problem``; return (a candidate within the limits or None, iterations).

    ``knots_only`` False leaves out the last candidates of step 7 (knots at
    the waypoints only, on this timing): for a caller that compares with
    the knots-only optimum anyway.  ``give_up`` as for
    :func:`plan_with_inner_knots` (None once the construction cannot beat it).
    """
    path, rest = problem.path, problem.rest
    most = REST_ITERATIONS if rest else ITERATIONS
    relax = REST_RELAX if rest else RELAX
    stall = STALL
    recounts = RECOUNTS
    if rest and tuple(path.windows) == DEFAULT_SMOOTHING and path.piece_factors is None:
        relax = WINDOWS_RELAX
        if path.points.shape[0] <= FEW_WAYPOINTS:
            most, stall = FEW_ITERATIONS, 1
            recounts = FEW_RECOUNTS
    budget = IterationBudget(most, relax, path.min_gain, stall, give_up)
    start = SpeedProfile(path, np.ones(path.s.size))
    best, iterations = iterate_knots(problem, start.local, None, None, budget, profile=start)
    for _ in range(recounts):
        if best is None:
            break
        # Step 7: halve the inner knots of the segments holding a piece that
        # still needs more than OUTLIER, and iterate on from there.
        worst = np.maximum.reduceat(best.factors, best.waypoint_knots[:-1])
        outliers = (worst > OUTLIER) & (best.counts > 0)
        if not np.any(outliers):
            break
        counts = np.where(outliers, best.counts // 2, best.counts)
        best, more = iterate_knots(problem, best.local, counts, best, budget,
                                   profile=best.profile, made=iterations)
        iterations += more
    if best is None:
        return None, iterations
    if long_segments and rest and path.piece_factors is None and not path.keep_time_scale:
        best, more = _with_long_segments(problem, best, budget)
        iterations += more
    # The same timing with knots at the waypoints only, for the requests
    # (few segments, one joint reversing) where that is shorter: on the
    # profiles of the best factors and of the first ones, both built already.
    # (Not one that starts or stops a joint the wrong way, step 4, where the best
    # does not: with a vibration_frequency such a tie went to it by 0.1 %.)
    for profile in (best.profile, start) if knots_only else ():
        candidate = KnotCandidate(problem, profile.local, np.zeros_like(best.counts),
                                  profile=profile)
        if (candidate.valid and candidate.better_than(best)
                and best.against_path >= candidate.against_path):
            best = candidate
    if not best.feasible:
        best = _with_margin(problem, best)
    return best, iterations


def _with_long_segments(problem, best, budget):
    """
    Step 8: return (the better of ``best`` and its long segments with more knots, iterations).

    A segment of ``T`` s on ``best``'s timing gets up to ``T / (LONG_PIECE
    tau) - 1`` inner knots (``tau`` the shortest ``v / a`` of the joints, at
    most :data:`LONG_MOST` and what its pieces' shortest length allows,
    :func:`knots_per_segment`) where that is more than it has, and steps
    2-6 run from ``best``'s factors with those counts; the better spline is
    kept.  With the few knots of step 3 a long segment's spline could not
    cruise: on moves of 2-5 waypoints with steps up to 6 rad the default
    took 1.10-1.15 times TOPP-RA's duration (median; 4 Hz shaking 0.24-0.29
    of its), 1.01-1.08 with this (0.34-0.37), short segments unchanged
    (``bench_inner_knots.py``'s long-moves table, three seeds).
    """
    path, limits = problem.path, problem.limits
    times = np.diff(best.profile.passed)
    fit = knots_per_segment(times, limits, LONG_MOST, path.min_piece, path.ramp_pieces,
                            path.ramp_acceleration)
    tau = float(np.min(limits.velocity / limits.acceleration))
    with np.errstate(invalid='ignore'):
        wanted = np.floor(times / (LONG_PIECE * tau)) - 1
    counts = np.maximum(np.minimum(np.nan_to_num(wanted, nan=0.0), fit),
                        best.counts).astype(int)
    if not np.any(counts > best.counts):
        return best, 0
    # Rest to rest's full budget even on a request of few waypoints (FEW_ITERATIONS
    # there: 1.09-1.12 times TOPP-RA's duration against 1.06-1.11 on the seeds
    # LONG_PIECE was chosen on).
    budget = IterationBudget(REST_ITERATIONS, budget.relax, budget.min_gain, STALL)
    longer, iterations = iterate_knots(problem, best.profile.local, counts, None, budget,
                                       profile=best.profile)
    if longer is not None and longer.better_than(best):
        return longer, iterations
    return best, iterations


def iterate_knots(problem, local, counts, best, budget, fractions=None, profile=None, made=0):
    """
    Run steps 2-6 from the local factors ``local``; return (best candidate or None, iterations).

    ``problem`` is the :class:`TimingProblem`, ``counts`` and ``fractions``
    as for :class:`KnotCandidate`, ``best`` the best candidate so far (or
    None).  ``budget`` (an :class:`IterationBudget`) says how it runs: it
    stops after ``budget.iterations``, or ``budget.stall`` iterations in a
    row without a relative gain of ``budget.min_gain`` over ``best``;
    ``budget.relax`` is step 6's exponent (:data:`REST_RELAX`,
    :data:`WINDOWS_RELAX` and the iterations for rest-to-rest requests of
    plan(): :func:`_construct`).  ``profile``, when given, is the
    :class:`SpeedProfile` of ``local`` (the first candidate's).  With
    ``budget.give_up`` (a total to beat), (None, iterations) once the best
    candidate is above it by more than :data:`GIVE_UP_GAINS` says the
    iterations could still gain after ``made`` + these candidates.
    """
    min_gain, stall, give_up = budget.min_gain, budget.stall, budget.give_up
    stalled, iterations = 0, budget.iterations
    for iterations in range(1, budget.iterations + 1):
        candidate = KnotCandidate(problem, local, counts, fractions, profile)
        profile = None
        if not candidate.valid:
            break
        counts = candidate.counts
        gain = best is None or candidate.score < best.score * (1.0 - min_gain)
        stalled = 0 if gain else stalled + 1
        if candidate.better_than(best):
            best = candidate
        if give_up is not None and best.feasible and best.score > give_up * (
                1.0 + GIVE_UP_GAINS[min(made + iterations, len(GIVE_UP_GAINS)) - 1]):
            return None, iterations
        if stalled >= stall or iterations == budget.iterations:
            break   # (no next candidate: its factors are not needed)
        local = candidate.relaxed(local, budget.relax)
    return best, iterations


def _with_margin(problem, best):
    """
    Return a spline within the limits for non-zero boundary values, or None.

    Step 5 cannot scale such a spline, so the local factors of ``best`` are
    multiplied by a common margin ``g`` in [:data:`MIN_MARGIN`, 1], bisected
    (:data:`MARGIN_STEPS` steps) for the largest ``g`` whose spline meets
    every limit; the shortest of those is returned (``problem`` has
    non-zero boundary values: not :attr:`TimingProblem.rest`).
    """
    def attempt(g):
        candidate = KnotCandidate(problem, best.local * g, best.counts)
        return candidate if candidate.valid and candidate.feasible else None

    found = attempt(MIN_MARGIN)
    if found is None:
        return None
    low, high = MIN_MARGIN, 1.0
    for _ in range(MARGIN_STEPS):
        g = 0.5 * (low + high)
        candidate = attempt(g)
        if candidate is None:
            high = g
        else:
            low = g
            if candidate.total < found.total:
                found = candidate
    return found


@dataclass(frozen=True)
class _KeptRequest:
    """What :func:`kept_trajectory` reads of its problem (for :func:`moved_trajectory`)."""

    points: np.ndarray
    boundary: tuple
    limits: object
    rest: bool = True


@dataclass(frozen=True)
class _KeptSpline:
    """What :func:`kept_trajectory` reads of its candidate (for :func:`moved_trajectory`)."""

    pieces: np.ndarray
    positions: np.ndarray
    waypoint_knots: np.ndarray
    coeffs: np.ndarray
    ratios: np.ndarray
    scale: float = 1.0


def moved_trajectory(traj, pieces, positions, waypoint_knots, coeffs, units, knots, moves):
    """
    Return the rest-to-rest 555 ``traj`` with its ``knots`` moved by ``moves``, or None.

    ``positions`` (K, n) are the spline's knot positions on ``pieces``,
    ``waypoint_knots`` the waypoints' indices among them, ``coeffs`` the
    spline through them and ``units`` the :func:`unit_splines` of
    ``knots``: the spline is linear in its knot positions, so the moved
    one is ``coeffs + units @ moves`` (``moves`` (len(knots), n)), without
    a solve.  It is stretched until it holds the v/a/j limits of ``traj``
    (never sped up, :func:`kept_trajectory`; None where it cannot be); its
    ``optimizer`` is a copy of ``traj``'s (:mod:`rest_ends`,
    :mod:`position_limit_knots`).
    """
    moved = positions.copy()
    moved[knots] += moves
    turned = coeffs + np.einsum('skm,mn->skn', units, moves)
    spline = _KeptSpline(pieces, moved, waypoint_knots, turned,
                         limit_ratios(turned, pieces, traj.limits))
    request = _KeptRequest(traj.waypoints, (np.zeros(traj.n_joints),) * 4, traj.limits)
    return kept_trajectory(request, spline, traj.dropped_waypoints, dict(traj.optimizer or {}))


def kept_trajectory(problem, best, dropped, optimizer):
    """
    Return the Trajectory of the kept spline ``best`` of ``problem``, on the PPoly's widths.

    ``dropped`` are the merged waypoints' indices, ``optimizer`` the
    trajectory's ``optimizer`` record.  The widths the PPoly really has

    differ from the pieces by round-off of the cumulative sum: the
    candidate's terms and exact ratios, time-scaled to its pieces, are kept
    when they differ by at most :data:`trajectory.REBUILD_RTOL` (its factor
    has a margin of 1e-12 over their round-off), and the spline is solved
    again on the widths otherwise, its ratios found again.  A rest-to-rest
    spline is stretched by its exact factor while one exceeds 1 (at most
    twice), any other must already be within its limits.
    """
    boundary, limits, rest = problem.boundary, problem.limits, problem.rest
    pieces = best.pieces
    # The candidate's terms, scaled to its pieces (no second solve), unless
    # the PPoly's widths differ from them by more than round-off.
    coeffs = ratios = None
    if best.coeffs is not None:
        coeffs = best.coeffs / best.scale ** np.arange(6)[None, :, None]
        if best.ratios is not None:
            ratios = best.ratios / best.scale ** np.arange(1, 4)
    for _ in range(3):
        widths = representable_durations(pieces)
        if not np.all(widths > 0.0):
            return None
        if coeffs is None or not np.max(np.abs(widths - pieces) / pieces) <= REBUILD_RTOL:
            coeffs = spline_coefficients('555', best.positions, widths, boundary)
            ratios = None
        pieces = widths
        if ratios is None:
            ratios = limit_ratios(coeffs, pieces, limits)
        f = closed_form_scale(ratios)
        if f <= _ROUNDOFF:
            break
        if not rest:
            return None
        pieces, coeffs, ratios = pieces * f, None, None
    else:
        return None
    traj = Trajectory('555', 'optimal', problem.points, pieces, coeffs, boundary, limits, None,
                      dropped, ratios=ratios)
    try:
        require_finite(traj)
    except ValueError:
        return None
    traj.waypoint_times = traj.breakpoints[best.waypoint_knots]
    traj.optimizer = optimizer
    return traj
