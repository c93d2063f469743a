"""
From a parsed waypoint request and the planner config to a trajectory (no rclpy).

This is everything the planner node does between parsing a message and
publishing one, so it is testable without ROS.
"""

from dataclasses import dataclass, replace
import re
from typing import Optional

import numpy as np

from ..cartesian.tool_paths import plan_tool_path
from ..planning.constraints import GravityOverload
from ..planning.constraints.torque import NoRoomToMove  # noqa: F401 - for the nodes
from ..planning.plan_options import BOUNDARY_NAMES, PlanOptions
from ..planning.planner import LEAVES_POSITION_LIMITS, NO_INNER_KNOT_SPLINE, plan_with_options
from ..planning.validation import waypoint_array
from ..robot.user_text import format_vector

# A fixed-timing request may exceed a limit by this much (round-off of times
# that came through nanosecond Durations) before it is rejected.
FIXED_TIMING_RTOL = 1e-6

# Replanning from a running trajectory: when no plan exists from its state at
# the requested switch time, the switch is tried this much later [s], ...
REPLAN_RETRY_STEP = 0.05
# ... at most this much later [s] (the running trajectory's end state included
# when it comes earlier).
REPLAN_MAX_DELAY = 1.0

# A uniform plan longer than this many times the duration lower bound gets a
# WARN status: above sound paths' plans (long 445 ones aside), far below
# near-duplicate ones (doc/nodes.md, "Where the constants come from").
SLOW_PLAN_FACTOR = 20.0
# Resolution of time_from_start (builtin_interfaces/Duration) [s]: knots are
# published at their times rounded to it.
TIME_RESOLUTION = 1e-9
# The default max_trajectory_points: the most points a published trajectory has
# (and the most arm_sim_node reads, ros_conversions.MAX_TRAJECTORY_POINTS).
DEFAULT_MAX_TRAJECTORY_POINTS = 200_000
# The longest trajectory a message holds [s]: builtin_interfaces/Duration's
# seconds are an int32 (a longer time_from_start wraps round in transit).
MAX_TIME_FROM_START = 2**31 - 1
# The torque limits bind a plan whose peak torque reaches this share of a limit
# (and more than any velocity, acceleration or jerk limit's share).
TORQUE_BINDING = 0.999
# A stop (a cancelled goal) is planned jerk-continuous and as short as the limits allow.
STOP_METHOD = '555'
STOP_TIMING = 'optimal'


@dataclass(frozen=True)
class TorqueOptions:
    """
    The torque limits a request is planned to (``limit_torque``), as ``plan()`` takes them.

    ``max_torque`` (n,) [N m, or N for a slide; inf = no limit], already less
    the ``torque_headroom``; ``inverse_dynamics`` gives the torques (an
    :class:`~splines445_ros.robot.dynamics.ArmDynamics`, with its gravity pass).
    """

    max_torque: np.ndarray
    inverse_dynamics: object


@dataclass
class WaypointRequest:
    """A parsed waypoint request, columns in the configured joint order."""

    waypoints: np.ndarray
    start_velocity: np.ndarray
    start_acceleration: np.ndarray
    end_velocity: np.ndarray
    end_acceleration: np.ndarray
    times: Optional[np.ndarray]


def plan_request(config, request, torque=None):
    """
    Plan ``request`` (a WaypointRequest) with ``config`` (a PlannerConfig).

    ``torque``: the :class:`TorqueOptions` (None = no torque limits), which
    plan rest to rest only.  Raises ValueError for anything the planning core rejects,
    for a "fixed" request without strictly increasing times, for a "fixed"
    request whose times would exceed a limit (a torque limit named by its
    joint), and with torque limits for a request that starts or ends moving.
    """
    if torque is not None:
        _require_rest(config, request)
    durations = None
    if config.timing == 'fixed':
        if request.times is None:
            raise ValueError('timing "fixed" needs a strictly increasing time_from_start '
                             'on every point')
        durations = np.diff(request.times)
    try:
        traj = _plan(request, config, durations, torque)
    except ValueError as exc:
        if torque is None or config.timing != 'fixed' or isinstance(exc, GravityOverload):
            raise
        raise _named_joint(exc, config.joint_names) from exc
    if not traj.within_limits(rtol=FIXED_TIMING_RTOL):
        b = traj.binding
        raise ValueError(
            f'the requested times exceed the {b.quantity} limit of '
            f'{config.joint_names[b.joint]} on segment {b.segment} by a factor {b.ratio:.4g}')
    return traj


def _plan(request, config, durations, torque):
    """Plan the request's waypoints under :func:`plan_options` (their shape checked here)."""
    points = waypoint_array(request.waypoints)
    options = plan_options(config, points.shape[1], (
        request.start_velocity, request.start_acceleration, request.end_velocity,
        request.end_acceleration), torque)
    return plan_with_options(points, options, durations)


def plan_options(config, n_joints, boundary=(None,) * 4, torque=None):
    """
    Return the :class:`~splines445_ros.planning.plan_options.PlanOptions` of one request.

    ``config``: a PlannerConfig its parameter layer validated (method,
    timing, limits, waypoint_tolerance, inner_knots, vibration_frequency,
    smoothing, speed_profile: taken as they are, not checked again); ``n_joints`` the
    request's columns, ``boundary`` its start velocity, start acceleration,
    end velocity and end acceleration (None: zeros) and ``torque`` its
    :class:`TorqueOptions` (None = none): these come with the request and
    are checked (ValueError, with plan()'s texts).  The config's position
    limits go with them (empty: none), and its joint names for their errors:
    plan_with_options checks its plan against them, and tries the other
    speed profile when the one asked for leaves them.
    """
    return PlanOptions.from_validated(
        n_joints, config.method, config.timing, config.max_velocity, config.max_acceleration,
        config.jerk_limits(), boundary, waypoint_tolerance=config.waypoint_tolerance,
        inner_knots=config.plan_inner_knots(), vibration_frequency=config.vibration_frequency,
        smoothing=config.smoothing, speed_profile=config.speed_profile,
        max_torque=None if torque is None else torque.max_torque,
        inverse_dynamics=None if torque is None else torque.inverse_dynamics,
        min_position=config.min_position or None, max_position=config.max_position or None,
        joint_names=config.joint_names)


def _named_joint(exc, joint_names):
    """Return ``exc`` with a leading 'joint <index> needs' naming the joint (fixed timing)."""
    text = str(exc)
    match = re.match(r'joint (\d+) needs ', text)
    if match is None or int(match.group(1)) >= len(joint_names):
        return ValueError(text)
    name = joint_names[int(match.group(1))]
    return ValueError(f'joint {name!r} (column {match.group(1)}) needs ' + text[match.end():])


def _require_rest(config, request):
    """Refuse a request with non-zero boundary values under torque limits (ValueError)."""
    moving = [(name, value) for name, value in zip(BOUNDARY_NAMES, (
        request.start_velocity, request.start_acceleration, request.end_velocity,
        request.end_acceleration)) if value is not None and np.any(np.asarray(value) != 0.0)]
    if not moving:
        return
    name, value = moving[0]
    hint = ('send the request with zero velocities and accelerations on its first and '
            'last points')
    if config.start_from_current_state and name.startswith('start'):
        hint = ('start_from_current_state starts from the state at the switch time, and the '
                'arm is moving there: send the request when the arm is at rest, or set '
                'limit_torque to false for replanning while moving')
    raise ValueError(f'limit_torque plans rest to rest, but the request has {name} '
                     f'[{format_vector(value)}]: {hint}')


def plan_tool_request(config, poses):
    """
    Plan tool waypoints ``poses`` (N, 3) = (x, y, yaw) with ``config``; return a ToolPath.

    Rest to rest (zero boundary values), with the inverse kinematics of
    ``config.kinematics`` (the paper's elbow branch for "planar_3dof"), refined
    until the tool stays within ``max_path_deviation`` [m] and
    ``max_orientation_deviation`` [rad] of the straight lines (0 = not checked;
    both 0 = no refinement).  Raises ValueError when the kinematics is unset,
    for "fixed" timing (a PoseArray has no times), for replanning (tool
    requests start at rest at their first waypoint), and for anything the
    refinement rejects.
    """
    kinematics = config.tool_kinematics()
    if kinematics is None:
        raise ValueError('tool_waypoints need the kinematics parameter (e.g. "planar_3dof"); '
                         'it is "" (joint space only)')
    return plan_tool_poses(config, poses, kinematics)


def plan_tool_poses(config, poses, kinematics, torque=None):
    """
    Plan tool ``poses`` with ``kinematics`` and ``config``, rest to rest; return a ToolPath.

    The part every tool request shares (planar or a robot model): refined to
    ``max_path_deviation`` and ``max_orientation_deviation``, within the
    position limits, with ``inner_knots`` (555 optimal) and the tool speed
    limits ``max_tool_speed`` [m/s], ``max_tool_angular_speed`` [rad/s] and
    ``max_tool_acceleration`` [m/s^2] (0 = no limit; the config refuses
    them where they cannot apply), and
    ``torque`` (the :class:`TorqueOptions`; None = none), which the
    'tool lines' construction (555 optimal) holds together with the tool
    speeds, and the refinement (other methods) by slowing each plan down.
    Raises ValueError for "fixed" timing (a PoseArray has no times), for
    replanning (tool requests start at rest at their first waypoint), and
    for anything the refinement or the limits reject.
    """
    if config.timing == 'fixed':
        raise ValueError('timing "fixed" needs times, which tool_waypoints (PoseArray) do not '
                         'carry: use timing "uniform" or "optimal"')
    if config.start_from_current_state:
        raise ValueError('tool_waypoints are planned rest to rest from their first waypoint; '
                         'set start_from_current_state to false for them')
    options = plan_options(config, len(config.joint_names), torque=torque)
    tool_path = plan_tool_path(poses, kinematics, config.max_path_deviation,
                               config.max_orientation_deviation, config.max_inserted_waypoints,
                               max_tool_speed=config.max_tool_speed,
                               max_tool_angular_speed=config.max_tool_angular_speed,
                               max_tool_acceleration=config.max_tool_acceleration,
                               max_refinement_time=config.max_refinement_time,
                               options=options)
    return tool_path


def output_samples(config, traj):
    """
    Return the points to publish for ``traj``: samples every ``sample_period`` or its knots.

    ``output: knots`` gives one point per breakpoint of ``traj.ppoly`` (inner
    knots included), at its time rounded to the nanosecond with the spline's
    exact state there (see ``Trajectory.knots``).  Raises ValueError when
    there would be more than ``max_trajectory_points`` points (checked before
    sampling), when two knots are less than a nanosecond apart, or when the
    trajectory lasts longer than a message's ``time_from_start`` holds
    (:data:`MAX_TIME_FROM_START`).
    """
    if not traj.duration <= MAX_TIME_FROM_START:
        raise ValueError(f'the trajectory lasts {traj.duration:.6g} s: more than a '
                         f'time_from_start holds ({MAX_TIME_FROM_START} s, an int32)')
    if config.output == 'knots':
        n_points = traj.ppoly.x.size
        what = f'{n_points} knots'
    else:
        # Between the regular samples alone (each knot's replaces at most one) and
        # all of them with every knot's: counted exactly only in between.
        regular = int(traj.duration / config.sample_period) + 1
        n_points = regular
        if regular <= config.max_trajectory_points < regular + traj.ppoly.x.size:
            n_points = traj.sample_times(config.sample_period, TIME_RESOLUTION)[0].size
        what = f'{n_points} points or more at sample_period {config.sample_period} s'
    if n_points > config.max_trajectory_points:
        raise ValueError(
            f'the trajectory lasts {traj.duration:.6g} s: {what}, more than '
            f'max_trajectory_points ({config.max_trajectory_points})')
    if config.output == 'knots':
        return traj.knots(TIME_RESOLUTION)
    return traj.sample(config.sample_period, TIME_RESOLUTION)


def tool_summary_values(tool_path):
    """
    Key/value details of a tool path for the status report.

    ``tool_construction`` is ``'tool lines'`` or ``'refined'``; the tool
    speeds reached [m/s], [rad/s] (checked every millisecond) come with the
    'tool lines' construction only, and ``tool_speed_share`` (of the path's
    length at >= 99 % of ``max_tool_speed``) with a linear tool speed limit
    only, ``max_tool_acceleration_reached`` [m/s^2] with
    ``max_tool_acceleration`` only: keys without a value are left out, like
    ``limit_velocity``.
    """
    values = {
        'tool_waypoints': len(tool_path.waypoint_knots),
        'inserted_waypoints': tool_path.inserted,
        'max_path_deviation_reached': f'{tool_path.max_deviation:.6g}',
        'max_orientation_deviation_reached': f'{tool_path.max_orientation_deviation:.6g}',
        'unrefined_max_path_deviation': f'{tool_path.initial_deviation.max_position:.6g}',
        'unrefined_duration': f'{tool_path.initial_duration:.9g}',
        'tool_construction': tool_path.construction,
    }
    for key, value in (('max_tool_speed_reached', tool_path.tool_speed),
                       ('max_tool_angular_speed_reached', tool_path.tool_angular_speed),
                       ('tool_speed_share', tool_path.speed_share),
                       ('max_tool_acceleration_reached', tool_path.tool_acceleration)):
        if value is not None:
            values[key] = f'{value:.6g}'
    return values


def start_from_state(request, position, velocity, acceleration, tolerance=0.0):
    """
    Return ``request`` starting from a current state (replanning).

    The state's position is prepended as the first waypoint, its velocity and
    acceleration replace the start values.  When every joint of the position
    is within ``tolerance`` of the request's first waypoint (a user who sends
    ``[current pose, goal, ...]`` while the measured pose carries noise or a
    friction dead band), it replaces that waypoint instead: a tiny first
    segment next to the start state would make the spline swing.  With times
    (fixed timing) the request's ``time_from_start`` values are taken as
    measured from the switch, so its first waypoint must come strictly after
    0 (a replaced first waypoint's time is dropped with it).
    """
    position = np.asarray(position, dtype=float)
    waypoints = request.waypoints
    times = request.times
    near = np.max(np.abs(waypoints[0] - position)) <= tolerance
    if waypoints.shape[0] == 1 and near:
        # joint_trajectory_controller would hold there; a plan needs a motion
        # (it said "all waypoints coincide", helper-91).
        raise ValueError(f'the one waypoint is where the arm is (within waypoint_tolerance '
                         f'{tolerance:g}): nothing to move')
    replaced = waypoints.shape[0] > 1 and near
    if replaced:
        waypoints = waypoints[1:]
        times = None if times is None else times[1:]
    if times is not None:
        if times[0] <= 0.0:
            raise ValueError('when starting from the current state, time_from_start of '
                             'the first waypoint must be > 0 (it is the time to reach it)')
        times = np.concatenate([[0.0], times])
    return WaypointRequest(
        np.vstack([position, waypoints]), np.asarray(velocity, dtype=float),
        np.asarray(acceleration, dtype=float), request.end_velocity, request.end_acceleration,
        times)


class InJointOrder:
    """
    A running Trajectory seen in another order of its joints (``joint_names`` reordered).

    ``order`` (n,) gives, for each joint in the new order, its column in
    ``running``.  It has what :func:`plan_from_running` and
    :func:`plan_from_state_at` read: ``duration`` and ``evaluate``.
    """

    def __init__(self, running, order):
        """Keep the trajectory and the column order."""
        self.running, self.order = running, list(order)
        self.duration = running.duration

    def evaluate(self, t, derivative=0):
        """Return the running trajectory's values at ``t`` (T, n), columns in the new order."""
        return self.running.evaluate(t, derivative)[:, self.order]


def running_in_order(running, running_names, joint_names):
    """
    Return ``running`` with its joints in the order ``joint_names``, or None.

    None when the two name other joints (not a reordering): the running
    state of the planned joints is then unknown to the plan.
    """
    running_names, joint_names = tuple(running_names), tuple(joint_names)
    if running_names == joint_names:
        return running
    if sorted(running_names) != sorted(joint_names):
        return None
    return InJointOrder(running, [running_names.index(n) for n in joint_names])


def plan_from_state_at(config, request, running, t, torque=None):
    """Plan ``request`` from the ``running`` Trajectory's state at ``t`` s (its p, v, a)."""
    state = tuple(running.evaluate([t], d)[0] for d in (0, 1, 2))
    return plan_request(config, start_from_state(request, *state, config.waypoint_tolerance),
                        torque)


def plan_from_running(config, request, running, switch_time, clock=None, torque=None):
    """
    Plan ``request`` from the state of the ``running`` Trajectory at ``switch_time``.

    ``switch_time`` is in seconds into ``running``.  A state the running
    trajectory passes through may admit no plan: a polynomial first segment
    cannot always turn a given velocity and acceleration towards the next
    waypoint within the limits (the paper example's 445 uniform plan has such
    windows, each about 0.1 s long).  Since following the running trajectory
    a little longer is always within the limits, later switch times are tried
    too, every :data:`REPLAN_RETRY_STEP` up to :data:`REPLAN_MAX_DELAY` later,
    ending with the running trajectory's end state when it comes earlier.
    ``clock()``, when given, returns the current time in the running
    trajectory's time; candidates it has already passed are skipped.
    ``torque``: as for :func:`plan_request` (rest to rest: only a candidate
    where the running trajectory is at rest, its end, can plan).

    Returns ``(time, trajectory)``: the switch time used and the plan.  Raises
    the requested switch time's ValueError (noting the later times tried)
    when no candidate plans.
    """
    n_retries = int(np.floor(REPLAN_MAX_DELAY / REPLAN_RETRY_STEP + 1e-9))
    candidates = switch_time + REPLAN_RETRY_STEP * np.arange(n_retries + 1)
    candidates = [float(t) for t in candidates if t < running.duration]
    if running.duration <= switch_time + REPLAN_MAX_DELAY:
        candidates.append(float(max(running.duration, switch_time)))
    first_error = None
    tried = 0
    for t in candidates:
        if clock is not None and tried and clock() >= t:
            continue
        tried += 1
        try:
            return t, plan_from_state_at(config, request, running, t, torque)
        except ValueError as exc:
            if first_error is None:
                first_error = exc
    if tried > 1:
        raise ValueError(f'{first_error} (from the state of the running trajectory at the switch '
                         f'time and {tried - 1} later times up to '
                         f'{candidates[-1] - switch_time:.3g} s later)') from first_error
    raise first_error


def stop_position(config, position, velocity):
    """
    Return where each joint comes to rest when braking from ``velocity``: the stop's goal.

    A joint braking at its acceleration limit a, reached at its jerk limit j,
    travels about v (|v| / 2a + a / 2j); without a jerk limit the second
    term is 0.
    """
    velocity = np.asarray(velocity, dtype=float)
    acceleration = np.asarray(config.max_acceleration, dtype=float)
    jerk = config.jerk_limits()
    ramp = 0.0 if jerk is None else acceleration / np.asarray(jerk, dtype=float)
    return (np.asarray(position, dtype=float)
            + velocity * (np.abs(velocity) / (2.0 * acceleration) + 0.5 * ramp))


def ends_at_rest(config, running):
    """
    Return True when the ``running`` Trajectory ends at rest, as :func:`plan_stop` judges rest.

    Braking from its end velocity would end within ``waypoint_tolerance``
    of its end position (:func:`stop_position`): a stop there holds it.
    """
    position, velocity = (running.evaluate([running.duration], d)[0] for d in (0, 1))
    return bool(np.max(np.abs(stop_position(config, position, velocity) - position))
                <= config.waypoint_tolerance)


def plan_stop(config, running, switch_time, clock=None):
    """
    Plan a stop of the ``running`` Trajectory from its state at ``switch_time`` (a cancel).

    The stop starts with the running trajectory's position, velocity and
    acceleration there, so the arm's commanded state does not jump, and ends
    at rest at :func:`stop_position`, within the velocity, acceleration and
    jerk limits of ``config``; it is planned with :data:`STOP_METHOD` and
    :data:`STOP_TIMING` (no torque limits, no smoothing windows: those
    plan rest to rest).  Later switch times are tried as in
    :func:`plan_from_running`.  Returns ``(time, trajectory)``, or None when
    the running trajectory is already within ``waypoint_tolerance`` of its
    stop there (it is at rest, or nearly: the caller holds its position).
    """
    position, velocity = (running.evaluate([switch_time], d)[0] for d in (0, 1))
    goal = stop_position(config, position, velocity)
    if np.max(np.abs(goal - position)) <= config.waypoint_tolerance:
        return None
    zeros = np.zeros_like(goal)
    request = WaypointRequest(goal[None, :], zeros, zeros, zeros, zeros, None)
    stop_config = replace(config, method=STOP_METHOD, timing=STOP_TIMING,
                          vibration_frequency=0.0)
    return plan_from_running(stop_config, request, running, switch_time, clock)


def slow_plan_warning(traj):
    """
    Return a warning when a uniform plan is far slower than it need be, else None.

    The paper's common factor stretches the whole path for its worst segment;
    beyond :data:`SLOW_PLAN_FACTOR` times the simple lower bound
    (:meth:`Trajectory.duration_lower_bound`) that is worth a word.
    """
    bound = traj.duration_lower_bound()
    if traj.timing != 'uniform' or not bound or traj.duration <= SLOW_PLAN_FACTOR * bound:
        return None
    if torque_binds(traj):
        return None  # the torque limits set the time, which the bound does not know
    return (f'the uniform plan lasts {traj.duration:.4g} s, {traj.duration / bound:.3g} times '
            f'the lower bound {bound:.4g} s (duration_lower_bound: segments at top speed, '
            "resting joints' rest-to-rest moves): timing \"optimal\" would be far shorter; "
            'near-duplicate waypoints above '
            'waypoint_tolerance cause this too')


def inner_knots_warning(traj):
    """
    Return a warning when 555 optimal's inner knots were asked for and none was found, else None.

    The construction (:mod:`~splines445_ros.planning.path_following.inner_knots`) found no
    spline with inner knots within the limits (boundary values it cannot
    keep, for one): the plan returned is the knots-only optimum, within
    every limit but slower and without the smoothing windows.  A knots-only
    plan that was simply shorter (the rival) is no failure and says nothing.
    Where that plan then got knots of its own at the position limits
    (``end_knots``, ``position_limit_knots``), the warning names them.
    """
    optimizer = traj.optimizer or {}
    if optimizer.get('inner_knots_skipped') != NO_INNER_KNOT_SPLINE:
        return None
    more = [key for key in ('end_knots', 'position_limit_knots') if optimizer.get(key)]
    knots = ('knots at the waypoints only' if not more else
             'knots at the waypoints and those of ' + ' and '.join(f'`{k}`' for k in more))
    return (f'{NO_INNER_KNOT_SPLINE}: planned with {knots} (within every limit, but slower, '
            'and not smoothed)')


def speed_profile_warning(traj):
    """
    Return a warning when speed_profile "time_optimal" was asked for and not used, else None.

    It found no spline (the plan is "smoothed"'s), or its plan left the
    position limits, and ``speed_profile_skipped`` already ends with what
    was planned instead ("smoothed", or the chord-length durations).
    """
    skipped = (traj.optimizer or {}).get('speed_profile_skipped')
    if not skipped:
        return None
    if skipped.startswith(LEAVES_POSITION_LIMITS.format('time_optimal')):
        return skipped
    return (f'{skipped}: planned with speed_profile "smoothed" instead (within every limit, '
            'but slower)')


def position_limits_warning(traj):
    """
    Return a warning when the smoothed plan left the position limits and another was given.

    The knots-only optimum (slower), speed_profile "time_optimal" (it shakes
    more) or the chord-length durations of timing "uniform" (slower):
    ``speed_profile_reason`` says which and why, else None.
    """
    reason = (traj.optimizer or {}).get('speed_profile_reason') or ''
    return reason if reason.startswith(LEAVES_POSITION_LIMITS.format('smoothed')) else None


def plan_warnings(traj):
    """Return the plan's warnings joined (slow, another plan than asked for), or None."""
    found = [w for w in (slow_plan_warning(traj), inner_knots_warning(traj),
                         speed_profile_warning(traj), position_limits_warning(traj)) if w]
    return '; '.join(found) or None


def summary_values(traj, joint_names):
    """Key/value details of a planned trajectory for the status report."""
    peaks = traj.peaks()
    values = {
        'method': traj.method,
        'timing': traj.timing,
        'duration': f'{traj.duration:.9g}',
        'waypoints': traj.waypoints.shape[0],
        'knots': traj.breakpoints.size,
        'dropped_waypoints': ' '.join(str(i) for i in traj.dropped_waypoints),
        'peak_velocity': format_vector(peaks['velocity']),
        'peak_acceleration': format_vector(peaks['acceleration']),
        'peak_jerk': format_vector(peaks['jerk']),
        'max_acceleration_jump': f'{float(np.max(traj.knot_jumps(2))):.6g}',
        'max_jerk_jump': f'{float(np.max(traj.knot_jumps(3))):.6g}',
        'max_excursion': format_vector(traj.excursion()),
    }
    if traj.limits is not None:
        values['limit_velocity'] = format_vector(traj.limits.velocity)
        values['limit_acceleration'] = format_vector(traj.limits.acceleration)
        values['limit_jerk'] = format_vector(traj.limits.jerk)
        b = traj.binding
        # A segment runs between waypoints; with inner knots it holds several pieces.
        segment = int(np.searchsorted(traj.waypoint_times, traj.breakpoints[b.segment],
                                      side='right')) - 1
        values['binding'] = (f'{joint_names[b.joint]} {b.quantity} segment {segment} '
                             f'ratio {b.ratio:.6g}')
        values['duration_lower_bound'] = f'{traj.duration_lower_bound():.9g}'
    ratios = traj.torque_ratios
    if ratios is not None:
        values['peak_torque_ratio'] = format_vector(ratios)
        if torque_binds(traj):
            j = int(np.argmax(ratios))
            values['binding'] = f'{joint_names[j]} torque ratio {ratios[j]:.6g}'
    for key in ('inner_knots_skipped', 'end_knots', 'knots_only_skipped', 'position_limit_knots',
                'residual_knots', 'speed_profile', 'speed_profile_skipped',
                'speed_profile_reason'):
        if (traj.optimizer or {}).get(key):
            values[key] = traj.optimizer[key]
    residual = (traj.optimizer or {}).get('vibration_residual')
    if residual is not None:
        # A vibration_frequency's ringing after the stop (time_optimal's, or smoothed's
        # with its knots moved to cancel it: residual_knots).
        values['vibration_residual'] = f'{residual:.3g}'
    return values


def torque_binds(traj):
    """
    Return True when a torque limit sets the time of ``traj`` (planned with torque limits).

    Its largest peak torque over limit reaches :data:`TORQUE_BINDING` and
    exceeds the largest velocity, acceleration or jerk ratio.
    """
    ratios = traj.torque_ratios
    if ratios is None or not np.max(ratios) >= TORQUE_BINDING:
        return False
    return traj.limits is None or float(np.max(ratios)) > traj.binding.ratio


def raised_from(exc, kind):
    """Return the ``kind`` (as :class:`GravityOverload`) ``exc`` is or was raised from, or None."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, kind):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


def _column_name(j, joint_names):
    """Return the name of the library's joint column ``j``: ``joint_names[j]``, or 'column j'."""
    return joint_names[j] if 0 <= j < len(joint_names) else f'column {j}'


def no_room_report(refusal, joint_names, headroom=0.0, counts_friction=True):
    """
    Return (message, status values) of a :class:`NoRoomToMove`, the joint named.

    ``headroom`` (``torque_headroom``) and ``counts_friction``
    (``torque_counts_friction``) are said in the advice when they apply.
    """
    name = _column_name(refusal.joint, joint_names)
    advice = ['lower the payload', 'raise max_effort']
    if headroom:
        advice.append(f'lower torque_headroom ({headroom:g})')
    if refusal.friction and counts_friction:
        advice.append('set torque_counts_friction false if the description overstates the '
                      'friction')
    advice[-1] = 'or ' + advice[-1]
    message = (f'joint {name!r}: {refusal.what()} {refusal.how()} (' + ', '.join(advice) + ')')
    return message, {'overloaded_joint': name}


def gravity_overload_report(overload, joint_names, headroom=0.0):
    """
    Return (message, status values) of a :class:`GravityOverload`, the joint named.

    The library names the joint by its column; the planned ``joint_names``
    give its name.  ``headroom``: the ``torque_headroom`` the limit was
    lowered by, said in the message.
    """
    name = _column_name(overload.joint, joint_names)
    pose = ', '.join(f'{v:.4g}' for v in overload.pose)
    planned = (f' (max_effort less torque_headroom {headroom:g})' if headroom else '')
    message = (f'joint {name!r}: gravity alone needs {overload.torque:.4g} N m at the pose '
               f'[{pose}] (joint_names order), beyond its torque limit of '
               f'{overload.limit:.4g} N m{planned}: no speed along this path holds it (lower '
               'the payload, raise max_effort, or choose waypoints where the arm can hold '
               'it)')
    values = {'overloaded_joint': name, 'gravity_torque': f'{overload.torque:.6g}',
              'torque_limit': f'{overload.limit:.6g}', 'pose': pose}
    return message, values
