"""``plan()``: the one entry point of the planning core."""

from dataclasses import dataclass, replace

import numpy as np

from .constraints.torque import checked_slow_down
from .durations.optimal import optimal_durations, two_segment_plan, two_segment_search
from .durations.ratio_search import GIVE_UP_PASSES
from .durations.timing import (chord_durations, rest_to_rest_durations, rest_to_rest_lower_bound,
                               rest_to_rest_scale, scaled_spline, ScaledSpline, uniform_scale)
from .path_following.inner_knots import plan_with_inner_knots
from .path_following.path_timing import rescaled
from .path_following.position_limit_knots import pulled_within
from .path_following.residual_knots import cancelled_residual
from .path_following.rest_ends import along_chords
from .path_following.time_optimal import (NAME as TIME_OPTIMAL, NO_TIME_OPTIMAL_SPLINE, NoSpline,
                                          plan_time_optimal)
from .plan_options import (check_time_optimal_waypoints, DEFAULT_SMOOTHING,
                           DEFAULT_WAYPOINT_TOLERANCE, PlanOptions)
from .speed_profile.residual_vibration import remeasure_residual, report_residual
from .spline.trajectory import Trajectory
from .validation import duration_array, position_limit_vector, waypoint_array

# The constants of plan(), each with its reason in one line; the measurements
# behind them are in doc/inner_knots.md ("Where the constants come from").
# Chords shorter than this (relative to the largest |coordinate|, at least 1)
# count as zero: such waypoints are exact duplicates, merged whatever the tolerance.
DUPLICATE_RTOL = 1e-12
# Position limits are met when no joint passes them by more than this
# (relative to the limit, at least 1): floating-point round-off.
POSITION_LIMIT_RTOL = 1e-12
# Optimal timing starts from the rest-to-rest durations instead of the uniform
# solution when that is this many times longer (see optimal_start).
ABSURD_UNIFORM = 2.0
# Requests of at most this many waypoints also get the knots-only optimum,
# and the shorter plan is returned (see _with_knots_only_rival): warm-started
# and giving up once it cannot win, it is cheap there, and it wins on short,
# fast moves, where the smoothing windows are a large share.
SMALL_REQUEST = 30
# The knots-only optimum of such a rival stops when its total gains less than
# this over two steps (optimal.STALL_TOLERANCE is 1e-4): its last LPs gain little.
RIVAL_STALL_TOLERANCE = 1e-3
# With non-zero boundary values the inner-knot plan is returned only when it
# is more than this share shorter than the knots-only optimum: its profile
# is not averaged then, and it pays for its time with jerk.
MOVING_END_GAIN = 0.05
# Trajectory.optimizer['inner_knots_skipped'] when the inner-knot construction
# found no spline within the limits (the plan has knots at the waypoints only).
NO_INNER_KNOT_SPLINE = 'no spline with inner knots found'
# Trajectory.optimizer['end_knots'] of a knots-only optimum that left the
# position limits at a rest end and got a knot next to each end (rest_ends).
END_KNOTS_REASON = 'a knot next to each rest end turns the end jerks along the chords'
# Trajectory.optimizer['knots_only_skipped'] when the knots-only rival (the
# optimum; the uniform plan above SMALL_REQUEST waypoints) won but left the
# position limits, and no turn at its rest ends stayed within them shorter than
# the inner-knot plan, which did (the text ends with the rival's duration).
KNOTS_ONLY_LEAVES = 'the knots-only plan left the position limits'
# Trajectory.optimizer['position_limit_knots'] of a plan that left the position
# limits and was pulled back within them by moving its knots (position_limit_knots).
POSITION_LIMIT_KNOTS = 'knots moved to keep {} within the position limits'
# Trajectory.optimizer['residual_knots'] of a vibration_frequency's plan whose
# knots were moved to cancel the mode's ringing after the stop (residual_knots).
RESIDUAL_KNOTS = ('knots of {} moved to cancel the ringing at {:g} Hz after the stop '
                  '(residual share {:.3g} -> {:.3g})')
# A pulled plan no longer than the plan it was by more than round-off is
# returned at once; a longer one (stretched for v/a/j) is compared with the
# other plans first (_pulled_or_other).
STRETCH_RTOL = 1e-9
# ... and its text names a stretch from this share on (4 digits show it).
STRETCH_SAID = 1e-4
# The start of optimizer['speed_profile_skipped'] or ['speed_profile_reason'] when
# the profile asked for left the position limits and another plan did not
# (planner._other_profile_within; the text ends with what was planned instead).
LEAVES_POSITION_LIMITS = 'speed_profile "{}" left the position limits'


@dataclass(frozen=True)
class MergedRequest:
    """
    A request with its duplicate waypoints merged: what a knots-only plan of it needs.

    ``method`` ("445", "434" or "555"), the merged waypoints ``points``
    (N, n) (:func:`merge_duplicates`), the four ``boundary`` vectors (start
    velocity and acceleration, end velocity and acceleration), the
    ``limits`` (:class:`limits.JointLimits`) and the indices ``dropped`` of
    the merged waypoints, which the trajectory reports.
    """

    method: str
    points: np.ndarray
    boundary: tuple
    limits: object
    dropped: list


def merge_duplicates(waypoints, tolerance=0.0):
    """
    Merge consecutive near-duplicate waypoints; return (kept, dropped indices).

    Two waypoints are near-duplicates when every joint differs by at most
    ``tolerance`` (or by round-off, :data:`DUPLICATE_RTOL`, when it is 0).
    Each waypoint is compared with the last one kept.  The first waypoint is
    always kept (it is where the robot is), and so is the last (the goal): a
    kept waypoint just before it that is its near-duplicate is dropped
    instead (of exact duplicates, the later ones are dropped, as anywhere).
    A tiny chord next to a rest end would get a tiny duration (eq. 11) and
    make the spline swing far out, so chord-based timing plans through the
    kept waypoints only; the trajectory passes within ``tolerance`` of every
    dropped one (within twice it when the goal replaced the kept waypoint a
    dropped one was compared with).
    """
    exact = DUPLICATE_RTOL * max(1.0, float(np.max(np.abs(waypoints))))
    tol = max(float(tolerance), exact)
    steps = np.max(np.abs(np.diff(waypoints, axis=0)), axis=1)
    if np.all(steps > tol):
        return waypoints, ()
    keep = [0]
    for i in range(1, waypoints.shape[0]):
        step = np.max(np.abs(waypoints[i] - waypoints[keep[-1]]))
        if step > tol:
            keep.append(i)
        elif i == waypoints.shape[0] - 1 and len(keep) > 1 and step > exact:
            keep[-1] = i
    if len(keep) < 2:
        if np.max(np.abs(waypoints[-1] - waypoints[0])) <= exact:
            raise ValueError('all waypoints coincide: need at least 2 distinct waypoints '
                             'for chord-length timing')
        keep.append(waypoints.shape[0] - 1)
    dropped = sorted(set(range(waypoints.shape[0])) - set(keep))
    return waypoints[keep], tuple(dropped)


def plan(waypoints, method='445', timing='uniform', durations=None,
         max_velocity=None, max_acceleration=None, max_jerk=None,
         start_velocity=None, start_acceleration=None,
         end_velocity=None, end_acceleration=None,
         waypoint_tolerance=DEFAULT_WAYPOINT_TOLERANCE, min_position=None, max_position=None,
         inner_knots=None, vibration_frequency=None, max_torque=None, inverse_dynamics=None,
         smoothing=None, speed_profile=None):
    """
    Plan a trajectory through ``waypoints`` (N, n_joints).

    Consecutive near-duplicate waypoints (every joint within
    ``waypoint_tolerance``) are merged for "uniform" and "optimal" timing
    (see :func:`merge_duplicates`, reported in
    ``Trajectory.dropped_waypoints``); "fixed" keeps them, since the caller's
    durations define the timing.  Raises ValueError naming the problem (and
    its index) for bad or infeasible input, and for a result that is not
    finite (absurd limits, durations or waypoints).

    Parameters
    ----------
    waypoints : array_like (N, n)
        Joint positions the trajectory passes through, in order.
    method : "445" (Petrinec & Kovacic: quartics and a final quintic, jerk
        continuous), "434" (Ho & Cook: quartic, cubics, quartic; C2) or "555"
        (quintics, jerk and snap continuous; stable on long lists).  The
        integer 555 (as a ROS parameter typed on the command line) is accepted
        too; see :mod:`methods`.
    timing : "fixed" uses ``durations``; "uniform" scales the chord
        durations of eq. (11) by the smallest common factor that meets every
        limit; "optimal" chooses every duration to minimise the total time.
    durations : array_like (N-1,)
        Positive segment durations in seconds: the timing for "fixed"; for
        "optimal", optionally where the optimisation starts instead of the
        uniform solution (a warm start, e.g. the optimal durations of a
        similar request; the uniform solution is still kept when the result
        is not shorter).  Not used by "uniform".
    max_velocity, max_acceleration : (n,) positive limits, needed for
        "uniform" and "optimal", optional for "fixed" (then only checked).
    max_jerk : (n,) positive limits or None (no jerk limit); +inf entries
        leave that joint's jerk unlimited.
    start_velocity, start_acceleration, end_velocity, end_acceleration : (n,)
        boundary values, zero when None.
    waypoint_tolerance : float >= 0, in joint units (rad or m)
        Consecutive waypoints closer than this in every joint are merged
        (default :data:`DEFAULT_WAYPOINT_TOLERANCE`; 0 merges exact
        duplicates only).
    min_position, max_position : (n,) or None
        Joint position limits (-inf / +inf entries: none), checked exactly
        on the polynomials; a plan that leaves them is rejected with the
        joint, the time and the excess.  A knots-only optimum of 555
        optimal with inner knots (left to plan() or asked for) that starts
        or stops a joint the wrong way at a rest end on a limit gets a knot
        next to each end, moved to turn that jerk along the chord
        (:mod:`rest_ends`; ``optimizer['end_knots']`` says so); where no
        such turn stays within them shorter than the inner-knot plan (or
        an end moves) and that plan stays within them, it is returned
        (``['knots_only_skipped']``).  For 555
        optimal where a plan still leaves them (a path that swings out),
        the knots-only optimum, then "time_optimal", then timing "uniform"
        (chord-length durations) is returned instead when it stays within
        them (not with ``inner_knots``, ``smoothing`` or a
        ``vibration_frequency`` given), and "time_optimal" asked for gives
        way to "smoothed", then "uniform", likewise ("smoothed" only with a
        ``vibration_frequency``, or above :data:`SMALL_REQUEST`
        waypoints); none other above :data:`SMALL_REQUEST` waypoints, and
        none where a moving end heads past a limit it sits on
        (:func:`_other_profile_within`).  The plan says so
        (``optimizer['speed_profile_reason']``, or
        ``['speed_profile_skipped']`` when time_optimal was asked for).
    inner_knots : int, 0 to 8, or None
        Most free inner knots per segment for method "555" with timing
        "optimal" (:mod:`inner_knots`; fewer on segments shorter than a few
        jerk ramp times): the result is still a C4 quintic spline through
        every waypoint, passed at ``waypoint_times``; its ``breakpoints``
        include the inner knots.  None (the default) is
        :data:`plan_options.DEFAULT_INNER_KNOTS` for 555 optimal
        (:data:`plan_options.TORQUE_INNER_KNOTS` with torque limits and no
        smoothing windows; rest to rest without either or a
        ``vibration_frequency``, up to :data:`inner_knots.LONG_MOST` on a
        long segment where that is shorter, step 8 of :mod:`inner_knots`)
        and 0 otherwise; 0 keeps knots at the waypoints
        only (the optimisation of :mod:`optimal`, which also takes the
        ``durations`` warm start).  When
        no spline with inner knots is found (non-zero boundary values it
        cannot keep within the limits), the knots-only optimum is returned
        and ``optimizer['inner_knots']`` is 0.
    vibration_frequency : float >= 0 [Hz], or None
        The arm's lowest structural mode, for 555 optimal with inner knots:
        the speed profile is averaged over two windows of ``1 / f``, so the
        path acceleration has no content at ``f`` (:func:`plan_options.
        smoothing_windows`).  None or 0 (the default): as ``smoothing``
        says.  "smoothed" averages rest-to-rest requests only:
        with non-zero boundary values the profile is not averaged
        (``optimizer['smoothing_windows']`` is then empty).  Given, the
        inner-knot plan is returned even where the knots-only optimum is
        shorter (that one has no zero at ``f``).  With ``speed_profile``
        "time_optimal" there are no windows: with a rest end (from a moving
        start too) its profile cancels the ringing a mode at ``f`` (damping
        ratio 0.02) is left with after the stop (:mod:`residual_vibration`):
        0.05-0.06 of TOPP-RA's ringing at 4-8 Hz (at most 0.1 of the static
        deflection ``a / w**2`` where it converges), against 0.35-0.85
        without, for a share of a period: 0.2-2 % of moves of several
        seconds, 7-9 % of 1-2 s moves with a jerk limit of hundreds of
        times the acceleration (the Panda's), medians; a mode far below the
        stop's own content (1.5 Hz) costs a median 5-10 % (at worst 30 %,
        more on short moves with such jerk limits) and is left 0.04-0.05.
        ``optimizer['vibration_residual']`` is what the plan leaves (the
        share of ``a / w**2``; None with a moving end, or when sampling it
        would take more than a million samples: 1 kHz on 50 s, 1 ms on
        1000 s).  The mode is taken at rest when the plan starts (from a
        moving start too).  A cancellation is narrow: a mode 10 % off in
        frequency is left 0.4-0.8 of TOPP-RA's ringing, one damped 0.01 or
        0.05 is left 0.13-0.25, and harmonics (8 Hz for 4) are not cancelled; the
        default's windows are broad (about 0.1 at all of these).
    max_torque, inverse_dynamics : (n,) positive limits [N m] (inf: none) and
        a function ``tau(q, qd, qdd)`` ((N, n) each -> (N, n)), or both None
        (:mod:`torque`).  When ``inverse_dynamics`` has a callable attribute
        ``gravity``, ``gravity(q)`` ((N, n) -> (N, n)) must equal
        ``inverse_dynamics(q, 0, 0)`` and is called for those (as an
        :class:`~splines445_ros.robot.dynamics.ArmDynamics`, callable as its
        ``torques``, has it: its own cheaper pass).  Rest to rest only.
        555 optimal with inner knots shapes its speed profile for them (the
        torque is one more constraint of the path-velocity step and of every
        piece); every other timing is slowed down uniformly by the smallest
        factor that holds them (checked at 1 kHz); "fixed" is only checked.
        A pose where gravity alone exceeds a limit is refused.  The result's
        ``torque_ratios`` (n,) are the peak torques over their limits.  The
        torque is taken as ``M(q) qdd + c(q, qd) + g(q)``, whose dynamic part
        falls as ``1 / f**2`` under a slow-down ``f``; damping (``D qd``) and
        dry friction go in callable attributes ``viscous(q, qd)`` and
        ``dry_friction(q)`` (:mod:`torque`).  A function with a term it does
        not expose so (a probe at 2 samples a joint of each check tells) has its
        slowed-down plans checked again and slowed further, conservatively.
    smoothing : "auto" (None, the default), "windows" or "none"
        Without a ``vibration_frequency``, for 555 optimal with inner knots:
        "windows" averages a rest-to-rest speed profile over the windows of
        :data:`plan_options.DEFAULT_SMOOTHING` (0.3 s and 0.15 s, 0.45 s
        longer: the arm's low modes shake about half as much as with
        TOPP-RA), "none" does not (about TOPP-RA's duration and shaking);
        "auto" is "windows" without torque limits and "none" with them
        (:data:`plan_options.SMOOTHINGS` says why).
    speed_profile : "smoothed" (None, the default) or "time_optimal"
        For 555 optimal: "smoothed" is the construction of
        :mod:`inner_knots` (or the knots-only optimum, when shorter), as
        ``inner_knots``, ``vibration_frequency`` and ``smoothing`` shape it.
        "time_optimal" follows the time-optimal third-order profile of
        :mod:`time_optimal` with a C4 spline (a knot every 15 ms or so): on
        the vendor arms 5-7 % shorter than "smoothed", with about 1.6
        times its 4 Hz shaking, planned in 3-5 times its time.  It holds
        the jerk limit of every joint that has one (only velocity and
        acceleration on the others; moving ends are kept; torque limits are
        rows of its profile).  It needs velocity and acceleration limits, no
        ``inner_knots`` or ``smoothing``, and at
        most :data:`plan_options.MAX_TIME_OPTIMAL_WAYPOINTS` waypoints
        (ValueError otherwise); ``durations`` are not used.  Should it find
        no spline, the plan is "smoothed"'s, with
        ``optimizer['speed_profile_skipped']`` saying so and why (the
        profile's LP failed, it stops inside the path, no spline through
        its knots holds the limits, or the spline could not be rebuilt on
        its representable piece widths).

    """
    points = waypoint_array(waypoints)
    with np.errstate(over='ignore', invalid='ignore', divide='ignore', under='ignore'):
        options = PlanOptions.from_arguments(
            points.shape[1], method=method, timing=timing, max_velocity=max_velocity,
            max_acceleration=max_acceleration, max_jerk=max_jerk,
            start_velocity=start_velocity, start_acceleration=start_acceleration,
            end_velocity=end_velocity, end_acceleration=end_acceleration,
            waypoint_tolerance=waypoint_tolerance, min_position=min_position,
            max_position=max_position, inner_knots=inner_knots,
            vibration_frequency=vibration_frequency, max_torque=max_torque,
            inverse_dynamics=inverse_dynamics, smoothing=smoothing,
            speed_profile=speed_profile)
    return plan_with_options(points, options, durations)


def plan_with_options(points, options, durations=None):
    """
    Plan through ``points`` (N, n), finite, under validated :class:`PlanOptions`.

    What :func:`plan` does once it has validated its arguments; the tool
    paths of ``cartesian/`` call it with the options they built once.
    ``durations`` as for :func:`plan` (checked here: they belong to the
    request, not to its options).
    """
    with np.errstate(over='ignore', invalid='ignore', divide='ignore', under='ignore'):
        traj = _profiled(points, durations, options)
        try:
            within_position_limits(traj, options.min_position, options.max_position,
                                   options.joint_names)
        except ValueError as leaves:
            return _pulled_or_other(points, durations, options, traj, leaves)
    return traj


def _pulled_or_other(points, durations, options, traj, leaves):
    """
    Return a plan within the position limits that ``traj`` left, or raise ``leaves``.

    ``traj`` with its knots moved within them (:func:`_pulled_within`)
    where the moves need no stretch; else the shorter of that and the
    first other plan within them (:func:`_other_profile_within`; not
    time_optimal for a smoothed plan that was pulled, which it would
    trade for its shaking): on random walks with a limit cut into a swing
    the knots-only optimum (6) or the chord-length plan (1) was shorter
    than a stretched pull on 7 of 63 (by 0.4-14 %), and shook less.
    """
    pulled = _pulled_within(traj, options, points)
    if pulled is not None and pulled.duration <= traj.duration * (1.0 + STRETCH_RTOL):
        return pulled
    try:
        other = _other_profile_within(points, durations, options, traj, leaves,
                                      rough=pulled is None)
    except ValueError:
        if pulled is None:
            raise
        return pulled
    return pulled if pulled is not None and pulled.duration <= other.duration else other


def _pulled_within(traj, options, points):
    """
    Return ``traj``, which left the position limits, pulled back within them, or None.

    Its knots are moved (:func:`position_limit_knots.pulled_within`), where
    it is a "smoothed" 555 optimal plan, rest to rest, of at most
    :data:`SMALL_REQUEST` requested ``points``, like the other plans (an LP
    a round and joint; over every knot it took 10 s at 100 waypoints on six
    joints, over a window of segments 0.14 s at 30): the same plan, with
    its inner knots and smoothing windows,
    rather than another plan (a uniform stretch where a move raised a v/a/j
    peak).  A segment without a knot of its own gets one, unless
    ``inner_knots`` was given as 0.  With a ``vibration_frequency`` the
    moves keep the mode's content in the acceleration (two equality rows a
    joint; without them the residual at the mode rose 1.11 times at the
    median, up to 16 times), and a pull that needed a stretch is not taken:
    it would move the plan's cancellation off the mode, which is not
    traded (:func:`_instead`).  Not a time_optimal plan: it is at its
    limits everywhere, so any move stretched it 1.7-3 times, with a knot
    every ~15 ms to move (its "smoothed" fallback is pulled instead,
    :func:`_other_profile_within`).  With torque limits the result is
    slowed down for them again, which keeps its positions.  The plan says
    so in ``optimizer['position_limit_knots']`` (the joints, the knots
    inserted, the stretch); its ``knots``, ``inner_knots`` and
    ``inner_knots_per_segment`` count the inserted knots.
    """
    if (options.method != '555' or options.timing != 'optimal' or options.limits is None
            or any(np.any(b) for b in options.boundary) or points.shape[0] > SMALL_REQUEST
            or (traj.optimizer or {}).get('speed_profile', 'smoothed') == TIME_OPTIMAL):
        return None
    low, high = options.min_position, options.max_position
    insert = options.inner_knots_auto or options.inner_knots > 0
    try:
        found = pulled_within(traj, low, high, position_limit_slack(low, high), insert,
                              options.vibration_frequency or None)
    except ValueError:      # a singular solve, or HiGHS refusing its input: no pull
        return None
    if found is None:
        return None
    pulled, joints, inserted = found
    names = ', '.join(joint_label(int(j), options.joint_names) for j in joints)
    said = [f'{inserted.size} knot{"s" * (inserted.size != 1)} inserted'] if inserted.size else []
    stretch = pulled.duration / traj.duration
    if stretch >= 1.0 + STRETCH_SAID:
        said.append(f'{stretch:.4g} times as long')
    record = pulled.optimizer
    record['position_limit_knots'] = POSITION_LIMIT_KNOTS.format(names) + (
        f' ({"; ".join(said)})' if said else '')
    if inserted.size:
        record['knots'] = int(pulled.breakpoints.size)
        counts = np.array(record.get('inner_knots_per_segment',
                                     np.zeros(traj.waypoints.shape[0] - 1, int)))
        counts[inserted] += 1
        if 'inner_knots_per_segment' in record:
            record['inner_knots_per_segment'] = counts.tolist()
        record['inner_knots'] = int(counts.max())
    remeasure_residual(pulled)
    try:
        if options.torque is not None:
            pulled = _torque_limited(pulled, options.torque)
        within_position_limits(pulled, low, high)
    except ValueError:
        return None
    if options.vibration_frequency and pulled.duration > traj.duration * (1.0 + STRETCH_RTOL):
        return None     # a stretch (for v/a/j or the torque) moves the cancellation off the mode
    return pulled


def _profiled(points, durations, options):
    """Plan under the v/a/j limits, then the torque limits: the plan before its position check."""
    traj = _plan_limited(points, durations, options)
    if options.torque is not None:
        traj = _torque_limited(traj, options.torque)
    return traj


def _other_profile_within(points, durations, options, traj, leaves, rough=True):
    """
    Return another plan of the request that stays within the position limits, if one does.

    ``traj``, planned with ``options``, left them (``leaves``, the error
    naming the joint), and no move of its knots kept it within them
    without a stretch (:func:`_pulled_or_other`).  Two plans of one request
    leave them differently: each profile's path swings out its own way between waypoints
    (``benchmarks/bench_position_limits.py``: 3-6 of 80 moves from limit
    to limit).  The inner-knot construction no longer starts or stops a
    joint the wrong way (step 4 of :mod:`inner_knots`), and a knots-only
    optimum of plan()'s own that does was turned at its ends first
    (:func:`_within_at_rest_ends`).  Tried in turn, for 555 optimal where
    :func:`_instead` allows it:

    1. the knots-only optimum (knots at the waypoints only, still
       "smoothed"): slower than the inner-knot plan but as smooth; not
       with ``inner_knots`` or ``smoothing`` given, which it would ignore;
    2. speed_profile "time_optimal", whose jerk at a rest end has the
       path's direction: faster, but it shakes about as much as TOPP-RA;
       not with ``inner_knots`` or ``smoothing`` given;
    3. timing "uniform": knots at the waypoints with the paper's
       chord-length durations (eq. 11) and one common scale (not from the
       caller's ``durations``); not with ``inner_knots``, ``smoothing`` or
       a ``vibration_frequency`` given.  Where every
       profile's path swings out (uneven steps one way: 4 of 480 of the
       tests' limit-to-limit moves, by 0.001-0.017 rad), the chord-length
       spline stayed within on each, 1.4-1.8 times as long;

    and for "time_optimal" asked for, "smoothed" (pulled within by its knots
    where it leaves them, :func:`_pulled_within`; stretched, it is compared
    with 3 and the shorter returned), then 3.  The first plan within
    the limits is returned, saying so (``speed_profile_reason``, or
    ``speed_profile_skipped`` when time_optimal was asked for, each
    starting with :data:`LEAVES_POSITION_LIMITS` and ending with what was
    planned instead; a time_optimal that had given way before, finding no
    spline, keeps its ``speed_profile_skipped``); ``leaves`` is raised
    when none is.  ``rough`` False: 2 is not tried for a "smoothed" plan
    (:func:`_pulled_or_other`, which has a smooth plan within already).
    """
    used = (traj.optimizer or {}).get('speed_profile', 'smoothed')
    why = f'{LEAVES_POSITION_LIMITS.format(used)} ({leaves})'
    # time_optimal asked for and given way already (no spline): that says why too.
    earlier = (traj.optimizer or {}).get('speed_profile_skipped')
    stretched = None    # a pulled "smoothed" fallback that needed a stretch, and its text
    for again, said in _instead(options, traj, used, points):
        if not rough and used != TIME_OPTIMAL and again.speed_profile == TIME_OPTIMAL:
            continue
        try:
            # A caller's durations start optimal timing; uniform timing has none.
            start = None if again.timing == 'uniform' else durations
            found = _profiled(points, start, again)
            try:
                within_position_limits(found, again.min_position, again.max_position)
            except ValueError:
                # time_optimal asked for: its "smoothed" fallback is pulled within;
                # stretched, it is compared with the next plan (_pulled_or_other).
                pulled = (_pulled_within(found, again, points) if used == TIME_OPTIMAL
                          else None)
                if pulled is None:
                    raise
                if pulled.duration > found.duration * (1.0 + STRETCH_RTOL):
                    stretched = (pulled, said)
                    continue
                found = pulled
        except ValueError:
            continue
        if stretched is not None and stretched[0].duration <= found.duration:
            found, said = stretched
        return _said_instead(found, used, f'{why}{said}', earlier)
    if stretched is not None:
        return _said_instead(stretched[0], used, f'{why}{stretched[1]}', earlier)
    raise leaves


def _said_instead(found, used, why, earlier):
    """Return ``found``, planned instead of the ``used`` profile's plan, saying so and why."""
    key = 'speed_profile_skipped' if used == TIME_OPTIMAL else 'speed_profile_reason'
    found.optimizer = dict(found.optimizer or {}, **{key: why})
    if earlier and key != 'speed_profile_skipped':
        found.optimizer['speed_profile_skipped'] = earlier
    return found


def _instead(options, traj, used, points):
    """
    Return the (options, what the plan says) to try, in order, when ``traj`` leaves the limits.

    ``used`` is the speed profile ``traj`` was planned with.  The list
    (see :func:`_other_profile_within`):

    * empty for requests of more than :data:`SMALL_REQUEST` waypoints (the
      other plans cost up to seconds there, for a refusal more often than
      not; but a time_optimal plan still gets "smoothed", the default plan,
      cheaper than its own), where a moving end heads past a limit it sits on
      (:func:`_heads_past_a_limit`: no plan stays within), and for a
      "smoothed" plan with ``inner_knots`` or ``smoothing`` given (the
      others would silently ignore them) or with a ``vibration_frequency``
      ("smoothed" is not traded: the knots-only and the chord-length plans
      have no zero at the mode, and time_optimal's cancellation is narrow:
      a mode 10 % off rings 0.4-0.8 of TOPP-RA's, against 0.1 with the
      windows);
    * time_optimal's plan left them: "smoothed", then the chord-length
      durations (not with a ``vibration_frequency``);
    * time_optimal was asked for and gave way to "smoothed" already (it
      found no spline): the chord-length durations only;
    * otherwise the knots-only optimum (where ``traj`` has inner knots),
      time_optimal, then the chord-length durations, last.
    """
    if (options.timing != 'optimal' or options.method != '555'
            or _heads_past_a_limit(points, options)):
        return []
    large = points.shape[0] > SMALL_REQUEST
    # Not with a mode to cancel: the chord-length spline has no zero at it.
    chords = [] if options.vibration_frequency or large else [(
        replace(options, timing='uniform', speed_profile='smoothed', inner_knots=0,
                inner_knots_auto=False),
        ': planned with timing "uniform" (chord-length durations) instead, slower')]
    if used == TIME_OPTIMAL:
        # At any size: "smoothed" is the default plan, cheaper than time_optimal's own.
        return [(replace(options, speed_profile='smoothed'),
                 ': planned with speed_profile "smoothed" instead (within every limit, but '
                 'slower)')] + chords
    if large:
        return []
    if options.speed_profile == TIME_OPTIMAL:
        return chords       # time_optimal fell back to "smoothed" already
    if options.vibration_frequency:
        return []           # a mode to cancel
    if not (options.inner_knots_auto and options.smoothing == 'auto'):
        return []           # options that the other plans would silently ignore
    tries = []
    if (traj.optimizer or {}).get('inner_knots', 0) > 0:
        tries.append((replace(options, inner_knots=0, inner_knots_auto=False),
                      ': planned with knots at the waypoints only instead'))
    return tries + [(replace(options, speed_profile=TIME_OPTIMAL),
                     f': planned with speed_profile "{TIME_OPTIMAL}" instead')] + chords


def _heads_past_a_limit(points, options):
    """
    Whether a moving end sits on a position limit and heads past it (no plan stays within).

    At the start ``q0 + v t + a t**2 / 2``: past the upper limit for
    ``v > 0``, or ``v = 0`` and ``a > 0``; at the end, where the motion
    comes from, past it for ``v < 0``, or ``v = 0`` and ``a > 0``; the
    lower limit likewise, mirrored.
    """
    low, high = options.min_position, options.max_position
    v0, a0, v1, a1 = options.boundary
    slack = position_limit_slack(low, high)
    for q, v, a, sign in ((points[0], v0, a0, 1.0), (points[-1], v1, a1, -1.0)):
        up = sign * v > 0.0
        up |= (v == 0.0) & (a > 0.0)
        down = sign * v < 0.0
        down |= (v == 0.0) & (a < 0.0)
        if np.any((q >= high - slack[1]) & up) or np.any((q <= low + slack[0]) & down):
            return True
    return False


def check_position_limits(traj, min_position=None, max_position=None, joint_names=None):
    """
    Raise ValueError when ``traj`` leaves [min_position, max_position] on any joint.

    The check is exact (the polynomials' position extremes,
    :meth:`Trajectory.position_extrema`); the error names the joint (its
    index, and its name from ``joint_names`` when given), the time and the
    excess of the worst violation.
    """
    if min_position is None and max_position is None:
        return
    n = traj.n_joints
    low = position_limit_vector('min_position', min_position, n, -np.inf)
    high = position_limit_vector('max_position', max_position, n, np.inf)
    bad = np.flatnonzero(low > high)
    if bad.size:
        j = int(bad[0])
        raise ValueError(f'min_position[{j}] = {low[j]} is above max_position[{j}] = {high[j]}')
    within_position_limits(traj, low, high, joint_names)


def within_position_limits(traj, low, high, joint_names=None):
    """
    Raise ValueError when ``traj`` leaves [low, high] (validated (n,) arrays, or both None).

    :func:`check_position_limits` without the checks of its arguments.
    """
    if low is None:
        return
    q_low, q_high, t_low, t_high = traj.position_extrema()
    excess = np.stack([low - q_low, q_high - high])
    if np.all(excess <= position_limit_slack(low, high)):
        return
    side, j = np.unravel_index(int(np.argmax(excess)), excess.shape)
    joint = joint_label(j, joint_names)
    if side == 0:
        raise ValueError(f'{joint} goes to {q_low[j]:.6g} at t = {t_low[j]:.6g} s, '
                         f'{excess[0, j]:.3g} below min_position[{j}] = {low[j]:g}')
    raise ValueError(f'{joint} goes to {q_high[j]:.6g} at t = {t_high[j]:.6g} s, '
                     f'{excess[1, j]:.3g} above max_position[{j}] = {high[j]:g}')


def position_limit_slack(low, high):
    """
    Return (2, n): how far past ``low`` and ``high`` a position is still within them.

    A velocity root a hair inside a segment next to a knot that sits on a
    limit can evaluate an ulp past it: round-off, not a violation
    (:data:`POSITION_LIMIT_RTOL`, relative to the limit, at least 1); 0 on
    an unbounded side.
    """
    slack = POSITION_LIMIT_RTOL * np.maximum(1.0, np.abs(np.stack([low, high])))
    return np.where(np.isfinite(slack), slack, 0.0)


def joint_label(j, joint_names=None):
    """Return how errors name joint ``j``: ``joint 1``, or ``joint 1 (shoulder)`` with names."""
    return f'joint {j}' + ('' if joint_names is None else f' ({joint_names[j]})')


def _torque_limited(traj, torque, to_beat=None):
    """
    Return ``traj`` slowed down uniformly as little as its torque limits need (rest to rest).

    Fixed timing is only checked: a ValueError names the joint.  The result
    carries ``torque_ratios`` (n,): peak torque over its limit per joint,
    and ``torque_factor`` <= 1 (its 1 kHz check).  ``to_beat``, a duration:
    None when slowing down makes ``traj`` at least that long (a rival that
    has lost), as soon as a lower bound of its factor shows it
    (:meth:`TorqueLimit.factor_at_least`, samples every 10 ms) or its 1 kHz
    check does, without checking the slowed-down plan.
    """
    if traj.torque_factor is not None and traj.torque_factor <= 1.0:
        return traj     # checked already
    if to_beat is not None and traj.duration * torque.factor_at_least(traj) >= to_beat:
        return None
    check = torque.check(traj)
    factor, ratios = check.needs()
    if factor > 1.0:
        if traj.timing == 'fixed':
            j = int(np.argmax(ratios))
            raise ValueError(f'joint {j} needs {ratios[j]:.4g} times its torque limit with '
                             f'the given durations: slow them down by {factor:.4g}')
        # The slowed-down plan's check is this one's, rescaled (TorqueCheck):
        # no second 1 kHz check, unless the inverse dynamics does not scale so.
        slow = check.slow_down_with(torque_need=factor)
        if to_beat is not None and traj.duration * slow >= to_beat:
            return None
        traj, slow, (factor, ratios) = checked_slow_down(torque, check, traj, slow,
                                                         slowed_down)
    traj.torque_ratios = ratios
    traj.torque_factor = factor
    return traj


def slowed_down(traj, factor):
    """Return the rest-to-rest ``traj`` with every duration times ``factor`` (> 1)."""
    if traj.breakpoints.size != traj.waypoint_times.size:
        return rescaled(traj, factor)   # inner knots
    slow = Trajectory.build(traj.method, traj.timing, traj.waypoints, traj.durations * factor,
                            (traj.start_velocity, traj.start_acceleration, traj.end_velocity,
                             traj.end_acceleration), traj.limits,
                            scale=None if traj.scale is None else traj.scale * factor,
                            dropped_waypoints=traj.dropped_waypoints)
    if traj.optimizer is not None:
        slow.optimizer = dict(traj.optimizer, time_scale=float(factor))
        remeasure_residual(slow)
    return slow


def _plan_limited(points, durations, options):
    """Plan under the v/a/j limits (and, for 555 optimal with inner knots, the torque)."""
    method, timing, limits = options.method, options.timing, options.limits
    boundary, torque = options.boundary, options.torque
    inner_knots, windows = options.planned_inner_knots, options.windows
    if timing == 'fixed':
        seg_durations = duration_array(durations, points.shape[0] - 1)
        return Trajectory.build(method, timing, points, seg_durations, boundary, limits)

    if durations is not None and timing != 'optimal':
        raise ValueError(f'durations are only used with timing "fixed" or "optimal", '
                         f'not {timing!r}')
    start = None if durations is None else duration_array(durations, points.shape[0] - 1)
    requested = points
    points, dropped = merge_duplicates(points, options.waypoint_tolerance)
    if start is not None and dropped:
        # A dropped waypoint's segment joins the one before it.
        start = np.diff(np.delete(np.concatenate([[0.0], np.cumsum(start)]), dropped))
    if options.speed_profile == 'time_optimal':
        check_time_optimal_waypoints(points.shape[0])
        try:
            return plan_time_optimal(points, limits, dropped, torque, boundary,
                                     options.vibration_frequency)
        except NoSpline as why:
            # No spline found: the default construction's plan of the request as
            # it came (merging twice could merge more), which says so and why.
            traj = _plan_limited(requested, durations,
                                 replace(options, speed_profile='smoothed'))
            traj.optimizer['speed_profile_skipped'] = f'{NO_TIME_OPTIMAL_SPLINE}: {why}'
            return traj
    search = give_up = None     # two segments: the knots-only optimum's search (below)
    if inner_knots:
        rest = options.rest
        shaped = windows not in ((), DEFAULT_SMOOTHING) and rest
        # The knots-only optimum is the rival below: the construction's own
        # knots-only candidates would only repeat it, less well.  With torque
        # limits and no smoothing windows there is no knots-only plan at all:
        # slowed down for the torque, such plans do not win and cost time.
        torque_only = options.torque_without_windows
        optimum_rival = _optimum_rival(points) and not shaped and not torque_only
        if optimum_rival and torque is None and len(points) == 3 and rest:
            # Two segments: the knots-only optimum is a cheap search, whose
            # first passes bound it; the construction stops once it cannot
            # beat that.
            try:
                search = two_segment_search(method, points, start, limits)
                give_up = search.run(GIVE_UP_PASSES).best_total
            except ValueError:
                search = None   # a singular system: the rival is optimal_durations'
        refined = plan_with_inner_knots(points, boundary, limits, inner_knots, dropped,
                                        windows, torque,
                                        knots_only=not optimum_rival and not torque_only,
                                        keep_time_scale=shaped, give_up=give_up,
                                        long_segments=options.inner_knots_auto)
        if refined is not None and shaped:
            # A vibration_frequency asks for a profile without content at it,
            # which only the inner-knot plan has: no rival then.  With moving
            # ends the profile is not averaged, so the rival stays.
            return _with_ringing_cancelled(refined, options)
        if refined is not None and torque_only:
            return _torque_limited(refined, torque)
        if refined is not None:
            return _with_knots_only_rival(
                refined, MergedRequest(method, points, boundary, limits, dropped), start,
                torque, search, options)
    knots_only = _plan_knots_only(MergedRequest(method, points, boundary, limits, dropped),
                                  timing, start, search)
    if timing == 'optimal':
        knots_only.optimizer['inner_knots'] = 0
        if inner_knots:
            knots_only.optimizer['inner_knots_skipped'] = (
                NO_INNER_KNOT_SPLINE if give_up is None else
                'no spline with inner knots shorter than the knots-only optimum')
            if options.rest:
                knots_only = _within_at_rest_ends(knots_only, options)
    return knots_only


def _with_ringing_cancelled(refined, options):
    """
    Return the inner-knot plan ``refined`` of a ``vibration_frequency``, its ringing cancelled.

    The windows of 1/f put spectral zeros at f in the path's acceleration,
    but a curved path modulates it: on the vendor arms the ringing after
    the stop stayed at up to 0.6 of TOPP-RA's (the Panda).  Its knots are
    moved (:func:`residual_knots.cancelled_residual`), each joint as far
    as its v/a/j and position limits, its ends and the ringing during the
    motion allow without a stretch; the plan says so in
    ``optimizer['residual_knots']`` (the joints, the largest residual
    share before and after) and reports its ``vibration_residual``.
    ``refined`` as it was where nothing moved, and with torque limits (a
    move changes the torques, and the slow-down for them would move the
    cancellation off the mode).
    """
    if options.torque is not None:
        return refined
    low, high = options.min_position, options.max_position
    if low is None:
        low, high = np.full((2, refined.n_joints), np.inf) * [[-1.0], [1.0]]
    try:
        found = cancelled_residual(refined, options.vibration_frequency, low, high)
    except ValueError:      # a singular solve: nothing moved
        found = None
    if found is None:
        return refined
    cancelled, joints, before, after = found
    names = ', '.join(joint_label(int(j), options.joint_names) for j in joints)
    cancelled.optimizer['residual_knots'] = RESIDUAL_KNOTS.format(
        names, options.vibration_frequency, before, after)
    report_residual(cancelled, options.vibration_frequency)
    return cancelled


def _within_at_rest_ends(traj, options, to_beat=np.inf):
    """
    Return the knots-only ``traj``, or where it leaves the position limits, it turned at its ends.

    555 optimal with inner knots left to plan() (or asked for), rest to
    rest: a knots-only optimum has no inner knot to pull a joint back that
    starts or stops the wrong way, past a limit it sits on (step 4 of
    :mod:`inner_knots` does that for the inner-knot plan).  It gets a knot
    next to each end (:func:`rest_ends.along_chords`), kept when it stays
    within the limits and is shorter than ``to_beat``, with
    ``optimizer['end_knots']`` saying so; ``traj`` otherwise (the caller
    decides: the inner-knot plan, or plan()'s other plans,
    :func:`_other_profile_within`, which refuses the request with
    ``inner_knots`` or ``smoothing`` given).
    """
    low, high = options.min_position, options.max_position
    if _within(traj, low, high):
        return traj
    turned = along_chords(traj, lambda t: t.duration < to_beat and _within(t, low, high))
    if turned is None:
        return traj
    turned.optimizer['end_knots'] = END_KNOTS_REASON
    return turned


def _with_knots_only_rival(refined, request, start, torque=None, search=None,
                           plan_options=None):
    """
    Return ``refined`` (inner knots), or a knots-only plan of ``request`` when it is shorter.

    ``request`` is the :class:`MergedRequest`, ``start`` the caller's
    durations (or None), ``plan_options`` the request's
    :class:`PlanOptions` (None: no position limits).  A rival that leaves
    the position limits is turned at its rest ends, rest to rest
    (:func:`_within_at_rest_ends`), and returned only if it is still
    shorter; otherwise (or with a moving end) ``refined`` is, where it
    stays within them.

    The rival is the knots-only optimum for requests of at most
    :data:`SMALL_REQUEST` waypoints and of one joint (:func:`_optimum_rival`),
    where it costs tens of milliseconds
    and wins now and then (one segment, a joint reversing at every
    waypoint, a short fast move that the smoothing window lengthens);
    uniform timing otherwise, which costs a banded solve.  So
    the result is never longer than either (a rival that gives up, below,
    is returned when it is shorter all the same).  With torque limits both
    are compared as they will be returned (slowed down for the torque).
    With non-zero boundary values the knots-only optimum is kept unless
    ``refined`` is shorter by more than :data:`MOVING_END_GAIN`.  Two
    segments rest to rest, the rival is the search ``search``
    (:func:`optimal.two_segment_search`, started by the caller; given up
    when its first passes show it cannot beat ``refined``).

    Rest to rest, the optimum is cheaper to find:

    * one segment: its duration alone is free, so the optimum is the
      uniform solution (the smallest factor that meets the limits), which
      :func:`_plan_knots_only` returns;
    * it starts from the segment durations of ``refined`` without the
      smoothing windows (:func:`_unsmoothed_durations`; unless the caller
      gave ``durations``): close to the optimum when the rival can win,
      without :func:`optimal_start`'s uniform and rest-to-rest solutions.
      Not with one joint: from there it often ended in another local
      optimum, so a single joint's rival is plan(inner_knots=0)'s,
      cold-started and run to the end (its LPs are small).  Nor with
      torque limits (smoothing windows given): the warm start ended in a
      v/a/j optimum that the torque's slow-down left up to 1.5 % longer
      than plan(inner_knots=0)'s (145 of 301 two-link requests longer, 7
      by more than 0.5 %); cold it is that plan, for 12-20 % more planning on the
      vendor arms (the Kinova 81 %; at most 0.1 % shorter there);
    * it stops at a gain of :data:`RIVAL_STALL_TOLERANCE` over two steps
      (a knob: coarser is faster, and longer where the rival wins);
    * it gives up once its restored total is above ``refined``'s duration
      by more than a margin that halves at every step
      (:data:`optimal.GIVE_UP_MARGIN`): it is not going to win (not with
      torque limits, whose rival is not warm-started);
    * with torque limits ``refined`` is slowed down for them first, and
      the rival, which a slow-down only lengthens, is not checked (1 kHz
      of inverse dynamics) when it is already longer;
    * a rival that cannot win any more is neither restored nor built, and
      its uniform timing only bounded from below unless it could win
      (:func:`optimal.optimal_durations` returns None; with
      :func:`optimal._beyond_give_up` and the sampled bounds of
      ``PeakRatios.evaluate``: the same plans bit for bit, sooner).

    The measurements behind these choices are in doc/inner_knots.md
    ("Where the constants come from").
    """
    points, boundary = request.points, request.boundary
    rest = not any(np.any(b) for b in boundary)
    small = _optimum_rival(points)
    timing = 'optimal' if small else 'uniform'
    options = {}
    # Not with torque limits: the v/a/j inner-knot plan's durations lead to a
    # knots-only optimum that the torque's slow-down can make 1.5 % longer
    # than the cold one's (below).
    warm = small and rest and points.shape[1] > 1 and torque is None
    if warm and start is None:
        start = _unsmoothed_durations(refined)
    if torque is not None:
        # Compared as returned: the torque's slow-down only lengthens a plan,
        # so the rival is beaten once it is longer than this before its own.
        refined = _torque_limited(refined, torque)
    if warm:
        options = {'stall_tolerance': RIVAL_STALL_TOLERANCE, 'give_up': refined.duration}
    try:
        rival = _plan_knots_only(request, timing, start, search, **options)
        if rival is None:
            return refined  # it could not beat refined (optimal.CANNOT_WIN_RTOL)
        if torque is not None:
            # Slowed down for the torque the rival only gets longer: once it
            # is longer, it is not checked (again).
            if rival.duration >= refined.duration:
                return refined
            rival = _torque_limited(rival, torque, to_beat=refined.duration)
            if rival is None:
                return refined
    except ValueError:
        return refined
    # With moving ends the inner-knot profile is not averaged (no smoothing
    # window): it pays for its time with jerk, so the knots-only optimum is
    # kept unless the inner knots gain more than MOVING_END_GAIN.
    premium = 1.0 if rest or timing != 'optimal' else 1.0 + MOVING_END_GAIN
    if refined.duration * premium <= rival.duration:
        return refined
    turned = rival
    if plan_options is not None:
        low, high = plan_options.min_position, plan_options.max_position
        if rest:
            turned = _within_at_rest_ends(rival, plan_options, refined.duration)
        if turned is not rival and torque is not None:
            # Slowed down for the torque it keeps its path: still within.
            turned = _torque_limited(turned, torque, to_beat=refined.duration)
            turned = rival if turned is None else turned
        if turned is rival and not _within(rival, low, high) and _within(refined, low, high):
            # Not turned (a moving end, or no turn within the limits and
            # shorter than refined): refined, within them, as smooth.
            refined.optimizer['knots_only_skipped'] = (
                f'{KNOTS_ONLY_LEAVES} ({rival.duration:.6g} s)')
            return refined
    if turned is rival and timing == 'uniform':
        turned = _as_optimal(rival, request)
    turned.optimizer.update(inner_knots=0, inner_knots_duration=refined.duration)
    return turned


def _within(traj, low, high):
    """Whether ``traj`` stays within the validated limits [low, high] (both None: no limits)."""
    try:
        within_position_limits(traj, low, high)
    except ValueError:
        return False
    return True


def _as_optimal(traj, request):
    """
    Return the knots-only ``traj`` of uniform timing as a plan of optimal timing: the same spline.

    ``traj`` plans the :class:`MergedRequest` ``request``.

    Its torque check, if any, stands (plan() would run it again).
    """
    optimal = Trajectory.build(traj.method, 'optimal', request.points, traj.durations,
                               request.boundary, request.limits, traj.coefficients,
                               traj.limit_ratios(), dropped_waypoints=request.dropped)
    optimal.optimizer = {}
    optimal.torque_ratios, optimal.torque_factor = traj.torque_ratios, traj.torque_factor
    return optimal


def _optimum_rival(points):
    """
    Whether the knots-only optimum is the rival of the inner-knot plan of ``points``.

    Up to :data:`SMALL_REQUEST` waypoints, and for a single joint at any
    length: with uniform timing as the rival, longer requests of several
    joints were never longer than the knots-only optimum, single-joint ones
    were.  A single joint's rival runs to its end (a cold start that gives
    up loses that one).  The measurements: doc/inner_knots.md ("Where the
    constants come from").
    """
    return len(points) <= SMALL_REQUEST or points.shape[1] == 1


def _unsmoothed_durations(refined):
    """
    Return the segment durations of ``refined`` without its smoothing windows' lengthening.

    The rival's warm start.  Averaging the profile over windows of total
    width ``W`` lengthens the plan by ``W``, at its ends: the first and last
    segments each get about ``W / 2`` (each keeps at least half of its
    time).  From the smoothed waypoint times themselves a rival can start
    too far above the inner-knot plan, give up and lose to the knots-only
    optimum it would have been (doc/inner_knots.md, "Where the constants
    come from").
    """
    durations = np.diff(refined.waypoint_times)
    half = 0.5 * sum(refined.optimizer.get('smoothing_windows', ()))
    for end in (0, -1):
        durations[end] = max(durations[end] - half, 0.5 * durations[end])
    return durations


def _plan_knots_only(request, timing, start, search=None, **options):
    """
    Uniform or optimal timing with knots at the waypoints only (``options``: optimal's).

    ``request`` is the :class:`MergedRequest`, ``start`` the durations
    optimal timing starts from (None: its own start).  With a ``give_up``
    total among the options, None when the plan would be longer than it
    (:func:`optimal.optimal_durations`).  Two segments rest to rest: the
    search of :func:`optimal.two_segment_search` (``search``, when the
    caller has started it).
    """
    method, points, boundary = request.method, request.points, request.boundary
    limits, dropped = request.limits, request.dropped
    chords = chord_durations(points)
    if not np.all(np.isfinite(chords)):
        raise ValueError('waypoints too large: chord lengths overflow')
    rest = not any(np.any(b) for b in boundary)
    if timing == 'optimal' and rest and chords.size == 1:
        # One segment rest to rest: its duration alone is free, and the
        # smallest factor that meets the limits is the optimum (the SLP came
        # within round-off of it, on either side of uniform timing's).
        uniform = _plan_knots_only(request, 'uniform', None)
        optimum = _as_optimal(uniform, request)
        optimum.optimizer = {'iterations': 0, 'message': 'one segment: the uniform solution',
                             'uniform_duration': uniform.duration}
        return optimum
    if timing == 'optimal' and rest and chords.size == 2:
        # One ratio of durations is free: searched on a grid (ratio_search).
        try:
            if search is None:
                search = two_segment_search(method, points, start, limits)
            return two_segment_plan(method, points, limits, dropped, search,
                                    options.get('give_up'))
        except ValueError:
            pass    # a singular system: optimal_durations below
    if timing == 'optimal' and start is not None and options.get('give_up') is not None \
            and rest:
        # A rest-to-rest rival: uniform timing is solved only if it can still
        # win, and otherwise only bounded (timing.rest_to_rest_lower_bound).
        spline = ScaledSpline(method, points, chords, boundary)

        def build_uniform():
            scale, ratios = uniform_scale(spline, limits)
            return Trajectory.build(method, 'uniform', points, spline.durations(scale),
                                    boundary, limits, spline.coefficients(scale), ratios,
                                    scale=scale, dropped_waypoints=dropped)

        at_least = rest_to_rest_lower_bound(spline, limits) * float(chords.sum())
        return optimal_durations(method, points, start, boundary, limits, dropped,
                                 build_uniform, uniform_at_least=at_least, **options)
    try:
        spline, scale, ratios = scaled_spline(method, points, chords, boundary, limits)
    except ValueError as exc:
        if 'infeasible' not in str(exc):
            raise
        if timing != 'optimal':
            raise ValueError(f'{exc} (timing "optimal" may still find durations)') from None
        # The paper's common factor cannot meet the limits: optimise from the
        # rest-to-rest factor's durations (unless given), which are infeasible.
        if start is None:
            start = chords * rest_to_rest_scale(
                ScaledSpline(method, points, chords, boundary), limits)
        return optimal_durations(method, points, start, boundary, limits, dropped, **options)
    uniform = Trajectory.build(method, 'uniform', points, spline.durations(scale), boundary,
                               limits, spline.coefficients(scale), ratios, scale=scale,
                               dropped_waypoints=dropped)
    if timing == 'optimal':
        if start is None:
            start = optimal_start(request, uniform)
        return optimal_durations(method, points, start, boundary, limits, dropped, uniform,
                                 **options)
    return uniform


def optimal_start(request, uniform):
    """
    Return where optimal timing starts: uniform, or rest-to-rest durations when far better.

    ``request`` is the :class:`MergedRequest`, ``uniform`` its uniform-timing
    trajectory.

    Uniform timing gives a near-duplicate waypoint (above the tolerance) a
    tiny chord duration and then stretches the whole path; the optimiser
    keeps every duration within a box around its start (``MIN_FRACTION``,
    moved where the iterate ends on it: ``optimal._iterate_in_box``), and a
    local optimiser need not recover from such a start.  Each segment's
    rest-to-rest time under every joint's v/a/j limits
    (:func:`rest_to_rest_durations`) is
    well scaled whatever the chords; scaled by its own smallest feasible
    common factor, it is used when its total is below uniform's by more
    than :data:`ABSURD_UNIFORM` (a local optimiser need not end better from
    a start only a little shorter: doc/inner_knots.md, "Where the constants
    come from").
    """
    guess = rest_to_rest_durations(request.points, request.limits)
    try:
        spline = ScaledSpline(request.method, request.points, guess, request.boundary)
        scale = uniform_scale(spline, request.limits)[0]
    except (ValueError, np.linalg.LinAlgError):
        return uniform.durations
    if np.isfinite(scale) and ABSURD_UNIFORM * scale * guess.sum() < uniform.duration:
        return scale * guess
    return uniform.durations
