"""``plan()``: the one entry point of the planning core."""

import numpy as np

from .continuity_system import spline_coefficients
from .inner_knots import inner_knot_count, with_inner_knots
from .limits import check_boundary_feasible, JointLimits
from .methods import get_method
from .optimal import optimal_durations
from .timing import chord_durations, rest_to_rest_scale, scaled_spline, ScaledSpline
from .trajectory import Trajectory
from .validation import boundary_vector, duration_array, waypoint_array

TIMINGS = ('uniform', 'fixed', 'optimal')

# Chords shorter than this (relative to the largest |coordinate|, at least 1)
# count as zero: such waypoints are duplicates and are merged for chord timing.
DUPLICATE_RTOL = 1e-12


def merge_duplicates(waypoints):
    """
    Drop every waypoint equal to its predecessor; return (kept, dropped indices).

    A zero chord would give a zero duration (eq. 11), so chord-based timing
    plans through the distinct waypoints only.  The trajectory passes through
    every dropped waypoint anyway, since it equals a kept one.
    """
    tol = DUPLICATE_RTOL * max(1.0, float(np.max(np.abs(waypoints))))
    chord = chord_durations(waypoints)
    keep = np.concatenate([[True], chord > tol])
    dropped = np.flatnonzero(~keep)
    if keep.sum() < 2:
        raise ValueError('all waypoints coincide: need at least 2 distinct waypoints '
                         'for chord-length timing')
    return waypoints[keep], tuple(int(i) for i in dropped)


def plan(waypoints, method='445', timing='uniform', durations=None,
         max_velocity=None, max_acceleration=None, max_jerk=None,
         start_velocity=None, start_acceleration=None,
         end_velocity=None, end_acceleration=None, inner_knots=0):
    """
    Plan a trajectory through ``waypoints`` (N, n_joints).

    Consecutive duplicate waypoints are merged for "uniform" and "optimal"
    timing (see :func:`merge_duplicates`, reported in
    ``Trajectory.dropped_waypoints``); "fixed" keeps them, since the caller's
    durations define the timing.  Raises ValueError naming the problem (and
    its index) for bad or infeasible input.  Floating-point overflow on absurd
    input (e.g. waypoints of 1e300) is not warned about: every result is
    checked for finiteness and such input ends in a ValueError.

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
    inner_knots : int, 0 to 8
        Free inner knots per segment for method "555" with timing
        "optimal" (:mod:`inner_knots`): the result is still a C4 quintic
        spline through every waypoint, passed at ``waypoint_times``; its
        ``breakpoints`` include the inner knots.  0 (the default) keeps knots
        at the waypoints only.  Used for rest-to-rest requests; with
        non-zero boundary values the knots-only optimum is returned.

    """
    inner_knots = inner_knot_count(inner_knots, get_method(method).name, timing)
    with np.errstate(over='ignore', invalid='ignore', divide='ignore'):
        traj = _plan(waypoints, method, timing, durations, max_velocity, max_acceleration,
                     max_jerk, start_velocity, start_acceleration, end_velocity,
                     end_acceleration)
        if inner_knots:
            traj = with_inner_knots(traj, inner_knots)
    return traj


def _plan(waypoints, method, timing, durations, max_velocity, max_acceleration, max_jerk,
          start_velocity, start_acceleration, end_velocity, end_acceleration):
    method = get_method(method).name
    if timing not in TIMINGS:
        raise ValueError(f'unknown timing {timing!r}: expected one of {TIMINGS}')
    points = waypoint_array(waypoints)
    n = points.shape[1]
    boundary = tuple(boundary_vector(name, value, n) for name, value in (
        ('start_velocity', start_velocity), ('start_acceleration', start_acceleration),
        ('end_velocity', end_velocity), ('end_acceleration', end_acceleration)))
    limits = None
    if max_velocity is not None or max_acceleration is not None or max_jerk is not None:
        if max_velocity is None or max_acceleration is None:
            raise ValueError('max_velocity and max_acceleration must be given together')
        limits = JointLimits.from_user(n, max_velocity, max_acceleration, max_jerk)
        check_boundary_feasible(limits, *boundary)
    elif timing != 'fixed':
        raise ValueError(f'timing={timing!r} needs max_velocity and max_acceleration')

    if timing == 'fixed':
        seg_durations = duration_array(durations, points.shape[0] - 1)
        coeffs = spline_coefficients(method, points, seg_durations, boundary)
        return Trajectory(method, timing, points, seg_durations, coeffs, boundary, limits)

    if durations is not None and timing != 'optimal':
        raise ValueError(f'durations are only used with timing "fixed" or "optimal", '
                         f'not {timing!r}')
    start = None if durations is None else duration_array(durations, points.shape[0] - 1)
    points, dropped = merge_duplicates(points)
    if start is not None and dropped:
        # A dropped waypoint's segment joins the one before it.
        start = np.diff(np.delete(np.concatenate([[0.0], np.cumsum(start)]), dropped))
    chords = chord_durations(points)
    if not np.all(np.isfinite(chords)):
        raise ValueError('waypoints too large: chord lengths overflow')
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
        return optimal_durations(method, points, start, boundary, limits, dropped)
    uniform = Trajectory(method, 'uniform', points, spline.durations(scale),
                         spline.coefficients(scale), boundary, limits, scale, dropped,
                         ratios=ratios)
    if timing == 'optimal':
        return optimal_durations(method, points,
                                 uniform.durations if start is None else start,
                                 boundary, limits, dropped, uniform)
    return uniform
