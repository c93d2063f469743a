"""
Conversions between ROS messages and the planning core's arrays.

Waypoint requests (``trajectory_msgs/JointTrajectory`` on ``waypoints``):

* ``joint_names`` in any order; they are mapped to the configured order, and an
  unknown, missing or duplicated joint is an error.
* one point per waypoint, each with ``positions`` for every joint.
* ``velocities`` / ``accelerations`` on the *first* and *last* point, when
  present, are the boundary values (default zero); on other points they are
  ignored.
* ``time_from_start`` on every point, strictly increasing, gives the segment
  durations when the planner's ``timing`` is "fixed"; otherwise it is ignored.

Tool waypoint requests (``geometry_msgs/PoseArray`` on ``tool_waypoints``):
one pose per tool waypoint, in the arm's base frame (``header.frame_id`` is
empty or the planar arm's base frame, :data:`planned_path.PLANAR_FRAME`); ``position.x``,
``position.y`` and the yaw of the orientation
(a rotation about z; ``position.z`` must be finite and is ignored).
"""

from collections import Counter
import math

from builtin_interfaces.msg import Duration
from diagnostic_msgs.msg import KeyValue
import numpy as np
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .planned_path import PLANAR_FRAME
from ..robot.user_text import show, show_names
from ..service.interface_requests import check_request_size
from ..service.request_planning import DEFAULT_MAX_TRAJECTORY_POINTS, WaypointRequest
from ..sim.playback import SampledTrajectory

NANOS = 1_000_000_000
# A tool orientation may tilt away from a rotation about z by this much [rad].
MAX_TOOL_TILT = 1e-6
# Most points a received trajectory may have: the planner's own default
# max_trajectory_points (a million took the arm 4 s and 1.9 GB to read).
MAX_TRAJECTORY_POINTS = DEFAULT_MAX_TRAJECTORY_POINTS
# A hold lasts at least this long [s] (hold_message): longer than any delivery,
# so that it never ends before it arrives.
MIN_HOLD_DURATION = 1.0


def duration_to_seconds(duration):
    """builtin_interfaces/Duration (or Time) to float seconds."""
    return duration.sec + duration.nanosec * 1e-9


def seconds_to_duration(seconds):
    """Float seconds (>= 0) to builtin_interfaces/Duration, rounded to nanoseconds."""
    total = int(round(seconds * NANOS))
    return Duration(sec=total // NANOS, nanosec=total % NANOS)


def joint_order(msg_names, joint_names):
    """Column index in the message for every configured joint (ValueError if not a match)."""
    if not msg_names:
        raise ValueError('joint_names of the message is empty')
    if len(msg_names) > len(joint_names):
        # Counted before anything else reads them (an untrusted message of any length).
        raise ValueError(f'the message names {len(msg_names)} joints; this node controls '
                         f'{len(joint_names)}: {show_names(joint_names)}')
    names = list(msg_names)
    counts = Counter(names)
    if len(counts) != len(names):
        dup = sorted(n for n, c in counts.items() if c > 1)
        raise ValueError(f'duplicate joint names in message: {show_names(dup)}')
    known = set(joint_names)
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(f'unknown joints {show_names(unknown)}; this node controls '
                         f'{show_names(joint_names)}')
    missing = [n for n in joint_names if n not in counts]
    if missing:
        raise ValueError(f'missing joints {show_names(missing)}; the message names '
                         f'{show_names(names)}')
    column = {n: k for k, n in enumerate(names)}
    return [column[n] for n in joint_names]


def _column(point, field, k, n, order, required):
    values = getattr(point, field)
    if len(values) == 0 and not required:
        return None
    if len(values) != n:
        raise ValueError(f'point {k} has {len(values)} {field} for {n} joints')
    return np.asarray(values, dtype=float)[order]


def parse_waypoint_request(msg, joint_names, from_arm=False):
    """
    Turn a waypoint ``JointTrajectory`` into a :class:`WaypointRequest` (ValueError).

    At least 2 points, or 1 when ``from_arm``: the plan starts from the
    arm's state (``start_from_current_state``, a follow_waypoints goal),
    which is prepended, as joint_trajectory_controller plays a one-point
    trajectory from where the arm is (helper-88: refused).
    """
    check_request_size(len(msg.points))
    order = joint_order(msg.joint_names, joint_names)
    n = len(order)
    least = 1 if from_arm else 2
    if len(msg.points) < least:
        raise ValueError(f'need at least {least} waypoint{"s" * (least > 1)}, got '
                         f'{len(msg.points)}' + ('' if from_arm else ' (one is enough where '
                                                 'the plan starts from the arm: '
                                                 'start_from_current_state, or a '
                                                 'follow_waypoints goal)'))
    waypoints = np.array([_column(p, 'positions', k, n, order, True)
                          for k, p in enumerate(msg.points)])
    with_effort = next((k for k, p in enumerate(msg.points) if len(p.effort)), None)
    if with_effort is not None:
        # Not planned, and not silently dropped (helper-88): the arm refuses them too.
        raise ValueError(f'point {with_effort} has effort values: waypoints are planned from '
                         'positions (torque limits: limit_torque, max_effort); send them '
                         'without efforts')
    first, last = msg.points[0], msg.points[-1]
    last_k = len(msg.points) - 1
    boundary = []
    for point, k in ((first, 0), (last, last_k)):
        for field in ('velocities', 'accelerations'):
            value = _column(point, field, k, n, order, False)
            boundary.append(np.zeros(n) if value is None else value)
    stamps = [p.time_from_start for p in msg.points]
    nanosec = np.array([d.nanosec for d in stamps])
    if np.any(nanosec >= NANOS):
        k = int(np.argmax(nanosec >= NANOS))
        raise ValueError(f'point {k}: time_from_start.nanosec is {nanosec[k]}: it must be '
                         'below 1e9 (whole seconds go in sec)')
    times = np.array([duration_to_seconds(d) for d in stamps])
    if np.any(times < 0.0):
        k = int(np.argmax(times < 0.0))
        raise ValueError(f'point {k}: time_from_start is {times[k]:.9g} s: it must not be '
                         'negative')
    # One point: its time is the time to reach it from the arm, none when 0.
    increasing = bool(np.all(np.diff(times) > 0.0)) and (times.size > 1 or times[0] > 0.0)
    return WaypointRequest(waypoints, boundary[0], boundary[1], boundary[2], boundary[3],
                           times if increasing else None)


def parse_tool_request(msg):
    """Turn a ``PoseArray`` of tool waypoints into an (N, 3) array of (x, y, yaw) (ValueError)."""
    check_request_size(len(msg.poses), 'tool_waypoints')
    frame = msg.header.frame_id
    if frame and frame != PLANAR_FRAME:
        # Poses in another frame would be planned as if in the base frame: no tf lookup.
        raise ValueError(f'tool_waypoints are in frame {show(frame)}, but the base frame of '
                         f'the planar arm is {PLANAR_FRAME!r} (no tf lookup: send them in it, '
                         'or with an empty frame_id)')
    if len(msg.poses) < 2:
        raise ValueError(f'need at least 2 tool waypoints, got {len(msg.poses)}')
    check_finite_poses(msg.poses)
    poses = np.empty((len(msg.poses), 3))
    for k, pose in enumerate(msg.poses):
        p, q = pose.position, pose.orientation
        values = np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w], dtype=float)
        scale = float(np.max(np.abs(values[3:])))
        if scale < 1e-9:
            raise ValueError(f'tool waypoint {k} has a zero orientation quaternion')
        quaternion = values[3:] / scale  # no overflow for huge components
        qx, qy, qz, qw = quaternion / np.linalg.norm(quaternion)
        tilt = 2.0 * np.arcsin(min(1.0, float(np.hypot(qx, qy))))
        if tilt > MAX_TOOL_TILT:
            raise ValueError(f'tool waypoint {k}: the orientation tilts {tilt:.3g} rad away '
                             'from a rotation about z (a planar tool has yaw only)')
        # Yaw in (-pi, pi], the same for q and -q (the same rotation).
        yaw = np.arctan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        poses[k] = (p.x, p.y, yaw)
    return poses


def check_finite_poses(poses):
    """Refuse (ValueError, naming it) the first tool waypoint with a value that is not finite."""
    for k, pose in enumerate(poses):
        p, q = pose.position, pose.orientation
        if not all(math.isfinite(v) for v in (p.x, p.y, p.z, q.x, q.y, q.z, q.w)):
            raise ValueError(f'tool waypoint {k} is not finite: position ({p.x}, {p.y}, {p.z}),'
                             f' orientation ({q.x}, {q.y}, {q.z}, {q.w})')


def trajectory_to_msg(samples, joint_names, stamp=None):
    """Convert samples of a planned trajectory to a ``JointTrajectory`` (pos, vel, acc)."""
    msg = JointTrajectory()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.joint_names = list(joint_names)
    nanos = np.round(samples.times * NANOS).astype(np.int64)
    positions = samples.positions.tolist()
    velocities = samples.velocities.tolist()
    accelerations = samples.accelerations.tolist()
    msg.points = [
        JointTrajectoryPoint(
            positions=positions[k], velocities=velocities[k], accelerations=accelerations[k],
            time_from_start=Duration(sec=int(t // NANOS), nanosec=int(t % NANOS)))
        for k, t in enumerate(nanos)]
    return msg


def sampled_trajectory_from_msg(msg, joint_names):
    """
    Convert a received ``JointTrajectory`` to a :class:`SampledTrajectory` (our order).

    Refused (ValueError): more than :data:`MAX_TRAJECTORY_POINTS` points
    (counted before anything is read), efforts (the arm plays positions,
    velocities and accelerations: they would be ignored), accelerations
    without velocities (played as positions only, as joint_trajectory_controller
    refuses them too), a ``time_from_start`` whose nanoseconds are not below
    1e9, and what :class:`SampledTrajectory` refuses.
    """
    order = joint_order(msg.joint_names, joint_names)
    n = len(order)
    if not msg.points:
        raise ValueError('trajectory has no points')
    if len(msg.points) > MAX_TRAJECTORY_POINTS:
        raise ValueError(f'trajectory has {len(msg.points)} points: more than '
                         f'{MAX_TRAJECTORY_POINTS}')
    for k, point in enumerate(msg.points):
        if len(point.effort):
            raise ValueError(f'point {k} has efforts: the arm takes positions, velocities '
                             'and accelerations only')
        if not point.time_from_start.nanosec < NANOS:
            raise ValueError(f'point {k}: time_from_start.nanosec = '
                             f'{point.time_from_start.nanosec} is not below 1e9')
    positions = np.array([_column(p, 'positions', k, n, order, True)
                          for k, p in enumerate(msg.points)])
    optional = {}
    for field in ('velocities', 'accelerations'):
        columns = [_column(p, field, k, n, order, False) for k, p in enumerate(msg.points)]
        present = [c is not None for c in columns]
        if all(present):
            optional[field] = np.array(columns)
        elif any(present):
            raise ValueError(f'{field} must be given on every point or on none')
        else:
            optional[field] = None
    if optional['accelerations'] is not None and optional['velocities'] is None:
        raise ValueError('accelerations without velocities: give both, or neither')
    times = np.array([duration_to_seconds(p.time_from_start) for p in msg.points])
    return SampledTrajectory(times, positions, optional['velocities'],
                             optional['accelerations'])


def lasting_at_rest(msg, duration=MIN_HOLD_DURATION):
    """
    Return ``msg`` with a last point at rest at ``duration`` [s] if it ends earlier.

    For a stop (it ends at rest: zero velocity and acceleration): the point
    repeats its end, so it holds there, and a stop of a few tens of
    milliseconds delivered that much late has not ended before it arrives
    (joint_trajectory_controller and ``arm_sim_node`` reject one that has, and
    the arm would go on with the motion it was to stop).  Any other ``msg``
    is returned as it is.
    """
    last = msg.points[-1]
    at_rest = not any(last.velocities) and not any(last.accelerations)
    if not at_rest or duration_to_seconds(last.time_from_start) >= duration:
        return msg
    msg.points.append(JointTrajectoryPoint(
        positions=list(last.positions), velocities=list(last.velocities),
        accelerations=list(last.accelerations), time_from_start=seconds_to_duration(duration)))
    return msg


def hold_message(position, joint_names, period, stamp=None):
    """
    Return a ``JointTrajectory`` holding ``position`` at rest: two points apart.

    ``stamp`` (builtin_interfaces/Time) is when it takes over; None = on receipt.
    The points are ``period`` apart, at least :data:`MIN_HOLD_DURATION`: a
    stop's hold is stamped ahead, and one that arrived after its end would
    be rejected (by joint_trajectory_controller and ``arm_sim_node``) and the
    arm would go on.
    """
    position = [float(v) for v in position]
    zeros = [0.0] * len(position)
    msg = JointTrajectory()
    msg.joint_names = list(joint_names)
    if stamp is not None:
        msg.header.stamp = stamp
    msg.points = [JointTrajectoryPoint(positions=position, velocities=zeros,
                                       accelerations=zeros,
                                       time_from_start=seconds_to_duration(t))
                  for t in (0.0, max(period, MIN_HOLD_DURATION))]
    return msg


def plan_response(response, outcome):
    """
    Fill a ``splines445_interfaces/srv/Plan`` response from the worker's PlanOutcome.

    On success: the trajectory as ``joint_trajectory`` would carry it, its
    duration, exact per-joint peaks and binding limit; always: the
    ``~/status`` message and values.
    """
    response.success = bool(outcome.ok)
    response.message = outcome.message
    response.values = [KeyValue(key=str(k), value=str(v)) for k, v in outcome.values.items()]
    traj = outcome.trajectory
    if not outcome.ok or traj is None:
        return response
    response.trajectory = outcome.msg
    response.duration = float(traj.duration)
    response.joint_names = list(outcome.joint_names)
    peaks = traj.peaks()
    response.peak_velocity = [float(v) for v in peaks['velocity']]
    response.peak_acceleration = [float(v) for v in peaks['acceleration']]
    response.peak_jerk = [float(v) for v in peaks['jerk']]
    response.binding_limit = str(outcome.values.get('binding', ''))
    return response
