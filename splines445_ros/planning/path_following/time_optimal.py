"""
plan()'s ``speed_profile`` "time_optimal": a C4 spline that follows the third-order profile.

The default speed profile of 555 optimal (:mod:`inner_knots`) is the
fastest velocity/acceleration (bang-bang) profile, averaged over smoothing
windows and pulled back where the spline overshoots it, or the knots-only
optimum when that is shorter.  Here the profile itself holds the jerk
(issue 38), and the spline only follows it:

1. Path.  The natural cubic spline through the waypoints on each segment's
   jerk-limited rest-to-rest time of its slowest joint (``inner_knots``
   step 1; with a moving end the 555 spline that has the boundary values in
   its own time), on :data:`inner_knots.GRID_STEPS` grid steps a segment.
2. Profile.  :class:`smooth_profile.SmoothProfile`: ``x(s) = sdot**2``, C2
   in ``s``, time-optimal under every joint's velocity, acceleration and
   :data:`JERK_MARGIN` times its jerk limit (none on a joint without one),
   at rest at both ends or at the boundary velocity and acceleration (the
   equations are in that module).  With a ``vibration_frequency`` f and a
   rest end it also cancels the ringing of a mode at f after the stop
   (:mod:`residual_vibration`), and the plan reports what it leaves
   (``optimizer['vibration_residual']``).
   Its exact time law gives the time at which every waypoint is passed.
3. Knots.  At the waypoints, at those times, and at equal time fractions
   of each segment, about :data:`KNOT_PERIOD` apart; each inner knot at
   ``q(s(t))``, the path's position at its time (at most about
   :data:`MAX_KNOTS` in all).  A piece that needs more
   than :data:`SPLIT_FACTOR` (step 4's factor of its own) is halved, for
   up to :data:`SPLIT_ROUNDS` rounds, while the plan gets shorter.
4. Spline and exact limits.  The C4 quintic spline through those knots
   (the banded system of 555, :mod:`continuity_system`), scaled in time by
   its exact factor ``max(r_v, r_a**(1/2), r_j**(1/3))`` (:mod:`peaks`): one
   limit binding, none exceeded (``inner_knots`` steps 4 and 5, the same
   code: :class:`inner_knots.KnotCandidate`, :func:`inner_knots.kept_trajectory`).

No windows, relaxation or outlier rounds: the profile is already
followable (sampled every 1 ms it needs a slow-down of 1.0004 median), so
one spline is enough.  With a moving end the spline cannot be scaled: the
profile's limits are lowered (:data:`MOVING_MARGINS`) until it holds them,
and where the path's own jerk at a moving end is more than any profile
holds, the end segments' own times are changed as the default construction
does (``inner_knots.END_SEGMENT_SHARES``): 20 of 20 random moving starts
were followed on each of three seeds (14 without the shares, which single
segments needed).  The joint torque is one more row of
the profile (a ``constraints.JointTorque``, linear in ``x`` and
``x'``).  Measured on the vendor arms (doc/benchmarks.md,
``bench_arm_moves.py``): 0.91-0.96 of the default's duration, with a 4 Hz
peak of about 1.6 times the default's (still half of TOPP-RA's but on the
Panda, whose jerk limit is 500 a); planning takes the profile's sequential
LPs, 3-5 times the default's time.

:func:`retime_path` times a finished plan's own path the same way: the tool
lines' (``cartesian/tool_lines.py``), whose path keeps the tool within its
tolerances.
"""

import numpy as np

from .inner_knots import (END_SEGMENT_SHARES, first_path, GRID_STEPS, kept_trajectory,
                          KnotCandidate, TimingProblem)
from .path_timing import midpoint_fractions
from ..durations.timing import rest_to_rest_durations
from ..speed_profile.residual_vibration import report_residual, trajectory_residual
from ..speed_profile.smooth_profile import END_STEPS, SmoothProfile

# The profile is planned with this share of each jerk limit: the spline
# through its knots overshoots the profile's jerk corners, and the exact
# factor of step 4 would otherwise slow the whole plan down for them
# (1.0: 1.058 x TOPP-RA on the arms, 0.9: 1.039-1.040; 0.85 no better).  Two
# more profiles with per-piece shares from the last spline's jerk ratios gave
# 0.5-1 % on the arms with j = 10 a (xArm7, Z1, UR5), 0 on the Panda and on
# random requests, for 2.1 times the planning time: not kept.
JERK_MARGIN = 0.9
# Inner knots about this far apart [s]: 15 ms gave 0.988-0.990 x TOPP-RA on 3
# fresh seeds of 12 random requests, 40 ms 0.993-0.997 and 60 ms 0.993-0.996
# (with the halving below; without it 0.998-1.015), 10 ms no better.
KNOT_PERIOD = 0.015
# At most about this many knots (before the halving below): a plan longer
# than MAX_KNOTS * KNOT_PERIOD (150 s) spaces them further apart, so planning
# time and memory do not grow with the plan's duration (71 000 knots took 5 s).
MAX_KNOTS = 10000
# Pieces whose own exact factor (v/a/j, torque) is above this get a knot at
# their midpoint, for at most SPLIT_ROUNDS rounds: with a jerk ramp shorter
# than KNOT_PERIOD (torque limits, j = 50 times the typical acceleration) the
# spline could not follow the profile, and one piece slowed a TALOS arm plan
# down by 1.21.
SPLIT_FACTOR = 1.005
SPLIT_ROUNDS = 4
# With a moving start or end: the shares of the limits the profile is planned
# with, tried in turn until the spline (which cannot be scaled) holds them.
MOVING_MARGINS = (0.98, 0.95, 0.9, 0.8, 0.6)
# With a moving start or end: the shares of the end segments' rest-to-rest time the
# path is tried at first, with the boundary's own velocity and acceleration as a floor
# of those limits (_boundary_floors); then inner_knots.END_SEGMENT_SHARES without it.
# From a running plan's states at a limit (bench_replanning.py) 1.25 and 1.5 took the
# states followed from 57-72 to 80-88 of 108-115 (two seeds nothing was tuned on),
# 0.949-0.977 of the default's time (median), worst 1.029-1.116 (before 1.033-1.166);
# at 2.0 with the floor 9 of 23 plans were 5-67 % longer than the default's.
FLOORED_SHARES = (1.0, 1.25, 1.5)
# vibration_frequency f: a spline whose exact factor k is further than this from 1
# has its profile cancel f k instead (the ringing of the stretched plan at f is the
# profile's at f k), and the plan that rings less is kept: 13 of 30 random requests
# with j = 3 a had k 0.97-1.02, and 8 rang less (0.175 -> 0.090, 0.081 -> 0.034), 4
# more (kept as they were).  1e-3 also re-solved most j = 10-20 a requests (k =
# 1.001-1.005), for 25-90 % more planning and a median 0.046 instead of 0.049-0.058.
RESIDUAL_SCALE = 5e-3
# retime_path: a grid step about every this much of the retimed plan's own
# time [s] (the tool lines' plans: their pieces last 15-30 ms).
RETIME_STEP = 0.01
# The name of this construction in Trajectory.optimizer['speed_profile'].
NAME = 'time_optimal'
# Trajectory.optimizer['speed_profile_skipped'] when no spline was found (plan()'s
# plan is then the default construction's, the tool lines keep their own timing).
NO_TIME_OPTIMAL_SPLINE = 'no time-optimal spline found'


class NoSpline(Exception):
    """Why no time-optimal plan was found: the text after :data:`NO_TIME_OPTIMAL_SPLINE`."""


class FollowedPath:
    """
    What :class:`inner_knots.KnotCandidate` reads of the path of steps 1-2.

    The grid ``s``, the ``ppoly`` ``q(s)``, the waypoints ``points`` and
    ``piece_factors``, the torque's per piece (None: no torque limits);
    no corner rounding, scaled to its limits, and no ``windows``: the
    profile is not averaged (its jerk at a rest end is along the path).
    """

    windows = ()
    rounding = 0.0
    keep_time_scale = False
    torque_neighbours = 0.0

    def __init__(self, s, ppoly, points, piece_factors=None):
        """Keep the grid, the path, its waypoints and the torque's piece factors (or None)."""
        self.s, self.ppoly, self.points = s, ppoly, points
        self.piece_factors = piece_factors


class FollowedProfile:
    """
    Step 2's profile as :class:`inner_knots.KnotCandidate` reads it.

    ``timing.position_at(t)`` is the profile's exact ``s(t)``, ``passed``
    the waypoints' times, ``local`` the (unused) local factors.
    """

    valid = True

    def __init__(self, profile, waypoint_s, grid_size):
        """Keep the profile; find the waypoints' times by its exact time law."""
        self.timing = self
        self.profile = profile
        self.passed = profile.time_at(waypoint_s)
        self.local = np.ones(grid_size)

    def position_at(self, t):
        """Return the path position at the times ``t``."""
        return self.profile.s_of_t(t)


def knot_fractions(segment_times, period=None):
    """
    Return per segment the time fractions [0, 1) of its knots, about ``period`` apart.

    ``period`` None: :data:`KNOT_PERIOD` (read at each call).  At most
    about :data:`MAX_KNOTS` in all: a longer plan gets a longer period.
    """
    segment_times = np.asarray(segment_times)
    period = KNOT_PERIOD if period is None else period
    period = max(period, float(np.sum(segment_times)) / MAX_KNOTS)
    counts = np.maximum(1, np.ceil(segment_times / period).astype(int))
    return [np.arange(m) / m for m in counts]


def _report_residual(traj, profile, vibration_frequency):
    """
    Set optimizer['vibration_residual'] (and ['vibration_frequency'], where it is a figure).

    The plan's residual share at the mode: None without a
    ``vibration_frequency`` or with a moving end (no stop to ring after);
    else :func:`residual_vibration.report_residual` of the finished plan
    (its polynomials, 20 samples a period or 1 kHz), the figure the
    profile's rows bound, for the mode's assumed damping.  A uniform slow-down
    afterwards (``path_timing.rescaled``) measures it again at that frequency.
    """
    if profile.residual is None:    # no vibration_frequency, or a moving end
        traj.optimizer['vibration_residual'] = None
    else:
        report_residual(traj, vibration_frequency)


def plan_time_optimal(points, limits, dropped=(), torque=None, boundary=None,
                      vibration_frequency=0.0):
    """
    Return the Trajectory of steps 1-4 through ``points`` (N, n).

    ``limits`` are the :class:`limits.JointLimits` (inf: no jerk limit),
    ``dropped`` the merged waypoints' indices, ``torque`` a
    :class:`torque.TorqueLimit` or None: its rows join the profile's and
    its per-piece factors step 4's exact ones (plan() checks the result at
    1 kHz and slows it down uniformly if it must).  ``boundary``: the four
    boundary vectors (None: at rest).  With a moving end the path is the
    555 spline with the boundary values in its own time (``inner_knots``
    step 1), the profile keeps ``x = 1``, ``x' = 0`` there, and as a spline
    that keeps them cannot be scaled, the profile's limits are lowered by
    the factors :data:`MOVING_MARGINS` (velocity ``g``, acceleration
    ``g**2``, jerk ``g**3``) until the spline holds them.
    ``vibration_frequency`` [Hz] (0: none): with a rest end the profile
    cancels the ringing of a mode at it after the stop
    (``SmoothProfile(vibration_frequency=)``).  Raises :class:`NoSpline`
    with the last attempt's reason when the profile's first LP fails, when
    it stops inside the path, or when no spline is found (the caller falls
    back to the default construction).
    """
    n = points.shape[1]
    boundary = tuple(np.zeros(n) for _ in range(4)) if boundary is None else tuple(boundary)
    moving = (bool(np.any(boundary[0]) or np.any(boundary[1])),
              bool(np.any(boundary[2]) or np.any(boundary[3])))
    durations = rest_to_rest_durations(points, limits)
    floors = _boundary_floors(boundary, limits) if any(moving) else None
    for share in FLOORED_SHARES + END_SEGMENT_SHARES if any(moving) else (1.0,):
        # With a moving end, the end segments' own times shape the path there
        # (inner_knots step 1): its own acceleration and jerk near the end may
        # be more than any profile holds; other shares are tried.
        scale = np.ones(durations.size)
        if moving[0]:
            scale[0] = share
        if moving[1]:
            scale[-1] = share
        times = durations * scale
        try:
            return _followed_trajectory(points, limits, dropped, torque, boundary, moving,
                                        times, vibration_frequency,
                                        floors if share in FLOORED_SHARES else None)
        except NoSpline as error:
            why = error
    raise why


def _boundary_floors(boundary, limits):
    """
    Return the velocity and acceleration below which no profile limit goes, for ``boundary``.

    A moving end is a state of its own (a running plan's, at a limit more
    often than not): the profile keeps ``x = 1``, ``x' = 0`` there, so its
    lowered limits (:data:`MOVING_MARGINS`) must not be below the state's
    own velocity and acceleration, or its first LP is infeasible.  Per
    joint, the larger of the two ends' magnitudes, at most the limit.  From
    a running time_optimal plan's states at a limit (``bench_replanning.py``,
    three seeds) that took the states followed from 0-5 to 59-69 of
    104-118 on the path at the end segments' own time, and to 76-94 with
    the shares :data:`FLOORED_SHARES`.
    """
    velocity = np.maximum(np.abs(boundary[0]), np.abs(boundary[2]))
    acceleration = np.maximum(np.abs(boundary[1]), np.abs(boundary[3]))
    return (np.minimum(limits.velocity, velocity * (1.0 + 1e-9)),
            np.minimum(limits.acceleration, acceleration * (1.0 + 1e-9)))


def _followed_trajectory(points, limits, dropped, torque, boundary, moving, durations,
                         vibration_frequency=0.0, floors=None):
    """
    Return steps 1-4's Trajectory on the path at the segment ``durations`` (or NoSpline).

    ``floors``: :func:`_boundary_floors` (None: the lowered limits as they are).
    """
    ppoly, grid = first_path(points, durations, boundary)
    knots = grid[::GRID_STEPS]
    constraints = () if torque is None else (torque.constraint(),)
    problem = TimingProblem(FollowedPath(grid, ppoly, points, None if torque is None
                                         else torque.piece_factors), boundary, limits,
                            not any(moving))
    for margin in MOVING_MARGINS if any(moving) else (1.0,):
        profile, candidate = _follow(problem, ppoly, grid, knots, limits, constraints,
                                     tuple(float(m) for m in moving), margin,
                                     vibration_frequency, floors)
        if candidate is not None and candidate.feasible:
            traj = kept_trajectory(problem, candidate, dropped, {
                'speed_profile': NAME, 'inner_knots': int(np.max(candidate.counts)),
                'knots': int(candidate.pieces.size + 1),
                'inner_knots_per_segment': candidate.counts.tolist(),
                'profile_lps': profile.lps, 'profile_duration': float(profile.duration),
                'time_scale': float(candidate.scale), 'limit_margin': margin,
                'smoothing_windows': []})
            if traj is None:
                raise NoSpline('the spline through the profile could not be rebuilt on its '
                               'representable piece widths')
            _report_residual(traj, profile, vibration_frequency)
            return traj
    if candidate is None:
        raise NoSpline("no spline through the profile's knots")
    raise NoSpline("the spline through the profile's knots exceeds the limits" + (
        f' at every margin {MOVING_MARGINS}' if any(moving) else ''))


def _follow(problem, path, grid, knots, limits, constraints, ends=(0.0, 0.0), margin=1.0,
            vibration_frequency=0.0, floors=None):
    """
    Return steps 2-4 on ``path`` through ``knots``: (profile, candidate or None).

    The profile at ``margin`` times the velocity limits (its square the
    acceleration's, its cube :data:`JERK_MARGIN` times the jerk's; ``floors``:
    :func:`_boundary_floors` under the first two).  Raises :class:`NoSpline`
    when it has none: its first LP failed, or ``x`` reached 0 between its
    row points (a joint reversing alone, or a path that nearly turns back
    at a waypoint, such as chords at a cosine of -0.99: the profile stops
    there, and a stop takes its C2 ``x(s)`` forever.  Rows where ``x``
    dipped were tried: the spline through such a profile took twice the
    default's time).  ``vibration_frequency``: the
    profile's (0: none).  The candidate is :func:`_followed_spline`'s.
    A rest-to-rest spline is the profile's time law stretched by its exact
    factor ``k``, so the ringing at ``f`` it leaves is the profile's at
    ``f k``: where ``k`` is more than :data:`RESIDUAL_SCALE` from 1, the
    profile cancels ``f k`` instead, once, and the spline that rings less
    at ``f`` is kept (the new one has a factor of its own).
    """
    followed = _followed_profile(path, grid, knots, limits, constraints, ends, margin,
                                 vibration_frequency, floors)
    candidate = _followed_spline(problem, followed)
    residual = followed.profile.residual
    if (candidate is not None and candidate.feasible and residual is not None
            and np.isfinite(residual) and abs(candidate.scale - 1.0) > RESIDUAL_SCALE):
        try:
            again = _followed_profile(path, grid, knots, limits, constraints, ends, margin,
                                      vibration_frequency * candidate.scale, floors)
        except NoSpline:
            again = None
        stretched = None if again is None else _followed_spline(problem, again)
        if stretched is not None and stretched.feasible and (
                _ringing(problem, stretched, vibration_frequency, limits)
                < _ringing(problem, candidate, vibration_frequency, limits)):
            followed, candidate = again, stretched
    return followed.profile, candidate


def _ringing(problem, candidate, vibration_frequency, limits):
    """Return the residual share at ``vibration_frequency`` of ``candidate``'s plan (inf: none)."""
    traj = kept_trajectory(problem, candidate, (), {})
    share = None if traj is None else trajectory_residual(traj, vibration_frequency,
                                                          limits.acceleration)
    return np.inf if share is None else share


def _followed_profile(path, grid, knots, limits, constraints, ends, margin,
                      vibration_frequency, floors=None):
    """Return step 2's :class:`FollowedProfile` (:func:`_follow`); NoSpline: none, and why."""
    velocity, acceleration = margin * limits.velocity, margin ** 2 * limits.acceleration
    if floors is not None:
        velocity, acceleration = np.maximum(velocity, floors[0]), np.maximum(acceleration,
                                                                             floors[1])
    try:
        profile = SmoothProfile(path, grid, velocity, acceleration,
                                JERK_MARGIN * margin ** 3 * limits.jerk, constraints, ends,
                                vibration_frequency)
    except RuntimeError as error:
        raise NoSpline(str(error)) from error
    followed = FollowedProfile(profile, knots, grid.size)
    if not np.all(np.isfinite(followed.passed)):
        raise NoSpline('the profile stops inside the path (a joint reversing alone, or a '
                       'path that nearly turns back at a waypoint: every joint at rest at '
                       'once, or nearly)')
    return followed


def _followed_spline(problem, followed):
    """Return step 4's candidate on the knots of step 3 (pieces halved where needed), or None."""
    fractions = knot_fractions(np.diff(followed.passed))
    candidate = KnotCandidate(problem, followed.local, None, fractions, followed)
    if not candidate.valid:
        return None
    for _ in range(SPLIT_ROUNDS):
        # Where the spline does not follow (its piece needs a slow-down), a
        # knot at the piece's midpoint; kept while the whole gets shorter
        # (with moving ends: while its worst piece needs less).
        slow = np.flatnonzero(candidate.factors > SPLIT_FACTOR)
        if slow.size == 0:
            break
        fractions = midpoint_fractions(fractions, slow, most=None)
        finer = KnotCandidate(problem, followed.local, None, fractions, followed)
        if not (finer.valid and finer.score < candidate.score):
            break
        candidate = finer
    return candidate


def retime_path(traj, limits, constraints=(), piece_factors=None, vibration_frequency=0.0):
    """
    Return ``traj``'s path timed by the third-order profile (steps 2-4), rest to rest, or None.

    The path is ``traj.ppoly`` in its own time, through ``traj.waypoints``
    at ``traj.waypoint_times`` (a finished plan: the tool lines', whose
    path keeps the tool near its lines); the grid has a step about every
    :data:`RETIME_STEP` of that time and the waypoints.  ``constraints``
    and ``piece_factors`` are more rows of the profile and more factors of
    step 4 (tool speed and acceleration, torque).  The caller checks what
    the new spline does between its knots (the tool's deviation).
    ``vibration_frequency``: as :func:`plan_time_optimal`'s.  None when no
    profile or no spline is found.
    """
    knots = traj.waypoint_times
    # At least the profile's two end regions (a plan of tens of milliseconds).
    steps = max(2 * END_STEPS, int(np.ceil(traj.duration / RETIME_STEP)))
    grid = np.unique(np.concatenate([np.linspace(0.0, traj.duration, steps + 1), knots]))
    points = traj.waypoints
    boundary = tuple(np.zeros(points.shape[1]) for _ in range(4))
    problem = TimingProblem(FollowedPath(grid, traj.ppoly, points, piece_factors), boundary,
                            limits, True)
    try:
        profile, candidate = _follow(problem, traj.ppoly, grid, knots, limits,
                                     tuple(constraints), vibration_frequency=vibration_frequency)
    except (ValueError, NoSpline):
        return None     # a constraint's own refusal, or no profile: the lines keep their timing
    if candidate is None:
        return None
    retimed = kept_trajectory(problem, candidate, traj.dropped_waypoints, {
        'speed_profile': NAME, 'knots': int(candidate.pieces.size + 1),
        'profile_lps': profile.lps, 'profile_duration': float(profile.duration),
        'time_scale': float(candidate.scale), 'retimed_duration': float(traj.duration),
        'smoothing_windows': []})
    if retimed is not None:
        _report_residual(retimed, profile, vibration_frequency)
    return retimed
