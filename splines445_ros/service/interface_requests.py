"""
Requests of the plan service and the follow_waypoints action (no rclpy).

A ``Plan`` request and a ``FollowWaypoints`` goal carry joint waypoints or
tool poses (:func:`request_message`) and a
``splines445_interfaces/PlanOverrides`` message (in a ``Plan`` request or a
``FollowWaypoints`` goal) names parameters of the planner by their names: an
empty string or array means "the node's parameter", anything else replaces
it for that one request and is validated exactly as a ``set_parameters`` of
the same value would be, with the same error text.
"""

# Override fields by kind: a non-empty string, a non-empty array (one value per
# planned joint), or an array of at most one value standing for an optional scalar.
STRING_FIELDS = ('method', 'timing', 'output', 'speed_profile')
ARRAY_FIELDS = ('max_velocity', 'max_acceleration', 'max_jerk')
SCALAR_FIELDS = ('max_tool_speed', 'max_tool_angular_speed', 'max_tool_acceleration',
                 'max_path_deviation')
OVERRIDE_FIELDS = STRING_FIELDS + ARRAY_FIELDS + SCALAR_FIELDS
# The most waypoints (or tool poses) a request may carry, checked before it is
# parsed or queued: ten times the largest request the benchmarks plan (1000).
# 100,000 were parsed and planned before max_trajectory_points refused the
# output, and a cancel queued behind them waited 4.4 s (helper-36).
MAX_REQUEST_WAYPOINTS = 10_000


def check_request_size(count, what='waypoints'):
    """Raise ValueError when a request carries more than :data:`MAX_REQUEST_WAYPOINTS`."""
    if count > MAX_REQUEST_WAYPOINTS:
        raise ValueError(f'{count} {what}: more than the {MAX_REQUEST_WAYPOINTS} a request '
                         'may carry')


def override_values(overrides, joint_request=False):
    """
    Return ``{parameter name: value}`` for the fields set in a PlanOverrides message.

    ``overrides`` may be None (nothing overridden).  Raises ValueError for an
    optional scalar given more than one value (a client that bypassed the
    message's bound), and with ``joint_request`` (joint waypoints, not tool
    poses) for a tool limit or path deviation (:data:`SCALAR_FIELDS`) other
    than 0 ("no limit"): a joint-space request has no tool path to hold it
    to.  Either would silently be ignored.
    """
    values = {}
    if overrides is None:
        return values
    for name in STRING_FIELDS:
        value = getattr(overrides, name)
        if value:
            values[name] = str(value)
    for name in ARRAY_FIELDS:
        value = getattr(overrides, name)
        if len(value):
            values[name] = tuple(float(v) for v in value)
    for name in SCALAR_FIELDS:
        value = getattr(overrides, name)
        if len(value) > 1:
            raise ValueError(f'overrides.{name} takes at most one value, got {len(value)}')
        if len(value) and joint_request and value[0] != 0.0:     # (0: no limit)
            raise ValueError(f'overrides.{name} applies to tool_waypoints requests only: '
                             'joint waypoints have no tool path to hold it to (it would be '
                             'ignored)')
        if len(value):
            values[name] = float(value[0])
    return values


def request_message(waypoints, tool_waypoints):
    """
    Return the request of a ``Plan`` request or a ``FollowWaypoints`` goal (ValueError).

    Its ``waypoints`` (a JointTrajectory) or its ``tool_waypoints`` (a
    PoseArray): exactly one of them must hold points, since the other would
    silently be ignored.
    """
    has_joints, has_tool = len(waypoints.points) > 0, len(tool_waypoints.poses) > 0
    check_request_size(len(waypoints.points))
    check_request_size(len(tool_waypoints.poses), 'tool_waypoints')
    if has_joints and has_tool:
        raise ValueError('give waypoints (joint positions) or tool_waypoints (tool poses), '
                         'not both')
    if not (has_joints or has_tool):
        raise ValueError('give waypoints (joint positions) or tool_waypoints (tool poses): '
                         'both are empty')
    return waypoints if has_joints else tool_waypoints
