"""
From a parsed waypoint request and the planner config to a trajectory (no rclpy).

This is everything the planner node does between parsing a message and
publishing one, so it is testable without ROS.
"""

import numpy as np

from .diagnostics import format_vector
from .ros_conversions import WaypointRequest
from ..planning import plan

# A fixed-timing request may exceed a limit by this much (round-off of times
# that came through nanosecond Durations) before it is rejected.
FIXED_TIMING_RTOL = 1e-6


def plan_request(config, request):
    """
    Plan ``request`` (a WaypointRequest) with ``config`` (a PlannerConfig).

    Raises ValueError for anything the planning core rejects, for a "fixed"
    request without strictly increasing times, and for a "fixed" request whose
    times would exceed a limit.
    """
    durations = None
    if config.timing == 'fixed':
        if request.times is None:
            raise ValueError('timing "fixed" needs a strictly increasing time_from_start '
                             'on every point')
        durations = np.diff(request.times)
    traj = plan(request.waypoints, method=config.method, timing=config.timing,
                durations=durations, max_velocity=config.max_velocity,
                max_acceleration=config.max_acceleration, max_jerk=config.jerk_limits(),
                start_velocity=request.start_velocity,
                start_acceleration=request.start_acceleration,
                end_velocity=request.end_velocity, end_acceleration=request.end_acceleration)
    if not traj.within_limits(rtol=FIXED_TIMING_RTOL):
        b = traj.binding
        raise ValueError(
            f'the requested times exceed the {b.quantity} limit of '
            f'{config.joint_names[b.joint]} on segment {b.segment} by a factor {b.ratio:.4g}')
    return traj


def start_from_state(request, position, velocity, acceleration):
    """
    Return ``request`` starting from a current state (replanning).

    The state's position is prepended as the first waypoint, its velocity and
    acceleration replace the start values.  With times (fixed timing) the
    request's ``time_from_start`` values are taken as measured from the
    switch, so its first waypoint must come strictly after 0.
    """
    times = None
    if request.times is not None:
        if request.times[0] <= 0.0:
            raise ValueError('when starting from the current state, time_from_start of '
                             'the first waypoint must be > 0 (it is the time to reach it)')
        times = np.concatenate([[0.0], request.times])
    return WaypointRequest(
        np.vstack([position, request.waypoints]), np.asarray(velocity, dtype=float),
        np.asarray(acceleration, dtype=float), request.end_velocity, request.end_acceleration,
        times)


def summary_values(traj, joint_names):
    """Key/value details of a planned trajectory for the status report."""
    peaks = traj.peaks()
    values = {
        'method': traj.method,
        'timing': traj.timing,
        'duration': f'{traj.duration:.9g}',
        'waypoints': traj.waypoints.shape[0],
        'dropped_waypoints': ' '.join(str(i) for i in traj.dropped_waypoints),
        'peak_velocity': format_vector(peaks['velocity']),
        'peak_acceleration': format_vector(peaks['acceleration']),
        'peak_jerk': format_vector(peaks['jerk']),
        'max_acceleration_jump': f'{float(np.max(traj.knot_jumps(2))):.6g}',
        'max_jerk_jump': f'{float(np.max(traj.knot_jumps(3))):.6g}',
    }
    if traj.limits is not None:
        values['limit_velocity'] = format_vector(traj.limits.velocity)
        values['limit_acceleration'] = format_vector(traj.limits.acceleration)
        values['limit_jerk'] = format_vector(traj.limits.jerk)
        b = traj.binding
        values['binding'] = (f'{joint_names[b.joint]} {b.quantity} segment {b.segment} '
                             f'ratio {b.ratio:.6g}')
    return values
