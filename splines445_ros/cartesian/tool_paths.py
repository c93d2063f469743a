"""
Straight tool paths within a tolerance: Taylor's bounded-deviation refinement on splines.

The paper ends its example noting that the 445 tool path leaves the straight
lines between the tool waypoints, and that waypoints should be added "by
using Taylor's bounded deviations method" (R. H. Taylor, IBM J. Res. Dev. 23,
1979).  :func:`plan_tool_path` does that for every method and timing of
:func:`splines445_ros.planning.plan`; pure Python, no ROS.

Kinematics protocol
-------------------
Any object with ``forward(joints)`` and ``inverse(poses)``, planar (P = 3:
x, y, yaw) or spatial (P = 7: x, y, z, qw, qx, qy, qz):
:class:`.tool_kinematics.ToolKinematics` says what each must do, and which
optional parts the tool paths use when a kinematics has them.
:class:`splines445_ros.robot.kinematics.PlanarArm` implements the planar
protocol (its ``inverse`` takes the paper's elbow branch, ``elbow=1``, by
default); :class:`splines445_ros.robot.inverse_kinematics.ModelKinematics` the
spatial one for any robot model.  The planar case is the special case of the
spatial one with z = 0 and rotations about z; it keeps its own arithmetic,
so its results are exactly those of the planar-only code.

Algorithm
---------
1. Inverse kinematics of the tool waypoints (consecutive duplicates merged,
   except with fixed timing), plan the joint trajectory with ``plan()``.
2. On every trajectory segment (between two consecutive knots), find the
   largest distance of the tool position from the straight segment between
   the two *requested* tool waypoints it belongs to, and the largest
   orientation deviation: ``|wrap(yaw(t) - (yaw_a + s (yaw_b - yaw_a)))|``,
   where ``s`` in [0, 1] is the projection of the tool position on that
   segment (for a pure rotation, the share of its rotation the tool has
   turned about its axis: ``path_deviation.PathMeasure``), so
   position and orientation are interpolated together, as in Taylor's method.
   Requested yaws are unwrapped, so the interpolation takes the short way.
   Spatial poses: the orientation deviation is the rotation angle between
   the tool's orientation and the slerp of the two requested orientations
   at the same ``s`` (requested quaternions are made sign-continuous, so the
   slerp takes the short way).
3. On every segment that exceeds a tolerance, insert the inverse kinematics of
   the Cartesian midpoint of its two knots (position and yaw, or position and
   the slerp midpoint of the two quaternions; on the straight line, since
   both knots are) as a new knot, re-plan the whole trajectory
   (every knot moves the whole spline, so nothing checked before is kept)
   and repeat from 2 until every segment is within the tolerances.
4. Stop with a ValueError naming the segment, the tool waypoints it lies
   between and the deviation reached when ``max_inserted`` knots would be
   exceeded, and naming the point when an inserted point is out of reach.

Timing and inserted knots
-------------------------
With "uniform" and "optimal" timing the inserted knots simply get their own
segment durations from the planner (their chord lengths, then the limits).
With "fixed" timing the caller's durations are per requested edge and are
kept: every tool waypoint is reached at its requested time, and an inserted
knot splits its segment's duration in proportion to the joint-space chord
lengths of the two halves (eq. 11 of the paper, within the segment).
"""

from dataclasses import dataclass, replace
import math
import numbers

import numpy as np

from .path_deviation import Deviation, PathMeasure, tolerance_excess
from .refinement_time import RefinementClock, RefinementTimeout, SKIPPED
from .tool_kinematics import declared_joint_count, refused_pose
from .tool_lines import edge_geometry, LineOutOfTolerance, LineUnreachable, plan_tool_lines
from ..planning import merge_duplicates
from ..planning.constraints import GravityOverload
from ..planning.plan_options import DEFAULT_WAYPOINT_TOLERANCE, PlanOptions, smoothing_windows
from ..planning.planner import (joint_label, plan_with_options, position_limit_slack,
                                within_position_limits)
from ..planning.validation import waypoint_array
from ..robot import rotations as rot

DEFAULT_MAX_INSERTED = 200
# Optimal timing's warm start after an insertion: the least share of its
# segment's time a half gets (its joint chord can be 0 at the IK's
# resolution, and a duration of 0 is refused).
MIN_SPLIT_SHARE = 1e-3
# The largest tool coordinate [m, and rad for a planar yaw] taken: far beyond
# any arm's reach, and far below where a line's length or its samples overflow.
MAX_COORDINATE = 1e6
# 'tool lines': a tool waypoint within this share of both tolerances of the one
# before is merged into it (_close_waypoints).
MERGE_SHARE = 0.1
# ... and on a side whose tolerance is not checked, within this [m, rad]: plan()'s
# default waypoint tolerance (1e-3, "below anything taught as two distinct
# points"), read as metres and radians.  Round-off only left a recorded path's
# 1-microradian jitter a line of its own, a stop (+35 % on a UR5 request,
# helper-46); merging within 0.1 of the checked side alone skipped poses 15 cm
# or 60 degrees away (helper-42).
UNCHECKED_MERGE = DEFAULT_WAYPOINT_TOLERANCE
# Tool waypoints that together move the tool less than this [m, and rad] coincide:
# no motion to plan (a nanometre, far below any deviation tolerance).
COINCIDENT = 1e-9


@dataclass(frozen=True)
class ToolPath:
    """
    A joint trajectory whose tool follows straight lines within tolerances.

    Attributes
    ----------
    trajectory : the planned :class:`~splines445_ros.planning.Trajectory`.
    poses : (M, P) tool poses of its knots: (x, y, yaw), yaw unwrapped, or
        (x, y, z, qw, qx, qy, qz), quaternions sign-continuous.
    joints : (M, n) joint positions of its knots (the waypoints planned).
    waypoint_knots : (N,) the knot of every requested tool waypoint (a merged
        duplicate maps to the knot it equals; with 'tool lines', a waypoint
        within a tenth of the tolerances of the one before maps to that one's,
        or to the goal's where the goal replaced that one).
    segment_edges : (M-1,) the requested edge (tool waypoints e, e+1 of the
        request) every trajectory segment lies on.
    inserted : number of knots inserted.
    deviation, initial_deviation : :class:`Deviation` of the result and of the
        unrefined plan; ``initial_duration`` the unrefined plan's duration.
    iterations : number of plans made.
    construction : ``'tool lines'`` (timed along the inverse kinematics of
        the lines, :mod:`tool_lines`) or ``'refined'`` (knots inserted into
        a plan through the waypoints).
    tool_speed, tool_angular_speed : the largest tool speeds [m/s], [rad/s]
        (checked every millisecond; ``'tool lines'`` only, else None).
    speed_share : the share of the path's length the tool runs at >= 99 %
        of ``max_tool_speed`` (None without one).
    tool_acceleration : the largest linear acceleration [m/s^2] of the
        tool frame's origin (checked every millisecond; with
        ``max_tool_acceleration`` only, else None).

    """

    trajectory: object
    poses: np.ndarray
    joints: np.ndarray
    waypoint_knots: np.ndarray
    segment_edges: np.ndarray
    inserted: int
    deviation: Deviation
    initial_deviation: Deviation
    initial_duration: float
    iterations: int
    construction: str = 'refined'
    tool_speed: float = None
    tool_angular_speed: float = None
    speed_share: float = None
    tool_acceleration: float = None

    @property
    def max_deviation(self):
        """Return the largest position deviation [m] of the result."""
        return self.deviation.max_position

    @property
    def max_orientation_deviation(self):
        """Return the largest orientation deviation [rad] of the result."""
        return self.deviation.max_orientation


def _tolerance(name, value):
    """Return a tolerance: None or 0 -> inf (unchecked); ValueError if negative or NaN."""
    if value is None:
        return math.inf
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f'{name} must be a number, got {value!r}')
    value = float(value)
    if math.isnan(value) or value < 0.0:
        raise ValueError(f'{name} = {value}: must be >= 0 (0 = not checked)')
    return value if value > 0.0 else math.inf


PLANAR_COMPONENTS = ('x', 'y', 'yaw')
SPATIAL_COMPONENTS = ('x', 'y', 'z', 'qw', 'qx', 'qy', 'qz')


def tool_pose_array(poses):
    """
    Return tool poses as a finite (N, 3) or (N, 7) array, N >= 2.

    Coordinates (and a planar yaw) of at most :data:`MAX_COORDINATE` in magnitude.

    Planar (x, y, yaw): yaw unwrapped.  Spatial (x, y, z, qw, qx, qy, qz):
    quaternions normalised and sign-continuous (neighbours' dot products >= 0).
    """
    try:
        arr = np.array(poses, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'tool poses must be numeric: {exc}') from None
    if arr.ndim != 2 or arr.shape[1] not in (3, 7):
        raise ValueError(f'tool poses must have shape (N, 3) = (x, y, yaw) or (N, 7) = '
                         f'(x, y, z, qw, qx, qy, qz), got {arr.shape}')
    if arr.shape[0] < 2:
        raise ValueError(f'need at least 2 tool waypoints, got {arr.shape[0]}')
    components = PLANAR_COMPONENTS if arr.shape[1] == 3 else SPATIAL_COMPONENTS
    bad = np.argwhere(~np.isfinite(arr))
    if bad.size:
        k, c = bad[0]
        raise ValueError(f'tool waypoint {k} has {components[c]} = {arr[k, c]}: '
                         'values must be finite')
    far = np.argwhere(np.abs(arr[:, :3]) > MAX_COORDINATE)
    if far.size:
        k, c = far[0]
        raise ValueError(f'tool waypoint {k} has {components[c]} = {arr[k, c]:.6g}: beyond '
                         f'{MAX_COORDINATE:.0e} in magnitude (no arm reaches it, and the '
                         'lines between waypoints would overflow)')
    if arr.shape[1] == 3:
        arr[:, 2] = np.unwrap(arr[:, 2])
        return arr
    quat = arr[:, 3:]
    scale = np.max(np.abs(quat), axis=1)
    if np.any(scale < 1e-9):
        raise ValueError(f'tool waypoint {int(np.argmin(scale))} has a zero quaternion')
    quat = quat / scale[:, None]  # no overflow for huge components
    arr[:, 3:] = rot.continuous(quat / np.linalg.norm(quat, axis=1, keepdims=True))
    return arr


def _format_pose(pose):
    if len(pose) == 3:
        return f'(x, y, yaw) = ({pose[0]:.6g}, {pose[1]:.6g}, {pose[2]:.6g})'
    return ('(x, y, z) = (' + ', '.join(f'{v:.6g}' for v in pose[:3]) + '), (qw, qx, qy, qz) = ('
            + ', '.join(f'{v:.6g}' for v in pose[3:]) + ')')


def _midpoints(a, b):
    """Return the Cartesian midpoints of knot poses a and b (K, P): on their straight line."""
    mid = 0.5 * (a + b)
    if a.shape[1] == 7:
        # The normalised sum of two quaternions in one hemisphere is their slerp midpoint.
        mid[:, 3:] /= np.linalg.norm(mid[:, 3:], axis=1, keepdims=True)
    return mid


def _inverse(kinematics, poses, describe):
    """IK of ``poses``; on failure name the first unreachable one with ``describe(k)``."""
    try:
        with np.errstate(over='ignore', invalid='ignore'):  # huge poses are unreachable
            joints = np.asarray(kinematics.inverse(poses), dtype=float)
    except ValueError as first:
        k, reason = refused_pose(first)
        if k is not None:
            # The kinematics knows which pose (and why: it walks from pose to pose).
            reason = str(first) if reason is None else reason
            raise ValueError(f'{describe(k)} at {_format_pose(poses[k])} {reason}') from None
        for k, pose in enumerate(poses):
            try:
                with np.errstate(over='ignore', invalid='ignore'):
                    kinematics.inverse(pose[None, :])
            except ValueError as exc:
                raise ValueError(f'{describe(k)} at {_format_pose(pose)} is '
                                 f'unreachable ({exc})') from None
        raise
    if joints.ndim != 2 or joints.shape[0] != len(poses) or not np.all(np.isfinite(joints)):
        raise ValueError(f'inverse kinematics returned {joints.shape} non-finite or '
                         f'mis-shaped joints for {len(poses)} poses')
    return joints


def _joints_within(joints, options, describe):
    """Raise ValueError naming the first pose whose ``joints`` (K, n) leave the position limits."""
    low, high = options.min_position, options.max_position
    if low is None:
        return
    slack = position_limit_slack(low, high)
    bad = (joints < low - slack[0]) | (joints > high + slack[1])
    if not np.any(bad):
        return
    k, j = (int(i) for i in np.argwhere(bad)[0])
    joint = joint_label(j, options.joint_names)
    side, limit = (('below min_position', low[j]) if joints[k, j] < low[j]
                   else ('above max_position', high[j]))
    raise ValueError(f'{describe(k)} needs {joint} at {joints[k, j]:.6g}, {side}[{j}] = '
                     f'{limit:g}')


def plan_tool_path(poses, kinematics, max_deviation=None, max_orientation_deviation=None,
                   max_inserted=DEFAULT_MAX_INSERTED, method='445', timing='uniform',
                   durations=None, max_tool_speed=None, max_tool_angular_speed=None,
                   options=None, max_tool_acceleration=None, max_refinement_time=None,
                   **plan_kwargs):
    """
    Plan a joint trajectory whose tool follows the straight lines between ``poses``.

    Parameters
    ----------
    poses : array_like (N, 3) or (N, 7)
        Tool waypoints (x, y, yaw), in order, yaw in radians (unwrapped here);
        or (x, y, z, qw, qx, qy, qz) (quaternions normalised and made
        sign-continuous here).
    kinematics : object
        With ``forward`` and ``inverse`` (see the module docstring).
    max_deviation : float
        Largest distance [m] of the tool position from the straight segment
        between consecutive tool waypoints; None or 0: not checked.
    max_orientation_deviation : float
        Largest deviation [rad] of the tool yaw from the linear interpolation
        (spatial: of the tool orientation from the slerp) between consecutive
        tool waypoints; None or 0: not checked.
    max_inserted : int
        Most knots that may be inserted; reaching it is a ValueError.
    method, timing, durations : as for :func:`~splines445_ros.planning.plan`;
        ``durations`` (N-1,) are per requested edge ("fixed" only, kept: see
        the module docstring).  With "optimal", every re-plan after an
        insertion starts from the previous optimal durations (split).
    max_tool_speed, max_tool_angular_speed : float
        Largest linear speed [m/s] of the tool frame's origin and angular
        speed [rad/s] of the tool; None or 0: no limit.  They need method
        555 with optimal timing, rest to rest (:mod:`tool_lines`).
    max_tool_acceleration : float
        Largest linear acceleration [m/s^2] of the tool frame's origin;
        None or 0: no limit.  Needs what the tool speeds need
        (:mod:`tool_acceleration`).
    plan_kwargs : limits and boundary values passed on to ``plan()``;
        ``inner_knots``, ``vibration_frequency`` and ``smoothing`` shape the
        555 optimal plan as there (the tool lines are never averaged: only
        a refined path's inner-knot plan follows ``smoothing``).
    options : :class:`~splines445_ros.planning.plan_options.PlanOptions`, or None
        Instead of ``method``, ``timing`` and ``plan_kwargs``: the options
        of a caller that validated them once already (the planner node,
        ``PlanOptions.from_validated``), for the joints of ``kinematics``;
        used as they are.
    max_refinement_time : float
        Most seconds the refinement may run (:mod:`refinement_time`: read
        between its rounds, so one round can run over); None or 0: no
        limit.  Past it, a :class:`refinement_time.RefinementTimeout` (a
        ValueError) says how far the refinement got.

    Method 555 with optimal timing (inner knots, rest to rest) is timed
    along the inverse kinematics of the lines themselves
    (:func:`tool_lines.plan_tool_lines`, the ``'tool lines'``
    construction); when that fails without a tool speed limit, and for
    every other method and timing, knots are inserted into a plan through
    the waypoints (the module docstring).

    Returns a :class:`ToolPath`.  Raises ValueError for bad input, an
    unreachable pose (tool waypoint or inserted point), anything ``plan()``
    rejects, or when ``max_inserted`` knots do not bring the deviation within
    the tolerances (naming the segment and the deviation reached).

    """
    clock = RefinementClock(max_refinement_time)
    request = tool_pose_array(poses)
    length, angle, _ = edge_geometry(request)
    if not (np.sum(length) > COINCIDENT or np.sum(angle) > COINCIDENT):
        # As plan() refuses joint waypoints that all coincide: the inverse kinematics'
        # round-off made a plan of microseconds, with a misleading warning (helper-66).
        raise ValueError(f'all {len(request)} tool waypoints coincide (within '
                         f'{COINCIDENT:g} m and rad): the tool does not move')
    tol_position = _tolerance('max_deviation', max_deviation)
    tol_orientation = _tolerance('max_orientation_deviation', max_orientation_deviation)
    if (isinstance(max_inserted, bool) or not isinstance(max_inserted, numbers.Real)
            or not math.isfinite(max_inserted) or int(max_inserted) != max_inserted
            or max_inserted < 0):
        raise ValueError(f'max_inserted = {max_inserted}: must be a non-negative integer')
    max_inserted = int(max_inserted)    # (2.0 was accepted, then refused by range(): helper-69)
    speeds = (_speed_limit('max_tool_speed', max_tool_speed),
              _speed_limit('max_tool_angular_speed', max_tool_angular_speed),
              _speed_limit('max_tool_acceleration', max_tool_acceleration))
    # Validated once; the plans below take copies with other knots or tolerances.
    if options is None:
        options = PlanOptions.from_arguments(_joint_count(kinematics, request), method=method,
                                             timing=timing, **plan_kwargs)
    elif plan_kwargs or (method, timing) != ('445', 'uniform'):
        raise TypeError('plan_tool_path takes options, or method, timing and the plan() '
                        'arguments, not both')
    timing = options.timing
    # 555 optimal's inner knots are tried on the refined path at the end (see
    # _with_inner_knots); the refinement itself keeps knots at the waypoints, and
    # no waypoint tolerance: inserted knots are deliberate, however close.
    # (The refinement's own plans keep the default profile: its deviation test
    # sees them; speed_profile "time_optimal" times the tool lines and the
    # refined path's inner-knot plan, each checked against the tolerances.)
    # Only the path it ends with is checked against the position limits: an
    # inserted waypoint can bring a plan back within them.
    refining = replace(options, waypoint_tolerance=0.0, inner_knots=0, inner_knots_auto=False,
                       speed_profile='smoothed', min_position=None, max_position=None)
    lines = (options.method == '555' and options.timing == 'optimal'
             and options.inner_knots > 0 and options.rest)
    if any(speeds) and not lines:
        raise ValueError('max_tool_speed, max_tool_angular_speed and max_tool_acceleration '
                         'need method "555" with timing "optimal" (inner_knots > 0), rest to '
                         'rest')
    n_req = len(request)
    if lines:
        # The tool lines walk the inverse kinematics along the lines
        # themselves, through every waypoint: the waypoints' own walk would be
        # a second one (doc/tool_paths.md, "Where the constants come from").
        # Duplicates are merged by pose, which gives them the same joints.
        kept_index, waypoint_knots = _kept(n_req, merge_duplicates(request)[1])
        edge_poses = request[kept_index]
        close, passed_at = _close_waypoints(edge_poses, tol_position, tol_orientation)
        try:
            found = _tool_lines(edge_poses[close], passed_at[waypoint_knots],
                                kinematics, (tol_position, tol_orientation), speeds,
                                max_inserted, options, kept_index[close], clock)
        except LineUnreachable as exc:
            # A tool waypoint out of reach is named as such (as the refinement does).
            _inverse(kinematics, request, lambda k: f'tool waypoint {k}')
            a, b = kept_index[close][exc.edge], kept_index[close][exc.edge + 1]
            raise ValueError(f'the straight line from tool waypoint {a} to {b} leaves the '
                             f'reach of the arm: its point at {_format_pose(exc.pose)} '
                             f'{exc.reason}') from None
        if found is not None:
            return found
    joints = _inverse(kinematics, request, lambda k: f'tool waypoint {k}')
    # Checked here: the refinement checks only the plan it ends with, and would
    # insert waypoints in vain around one the plan must pass outside the limits.
    _joints_within(joints, options, lambda k: f'tool waypoint {k}')
    if timing == 'fixed':
        if durations is None:
            raise ValueError('timing "fixed" needs durations, one per pair of tool waypoints')
        seg_durations = np.array(durations, dtype=float)
        if seg_durations.shape != (n_req - 1,):
            raise ValueError(f'durations must have shape ({n_req - 1},), '
                             f'got {seg_durations.shape}')
        kept_index, waypoint_knots = _kept(n_req, ())
    else:
        seg_durations = None
        # As the tool lines do: a waypoint the tool passes within a tenth of the
        # tolerances of the one before is not one of its own (a segment of
        # nanometres would set the whole uniform plan's time); then exact twins.
        close, passed_at = _close_waypoints(request, tol_position, tol_orientation)
        kept_close, knot_of_close = _kept(int(close.sum()),
                                          merge_duplicates(joints[close])[1])
        kept_index = np.flatnonzero(close)[kept_close]
        waypoint_knots = knot_of_close[passed_at]
    edge_poses = request[kept_index]
    knots = edge_poses.copy()
    knot_joints = joints[kept_index]
    segment_edges = np.arange(len(knots) - 1)
    inserted = 0
    initial = None
    for iteration in range(1, max_inserted + 2):
        try:
            traj = plan_with_options(waypoint_array(knot_joints), refining, seg_durations)
        except ValueError as exc:
            if not inserted:
                raise
            raise ValueError(f'planning the refined path ({len(knots)} waypoints, {inserted} '
                             f'inserted) failed: {exc}') from None
        if traj.dropped_waypoints:
            raise ValueError(f'the refinement made segments too short to plan (knots '
                             f'{list(traj.dropped_waypoints)} coincide with their predecessors '
                             f'after {inserted} inserted waypoints)')
        deviation = PathMeasure(traj, kinematics, edge_poses, segment_edges).deviation(
            (tol_position, tol_orientation))
        if initial is None:
            initial = (deviation, traj.duration)
        excess = tolerance_excess(deviation, (tol_position, tol_orientation))
        bad = np.flatnonzero(excess > 1.0)
        if bad.size and iteration > 1:
            clock.check(lambda: f'{inserted} waypoints inserted, and the tool still ' + _still(
                deviation, excess, segment_edges, kept_index, tol_position, tol_orientation))
        if bad.size == 0:
            if options.inner_knots and clock.expired():
                traj.optimizer['refinement_time'] = SKIPPED
            elif options.inner_knots:
                traj, deviation = _with_inner_knots(
                    traj, deviation, knot_joints, kinematics, edge_poses, segment_edges,
                    (tol_position, tol_orientation),
                    replace(options, waypoint_tolerance=0.0, inner_knots_auto=False))
            within_position_limits(traj, options.min_position, options.max_position,
                                   options.joint_names)
            return ToolPath(traj, knots, knot_joints, _knot_of_waypoint(
                waypoint_knots, segment_edges, len(knots)), segment_edges, inserted,
                deviation, initial[0], initial[1], iteration)
        budget = max_inserted - inserted
        if budget <= 0:
            raise ValueError(_not_within(deviation, excess, segment_edges, kept_index,
                                         tol_position, tol_orientation, max_inserted,
                                         options.method))
        if bad.size > budget:
            bad = np.sort(bad[np.argsort(excess[bad])[::-1][:budget]])
        midpoints = _midpoints(knots[bad], knots[bad + 1])
        new_knots = np.insert(knots, bad + 1, midpoints, axis=0)
        new_joints = _inverse(kinematics, new_knots, _describe_inserted(
            bad, segment_edges, kept_index, new_knots))
        if timing == 'optimal':
            # Warm start: the optimum before the insertion, its split segments
            # shared by their chords (3x faster on the triangle, and shorter).
            # (Per segment: a 555 optimal plan's pieces are finer.)
            seg_durations = np.diff(traj.waypoint_times)
        if seg_durations is not None:
            seg_durations = _split_durations(seg_durations, bad, new_joints)
        segment_edges = np.insert(segment_edges, bad + 1, segment_edges[bad])
        knots, knot_joints = new_knots, new_joints
        inserted += bad.size
    raise AssertionError('unreachable: every iteration inserts at least one knot')


def _close_waypoints(poses, tol_position, tol_orientation):
    """
    Return which tool waypoints (N,) are kept, and the kept one each is passed at.

    A waypoint within :data:`MERGE_SHARE` of both tolerances of the last one
    kept is passed within that share of them without being a waypoint of its
    own: a line of a few micrometres between two waypoints would be a stop
    that the whole rest-to-rest spline slows down for.  A tolerance not
    checked (inf) merges within :data:`UNCHECKED_MERGE` only on its side: a
    waypoint that moves the tool, or turns it, is kept however close it is
    in the other (with neither checked, within that on both, as plan()
    merges joint waypoints within its ``waypoint_tolerance``).  The 'tool
    lines' and the refinement (but for "fixed" timing, whose durations are
    per requested edge) both merge so.  The first and the last waypoint are kept (the goal
    replaces a kept one close to it, and is then where the waypoints merged
    into that one are passed: within twice the share).
    Returns (keep (N,) bool, owner (N,) the index among the kept waypoints
    of the one each waypoint is passed at).
    """
    checked = [math.isfinite(tol) for tol in (tol_position, tol_orientation)]
    owner = np.arange(len(poses))
    limits = [MERGE_SHARE * tol if ok else UNCHECKED_MERGE
              for tol, ok in zip((tol_position, tol_orientation), checked)]
    keep = [0]
    for i in range(1, len(poses)):
        a, b = poses[keep[-1]], poses[i]
        d, theta, _ = edge_geometry(np.stack([a, b]))
        if not (d[0] < limits[0] and theta[0] < limits[1]):
            keep.append(i)
        elif i == len(poses) - 1 and len(keep) > 1:
            owner[owner == keep[-1]] = i
            keep[-1] = i
        owner[i] = keep[-1]
    if len(keep) < 2:
        keep.append(len(poses) - 1)
        owner[-1] = len(poses) - 1
    mask = np.zeros(len(poses), dtype=bool)
    mask[keep] = True
    return mask, np.searchsorted(keep, owner)


def _kept(count, dropped):
    """
    Return (the kept tool waypoints' indices, each waypoint's (N,) index among them).

    Of ``count`` waypoints all but ``dropped`` are kept; a dropped one's
    index is that of the kept one before it.
    """
    keep = np.ones(count, dtype=bool)
    keep[list(dropped)] = False
    return np.flatnonzero(keep), np.cumsum(keep) - 1


def _joint_count(kinematics, poses):
    """Return the joints of ``kinematics``: its ``n_joints``, else those of the first pose's IK."""
    count = declared_joint_count(kinematics)
    if count is not None:
        return count
    return _inverse(kinematics, poses[:1], lambda k: 'tool waypoint 0').shape[1]


def _speed_limit(name, value):
    """Return a tool speed or acceleration limit: None, 0 -> 0 (no limit); finite, >= 0."""
    if value is None:
        return 0.0
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f'{name} must be a number, got {type(value).__name__}')
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f'{name} = {value:.6g}: must be a finite number >= 0 (0 = no limit)')
    return value


def _tool_lines(edge_poses, waypoint_knots, kinematics, tolerances, speeds, max_inserted,
                options, names, clock=None):
    """
    Return the :class:`ToolPath` of :func:`tool_lines.plan_tool_lines`, or None to refine instead.

    None when that construction fails without a tool speed limit (the
    refinement then names the problem); with one its error is raised, a
    line out of reach as the :class:`tool_lines.LineUnreachable`.  A tool
    waypoint whose joints lie beyond the position limits is named
    (``names``: each edge pose's index among the request's waypoints).
    Past the ``clock``'s time its :class:`refinement_time.RefinementTimeout`
    is raised: the refinement would only start the clock's work again.
    """
    segment_edges = np.arange(len(edge_poses) - 1)

    def measure(traj, edges):
        return PathMeasure(traj, kinematics, edge_poses, edges).deviation(tolerances)

    vibration = options.vibration_frequency
    windows = smoothing_windows(vibration) if vibration else ()
    try:
        found = plan_tool_lines(edge_poses, kinematics, options.limits, measure, tolerances,
                                *speeds, windows=windows, max_inserted=max_inserted,
                                torque=options.torque,
                                time_optimal=options.speed_profile == 'time_optimal',
                                vibration_frequency=vibration,
                                position_limits=(options.min_position, options.max_position),
                                clock=clock)
    except RefinementTimeout:
        raise
    except LineUnreachable:
        if not any(speeds):
            return None
        raise
    except GravityOverload:
        raise
    except LineOutOfTolerance as exc:
        if any(speeds):
            raise ValueError(f'the line from tool waypoint {names[exc.edge]} to '
                             f'{names[exc.edge + 1]}: {exc.reason}') from None
        return None
    except ValueError:
        if any(speeds):
            raise
        return None
    _joints_within(found.joints, options, lambda k: f'tool waypoint {names[k]}')
    within_position_limits(found.trajectory, options.min_position, options.max_position,
                           options.joint_names)
    return ToolPath(found.trajectory, edge_poses, found.joints, waypoint_knots, segment_edges,
                    found.inserted, found.deviation, found.initial_deviation,
                    found.initial_duration, found.rounds, 'tool lines', found.tool_speed,
                    found.tool_angular_speed, found.speed_share if speeds[0] else None,
                    found.tool_acceleration)


def _with_inner_knots(traj, deviation, joints, kinematics, edge_poses, segment_edges,
                      tolerances, options):
    """
    Return (trajectory, deviation): the refined path planned with inner knots when better.

    The refinement inserts waypoints with knots at the waypoints only: its
    optimum shapes each segment through its durations, which the deviation
    test sees.  With inner knots (555 optimal, :mod:`planning.path_following.inner_knots`)
    the segments follow another path between the same waypoints, usually
    faster; it is kept when it is shorter and still within the tolerances.
    """
    try:
        refined = plan_with_options(waypoint_array(joints), options)
    except ValueError:
        return traj, deviation
    if not refined.duration < traj.duration:
        return traj, deviation
    measured = PathMeasure(refined, kinematics, edge_poses, segment_edges).deviation(tolerances)
    if np.any(tolerance_excess(measured, tolerances) > 1.0):
        return traj, deviation
    return refined, measured


def _knot_of_waypoint(waypoint_knots, segment_edges, n_knots):
    """Map every requested waypoint to its knot after insertions."""
    edge_start = np.concatenate([[0], np.flatnonzero(np.diff(segment_edges)) + 1,
                                 [n_knots - 1]])
    return edge_start[waypoint_knots]


def _describe_inserted(bad, segment_edges, kept_index, new_knots):
    """Return describe(k) for inserted knot poses (indices into ``new_knots``)."""
    inserted_at = {int(b + 1 + i): int(segment_edges[b]) for i, b in enumerate(bad)}

    def describe(k):
        if k not in inserted_at:
            return f'knot {k}'
        e = inserted_at[k]
        return (f'the straight line from tool waypoint {kept_index[e]} to '
                f'{kept_index[e + 1]} leaves the reach of the arm: its point {k}')
    return describe


def _split_durations(durations, bad, joints):
    """
    Split the durations of segments ``bad`` by the joint chords of their halves.

    Each half gets at least :data:`MIN_SPLIT_SHARE` of its segment's time.
    """
    out = []
    bad_set = {int(b) for b in bad}
    k = 0  # knot index in the new list
    for s, duration in enumerate(durations):
        if s in bad_set:
            c1 = np.linalg.norm(joints[k + 1] - joints[k])
            c2 = np.linalg.norm(joints[k + 2] - joints[k + 1])
            share = 0.5 if c1 + c2 <= 0.0 else c1 / (c1 + c2)
            # A half whose joints do not move (an inserted knot on the one
            # before, to the IK's resolution) still gets time: a start, not 0.
            share = min(max(share, MIN_SPLIT_SHARE), 1.0 - MIN_SPLIT_SHARE)
            out += [duration * share, duration * (1.0 - share)]
            k += 2
        else:
            out.append(duration)
            k += 1
    return np.array(out)


def _not_within(deviation, excess, segment_edges, kept_index, tol_position,
                tol_orientation, max_inserted, method):
    what = _still(deviation, excess, segment_edges, kept_index, tol_position, tol_orientation)
    hint = ''
    if str(method) == '445':
        hint = ('; 445 carries the disturbance of every inserted knot to the end, so '
                'it needs many more waypoints than 555 or optimal timing (paper triangle at '
                '1 mm: 785 with uniform timing, under 70 otherwise)')
    return (f'tool path refinement stopped after inserting {max_inserted} waypoints '
            f'(max_inserted): the tool still {what}{hint}')


def _still(deviation, excess, segment_edges, kept_index, tol_position, tol_orientation):
    """Where and by how much the tool is furthest out of its tolerances ("deviates ...")."""
    s = int(np.argmax(excess))
    e = int(segment_edges[s])
    where = (f'between tool waypoints {kept_index[e]} and {kept_index[e + 1]} '
             f'(trajectory segment {s}')
    if deviation.position[s] > tol_position:
        what = (f'deviates {deviation.position[s]:.4g} m from the straight line (tolerance '
                f'{tol_position:g} m) {where}, t = {deviation.position_time[s]:.4g} s)')
    else:
        what = (f'deviates {deviation.orientation[s]:.4g} rad from the interpolated '
                f'orientation (tolerance {tol_orientation:g} rad) {where}, '
                f't = {deviation.orientation_time[s]:.4g} s)')
    return what
