"""
A knots-only plan whose joints leave and reach their rest ends the way their chords go.

A 555 spline's jerk at a rest end (velocity and acceleration 0 there, the
boundary conditions of eq. 7) is not prescribed: it follows from the whole
spline.  Where its sign is against the joint's first (last) chord, the
joint starts (stops) the wrong way, ``q0 + j t**3 / 6``, past a start on a
position limit: 1e-7-1e-3 rad for the inner-knot plan, up to 0.13 rad for a
knots-only optimum, whose whole first segment can swing back
(``benchmarks/bench_position_limits.py``).  An
inner-knot plan moves its knot next to the end (step 4 of
:mod:`inner_knots`); a knots-only plan has none to move.  Here it gets one:
a knot in its first and in its last segment, placed on the spline itself
(the C4 quintic spline through the same positions with those two more
knots is the same spline), then moved per joint, as step 4 does, to set
each wrong end jerk to 0.  The spline is linear in its knot positions, so
one solve with unit positions gives the moves.  The result is stretched
in time, uniformly, until it holds the v/a/j limits again (never sped
up: a plan slowed down for the torque stays as slow).
"""

import numpy as np

from .inner_knots import end_jerks, moved_trajectory, unit_end_jerks
from ..spline.continuity_system import spline_coefficients
from ..spline.trajectory import representable_durations

# Where the new knot goes, as a share of its end segment from the rest end.
END_KNOT_SHARE = 0.5
# The end jerks tried, as shares of each joint's peak jerk: 0 first (only the
# joints against their chord are moved), then pushed further along it.
END_JERK_FLOORS = (0.0, 1.0 / 16.0, 0.25, 1.0)


def along_chords(traj, accept):
    """
    Return the knots-only rest-to-rest 555 ``traj`` turned along its chords at its rest ends.

    A knot goes into its first and last segment, at :data:`END_KNOT_SHARE`
    of each from its rest end, and is moved per joint so that the joint's
    jerk at that end has its chord's direction: 0 where it was against it,
    then, while the spline is not accepted, at least each share of
    :data:`END_JERK_FLOORS` of the joint's peak jerk in ``traj`` (a jerk of 0
    can still leave the end the wrong way through the snap).  Each move is
    one linear solve (the spline is linear in its knot positions).  Returns
    the first spline that ``accept`` (a function of a Trajectory) accepts,
    stretched until it holds the v/a/j limits of ``traj`` (never sped up,
    :func:`inner_knots.kept_trajectory`), or None.  The result passes every
    waypoint at its (scaled) time; its ``optimizer`` is a copy of ``traj``'s.
    """
    points = traj.waypoints
    sign = np.sign(np.stack([points[1] - points[0], points[-1] - points[-2]]))   # (2, n)
    if not np.any(sign):
        return None
    widths, waypoint_knots, inserted = _with_end_knots(traj)
    if widths is None:
        return None
    knots = np.array([1, widths.size - 1])
    positions = np.empty((widths.size + 1, traj.n_joints))
    positions[waypoint_knots] = points
    positions[knots] = traj.evaluate(inserted)
    rest = (np.zeros(traj.n_joints),) * 4
    coeffs = spline_coefficients('555', positions, widths, rest)
    units, sensitivity = unit_end_jerks(positions.shape[0], knots, widths)   # (2 ends, 2)
    jerks = end_jerks(coeffs, widths[-1])                           # (2 ends, n)
    scale = traj.peaks()['jerk']
    for floor in END_JERK_FLOORS:
        along = jerks * sign
        if floor == 0.0:
            target = np.where(along < 0.0, 0.0, jerks)      # only those against the chord
        else:
            # Along the chord: at least floor * scale in its direction (where it has one).
            target = np.where(sign != 0.0, sign * np.maximum(along, floor * scale), jerks)
        try:
            moves = np.linalg.solve(sensitivity, target - jerks)
        except np.linalg.LinAlgError:
            return None
        found = moved_trajectory(traj, widths, positions, waypoint_knots, coeffs, units, knots,
                                 moves)
        if found is not None and accept(found):
            return found
    return None


def _with_end_knots(traj):
    """
    Return the pieces' widths, the waypoints' knot indices and the new knots' times.

    The pieces of ``traj``'s segments with a knot at :data:`END_KNOT_SHARE`
    of the first and the last from its rest end (of one segment, at its
    thirds); widths None when a piece is below the resolution of the time
    axis.
    """
    durations = traj.durations
    share = END_KNOT_SHARE
    if durations.size == 1:
        # Both knots in the one segment, at thirds (its quintic, eq. 7 at
        # rest, never starts the wrong way; a caller may still ask).
        cuts = np.array([1.0, 2.0]) / 3.0 * durations[0]
        pieces = np.array([cuts[0], cuts[1] - cuts[0], durations[0] - cuts[1]])
        waypoint_knots = np.array([0, 3])
        inserted = cuts
    else:
        pieces = np.concatenate([[share * durations[0], (1.0 - share) * durations[0]],
                                 durations[1:-1],
                                 [(1.0 - share) * durations[-1], share * durations[-1]]])
        last = durations.size + 1
        waypoint_knots = np.concatenate([[0], np.arange(2, last), [last + 1]])
        inserted = np.array([share * durations[0], traj.duration - share * durations[-1]])
    widths = representable_durations(pieces)
    if not np.all(widths > 0.0):
        return None, None, None
    return widths, waypoint_knots, inserted
