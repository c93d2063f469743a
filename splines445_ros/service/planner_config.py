"""
Validated configuration of the planner node (pure Python, no rclpy).

The node's ROS parameters map one to one onto :class:`PlannerConfig`; every
``set_parameters`` is checked by building a new config from the current values
overlaid with the request, so a bad value is rejected with the reason and the
old configuration stays.
"""

from dataclasses import dataclass, replace
import math
from typing import Tuple

from .validated_config import ValidatedConfig
from ..planning import DEFAULT_WAYPOINT_TOLERANCE, METHODS, TIMINGS
from ..planning.plan_options import MAX_INNER_KNOTS, MAX_VIBRATION_FREQUENCY, smoothing_value
from ..robot.dynamics import payload_inertia_matrix
from ..robot.joint_limits_file import check_limit_value
from ..robot.kinematics import PlanarArm
from ..robot.user_text import show, show_names

DEFAULT_JOINTS = ('joint1', 'joint2', 'joint3')
# The planar arm's (and a joint-space planner's) limits when none are set.
PLANAR_VELOCITY = 2.0
PLANAR_ACCELERATION = 10.0
# Declared parameter values meaning "not set": with kinematics "model" every one
# comes from the robot's description; otherwise the planar arm's defaults apply.
# ('' and 0.0 since ROS parameter overrides cannot carry an empty array.)
NOT_SET_NAMES = ('',)
NOT_SET_LIMITS = (0.0,)
MIN_SAMPLE_PERIOD = 1e-4
MAX_LEAD_TIME = 10.0
# Values of the ``kinematics`` parameter: '' = joint space only.
KINEMATICS = ('', 'planar_3dof', 'model')
MAX_INSERTED_WAYPOINTS = 100000
# A waypoint tolerance above this [rad or m] would merge distinct taught points.
MAX_WAYPOINT_TOLERANCE = 0.1
# Values of the ``output`` parameter: a point every sample_period, or one per knot.
OUTPUTS = ('sampled', 'knots')
# Tool speed limits of tool_waypoints requests and their units (0 = no limit).
TOOL_SPEEDS = (('max_tool_speed', 'm/s'), ('max_tool_angular_speed', 'rad/s'))
# limit_torque: the acceleration limit [rad/s^2 or m/s^2] of a joint that has none
# (neither max_acceleration nor the joint_limits_file): high enough that the torque
# limits the arm, within the range the planner works in (LIMIT_RANGES).
TORQUE_STAND_IN_ACCELERATION = 1000.0
# inner_knots "auto": plan()'s default (inner_knots None), 4, or 6 with torque
# limits and no smoothing windows (plan_options.DEFAULT_INNER_KNOTS and
# TORQUE_INNER_KNOTS).
AUTO_INNER_KNOTS = -1
# limit_torque: the share of every torque limit a plan leaves to the controller's
# feedback (torque_headroom), by default and at most.  A plan that uses all of a
# joint's torque leaves the PD loop nothing for its corrections, and the motor
# saturates (benchmarks/bench_torque_arm.py).
DEFAULT_TORQUE_HEADROOM = 0.1
MAX_TORQUE_HEADROOM = 0.5
# follow_waypoints goals: the arm has settled when joint_states are this close to the
# end [rad or m] and this slow [rad/s or m/s] (joint_trajectory_controller's goal
# and stopped_velocity_tolerance), at most goal_time_tolerance after the end [s].
DEFAULT_GOAL_POSITION_TOLERANCE = 0.01
DEFAULT_GOAL_VELOCITY_TOLERANCE = 0.01
DEFAULT_GOAL_TIME_TOLERANCE = 2.0
MAX_GOAL_TIME_TOLERANCE = 3600.0


@dataclass(frozen=True)
class PlannerConfig(ValidatedConfig):
    """Everything the planner needs besides the request itself."""

    joint_names: Tuple[str, ...] = DEFAULT_JOINTS
    max_velocity: Tuple[float, ...] = (2.0, 2.0, 2.0)
    max_acceleration: Tuple[float, ...] = (10.0, 10.0, 10.0)
    max_jerk: Tuple[float, ...] = (0.0, 0.0, 0.0)
    method: str = '445'
    timing: str = 'uniform'
    sample_period: float = 0.01
    start_from_current_state: bool = False
    replan_lead_time: float = 0.2
    max_trajectory_points: int = 200000
    kinematics: str = ''
    link_lengths: Tuple[float, ...] = (1.1, 0.9)
    max_path_deviation: float = 0.0
    max_orientation_deviation: float = 0.0
    # Tool speed limits [m/s], [rad/s] of tool_waypoints requests; 0 = no limit.
    max_tool_speed: float = 0.0
    max_tool_angular_speed: float = 0.0
    max_inserted_waypoints: int = 200
    waypoint_tolerance: float = DEFAULT_WAYPOINT_TOLERANCE
    min_position: Tuple[float, ...] = ()
    max_position: Tuple[float, ...] = ()
    output: str = 'sampled'
    inner_knots: int = AUTO_INNER_KNOTS
    vibration_frequency: float = 0.0
    smoothing: str = 'auto'
    # kinematics "model": a robot description (see nodes/robot_description.py).
    model_file: str = ''
    tool_frame: str = ''
    base_frame: str = ''
    joint_limits_file: str = ''
    # Torque limits (kinematics "model"): see _validate_torque.
    limit_torque: bool = False
    max_effort: Tuple[float, ...] = NOT_SET_LIMITS
    payload_mass: float = 0.0
    payload_center_of_mass: Tuple[float, ...] = (0.0, 0.0, 0.0)
    payload_inertia: Tuple[float, ...] = ()
    torque_headroom: float = DEFAULT_TORQUE_HEADROOM
    # follow_waypoints goals: when the arm has settled at the end.
    goal_position_tolerance: float = DEFAULT_GOAL_POSITION_TOLERANCE
    goal_velocity_tolerance: float = DEFAULT_GOAL_VELOCITY_TOLERANCE
    goal_time_tolerance: float = DEFAULT_GOAL_TIME_TOLERANCE

    PARAMETER_DEFAULTS = {'joint_names': NOT_SET_NAMES, 'max_velocity': NOT_SET_LIMITS,
                          'max_acceleration': NOT_SET_LIMITS, 'max_jerk': NOT_SET_LIMITS,
                          'max_effort': NOT_SET_LIMITS}

    def with_defaults(self):
        """
        Return the config with "not set" joint names and limits resolved.

        With kinematics "model" they stay "not set" (``joint_names`` ``()``,
        limits all zero): the robot's description gives them once it is loaded
        (see :mod:`.model_planning`).  Otherwise joint_names not set means the
        planar arm's ``joint1..3``, and with those joints limits not set mean
        the paper's 2 rad/s and 10 rad/s^2 (no jerk limit); other joints need
        their limits given (:meth:`validate` says how).
        """
        names = () if tuple(self.joint_names) in ((), NOT_SET_NAMES) else self.joint_names
        jerk = () if not any(self.max_jerk) else self.max_jerk
        effort = () if not any(self.max_effort) else self.max_effort
        if self.kinematics == 'model':
            return replace(self, joint_names=names, max_jerk=jerk, max_effort=effort)
        names = names or DEFAULT_JOINTS
        changes = {'joint_names': names, 'max_jerk': jerk, 'max_effort': effort}
        if names == DEFAULT_JOINTS:
            for field, value in (('max_velocity', PLANAR_VELOCITY),
                                 ('max_acceleration', PLANAR_ACCELERATION)):
                if not any(getattr(self, field)):
                    changes[field] = (value,) * len(names)
        return replace(self, **changes)

    def validate(self):
        """Raise ValueError with the reason when any value is unusable."""
        names = self.joint_names
        model = self.kinematics == 'model'
        self._require_model_for_torque()
        if model and names == NOT_SET_NAMES:
            names = ()  # all of the model's actuated joints
        if not names and not model:
            raise ValueError('joint_names must not be empty')
        if any(not isinstance(n, str) or not n for n in names):
            raise ValueError('joint_names must be non-empty strings')
        if len(set(names)) != len(names):
            raise ValueError(f'joint_names has duplicates: {show_names(names)}')
        n = len(names)
        for name in ('max_velocity', 'max_acceleration'):
            if model:
                require_description_limits(name, getattr(self, name), names)
            elif not any(getattr(self, name)):
                raise ValueError(
                    f'{name} is not set for joint_names {show_names(names)}: give one value per '
                    f'joint, e.g. -p {name}:=[{", ".join(["1.0"] * n)}] (the defaults are '
                    "the planar arm's, for joint1..3), or kinematics:=model with a robot "
                    'description to take them from it')
            else:
                self.require_positive(name, n, f'one value per joint ({n}) of joint_names '
                                      f'{show_names(names)}')
        for name, quantity in (('max_velocity', 'velocity'),
                               ('max_acceleration', 'acceleration'), ('max_jerk', 'jerk')):
            for i, value in enumerate(getattr(self, name)):
                if value > 0.0:  # 0: not set (or no jerk limit), checked above
                    check_limit_value(quantity, value, f'{name}[{i}]')
        if len(self.max_jerk) not in (0, n) and not model:
            raise ValueError(f'max_jerk needs one value per joint ({n}) of joint_names '
                             f'{show_names(names)}, or [0.0] for no jerk limit; got '
                             f'{len(self.max_jerk)}')
        for i, v in enumerate(self.max_jerk):
            if math.isnan(v) or v < 0.0:
                raise ValueError(f'max_jerk[{i}] = {v}: must be >= 0 (0 = no jerk limit)')
        if self.method not in METHODS:
            raise ValueError(f'method must be one of {list(METHODS)}, '
                             f'got {show(self.method)}')
        if self.timing not in TIMINGS:
            raise ValueError(f'timing must be one of {list(TIMINGS)}, '
                             f'got {show(self.timing)}')
        if not (math.isfinite(self.sample_period) and self.sample_period >= MIN_SAMPLE_PERIOD):
            raise ValueError(f'sample_period = {self.sample_period}: must be at least '
                             f'{MIN_SAMPLE_PERIOD} s')
        self.require_in_range('replan_lead_time', 0.0, MAX_LEAD_TIME, 's')
        self.require_in_range('waypoint_tolerance', 0.0, MAX_WAYPOINT_TOLERANCE)
        for name in ('goal_position_tolerance', 'goal_velocity_tolerance'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f'{name} = {value}: must be positive and finite')
        self.require_in_range('goal_time_tolerance', 0.0, MAX_GOAL_TIME_TOLERANCE, 's')
        if n or not model:  # with all of a model's joints: checked once it is loaded
            self.validate_position_limits(n)
        if self.output not in OUTPUTS:
            raise ValueError(f'output must be one of {list(OUTPUTS)}, '
                             f'got {show(self.output)}')

        if not AUTO_INNER_KNOTS <= self.inner_knots <= MAX_INNER_KNOTS:
            raise ValueError(f'inner_knots = {self.inner_knots}: must be in '
                             f'[0, {MAX_INNER_KNOTS}], or {AUTO_INNER_KNOTS} (auto)')
        self.require_in_range('vibration_frequency', 0.0, MAX_VIBRATION_FREQUENCY, 'Hz')
        if self.vibration_frequency and not self.has_inner_knots():
            raise ValueError(f'vibration_frequency = {self.vibration_frequency:g} Hz needs '
                             'method "555" with timing "optimal" and inner_knots > 0 (got '
                             f'method {show(self.method)}, timing {show(self.timing)}, '
                             f'inner_knots {self.inner_knots}); 0 = not used')
        # The library's own check: one of auto, windows, none; not with a
        # vibration_frequency, and not where no speed profile is averaged.
        smoothing_value(self.smoothing, self.vibration_frequency, self.has_inner_knots())
        if self.max_trajectory_points < 2:
            raise ValueError(f'max_trajectory_points = {self.max_trajectory_points}: must be '
                             'at least 2')
        self._validate_tool_paths()
        self._validate_torque(names)

    def validate_position_limits(self, n):
        """Raise ValueError unless the position limits have 0 or ``n`` values, low <= high."""
        for name in ('min_position', 'max_position'):
            values = getattr(self, name)
            if len(values) not in (0, n):
                raise ValueError(f'{name} needs one value per joint ({n}) or none, '
                                 f'got {len(values)}')
            for i, v in enumerate(values):
                if math.isnan(v):
                    raise ValueError(f'{name}[{i}] is nan')
        if self.min_position and self.max_position:
            for i, (low, high) in enumerate(zip(self.min_position, self.max_position)):
                if low > high:
                    raise ValueError(f'min_position[{i}] = {low} is above '
                                     f'max_position[{i}] = {high}')

    def position_limits(self):
        """Return the position limits (None where unset) and joint names as keyword arguments."""
        return {'min_position': list(self.min_position) or None,
                'max_position': list(self.max_position) or None,
                'joint_names': self.joint_names}

    def _validate_tool_paths(self):
        if self.kinematics not in KINEMATICS:
            raise ValueError(f'kinematics must be one of {list(KINEMATICS)} ("" = joint space '
                             f'only), got {show(self.kinematics)}')
        self.require_positive('link_lengths', 2)
        if self.kinematics == 'planar_3dof' and len(self.joint_names) != 3:
            raise ValueError(f'kinematics "planar_3dof" needs 3 joint_names (shoulder, elbow, '
                             f'tool), got {len(self.joint_names)}')
        for name in ('max_path_deviation', 'max_orientation_deviation'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} = {value}: must be >= 0 and finite (0 = not checked)')
        if not 0 <= self.max_inserted_waypoints <= MAX_INSERTED_WAYPOINTS:
            raise ValueError(f'max_inserted_waypoints = {self.max_inserted_waypoints}: must be '
                             f'in [0, {MAX_INSERTED_WAYPOINTS}]')
        self._validate_tool_speeds()

    def _validate_tool_speeds(self):
        """
        Refuse a tool speed limit that is not a finite value >= 0, or that could never apply.

        A limit (non-zero) is only held by the 'tool lines' construction of
        method 555 with timing "optimal" and inner knots, and only on
        tool_waypoints requests, which need kinematics: anywhere else it
        would be silently ignored, so it is refused with the reason (like
        ``vibration_frequency``).  Joint-space requests (``waypoints``) have
        no tool path and are planned without it.
        """
        for name, unit in TOOL_SPEEDS:
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f'{name} = {value}: must be >= 0 and finite ({unit}; '
                                 '0 = no limit)')
        for name, unit in TOOL_SPEEDS:
            value = getattr(self, name)
            if not value:
                continue
            if not self.has_inner_knots():
                raise ValueError(f'{name} = {value:g} {unit} needs method "555" with timing '
                                 '"optimal" and inner_knots > 0 (got method '
                                 f'{show(self.method)}, timing {show(self.timing)}, '
                                 f'inner_knots {self.inner_knots}); 0 = no limit')
            if not self.kinematics:
                raise ValueError(f'{name} = {value:g} {unit} limits the tool of tool_waypoints '
                                 'requests, which need kinematics "planar_3dof" or "model" '
                                 '(kinematics is "": joint space only, where a tool speed '
                                 'never applies); 0 = no limit')

    def _validate_torque(self, names):
        """
        Refuse unusable torque parameters, and any that would be silently ignored.

        ``max_effort``: empty or all 0 = every limit from the description;
        otherwise one value per joint, each >= 0 (0 = from the description
        for that joint, inf = no torque limit).  The payload: see
        :func:`check_payload`.  ``limit_torque`` needs kinematics "model"
        (the torques come from the description's masses and inertias).
        Without ``limit_torque``
        a max_effort or a payload would change nothing: refused.
        """
        check_payload(self.payload_mass, self.payload_center_of_mass, self.payload_inertia)
        if not (0.0 <= self.torque_headroom < MAX_TORQUE_HEADROOM):
            raise ValueError(f'torque_headroom = {self.torque_headroom}: must be in [0, '
                             f'{MAX_TORQUE_HEADROOM:g}) (the share of every torque limit left '
                             "to the controller's corrections)")
        for i, v in enumerate(self.max_effort):
            if math.isnan(v) or v < 0.0:
                raise ValueError(f'max_effort[{i}] = {v}: must be >= 0 [N m or N] (0 = from '
                                 'the robot description for that joint, inf = no torque '
                                 'limit)')
        if self.max_effort and names and len(self.max_effort) != len(names):
            raise ValueError(f'max_effort needs one value per joint ({len(names)}) of '
                             f'joint_names {show_names(names)}, got {len(self.max_effort)}: give '
                             'them all (0 = from the robot description for that joint), or '
                             '-p max_effort:=[0.0] to take every one from the description')
        if not self.limit_torque:
            for name, used in (('max_effort', any(self.max_effort)),
                               ('payload_mass', self.payload_mass > 0.0),
                               ('torque_headroom',
                                self.torque_headroom != DEFAULT_TORQUE_HEADROOM)):
                if used:
                    raise ValueError(f'{name} is set but limit_torque is false: it only '
                                     'matters to the torque limits (set limit_torque:=true, '
                                     f'or leave {name} at its default)')

    def _require_model_for_torque(self):
        """Refuse limit_torque without kinematics "model" (checked first: it says why)."""
        if self.limit_torque and self.kinematics != 'model':
            raise ValueError('limit_torque needs kinematics "model": the torques come from the '
                             "robot description's masses and inertias (kinematics is "
                             f'{show(self.kinematics)})')

    def torque_payload(self):
        """Return the payload as ArmDynamics keyword arguments (inertia None when not set)."""
        return {'payload_mass': self.payload_mass,
                'payload_center_of_mass': self.payload_center_of_mass,
                'payload_inertia': self.payload_inertia or None}

    def tool_kinematics(self):
        """Return the kinematics object of ``kinematics`` (with ``link_lengths``), or None."""
        if self.kinematics == 'planar_3dof':
            return PlanarArm(*self.link_lengths)
        return None

    def plan_inner_knots(self):
        """
        Inner knots per segment for plan(): ``inner_knots`` for 555 optimal, else 0.

        "auto" (:data:`AUTO_INNER_KNOTS`) is None, plan()'s default.
        """
        if self.method == '555' and self.timing == 'optimal':
            return None if self.inner_knots == AUTO_INNER_KNOTS else self.inner_knots
        return 0

    def has_inner_knots(self):
        """Whether plan() places inner knots: 555 optimal with ``inner_knots`` not 0."""
        return self.method == '555' and self.timing == 'optimal' and self.inner_knots != 0

    def description_limits(self):
        """Return explicit (max_velocity, max_acceleration, max_jerk) for resolve_limits."""
        return tuple(() if all(v == 0.0 for v in values) else values
                     for values in (self.max_velocity, self.max_acceleration, self.max_jerk))

    def jerk_limits(self):
        """Jerk limits for plan(): None when no joint has one, +inf for 0 entries."""
        if not any(v > 0.0 for v in self.max_jerk):
            return None
        return [v if v > 0.0 else math.inf for v in self.max_jerk]


# Payloads beyond these are typing errors, not payloads [kg, m]: refused before
# they reach the dynamics as overflowing torques.
MAX_PAYLOAD_MASS = 1e4
MAX_PAYLOAD_OFFSET = 100.0


def check_payload(mass, center, inertia):
    """
    Raise ValueError unless the payload parameters describe a rigid body (or none).

    ``mass`` [kg] finite >= 0; ``center`` 3 finite values [m] (the centre of
    mass in the tool frame); ``inertia`` none, 3 principal moments or 6
    values ``ixx iyy izz ixy ixz iyz`` [kg m^2] about the centre of mass in
    the tool frame's axes, a physical inertia (positive definite, the
    triangle inequality).  A centre of mass or an inertia without a mass
    is refused (it would change nothing).
    """
    if not (math.isfinite(mass) and mass >= 0.0):
        raise ValueError(f'payload_mass = {mass}: must be >= 0 and finite [kg] (0 = no payload)')
    if mass > MAX_PAYLOAD_MASS:
        raise ValueError(f'payload_mass = {mass:.4g} kg: above {MAX_PAYLOAD_MASS:g} kg, more '
                         'than any arm carries')
    if len(center) != 3 or not all(math.isfinite(v) for v in center):
        raise ValueError('payload_center_of_mass must be 3 finite values [m] (x, y, z in the '
                         f'tool frame), got {show(list(center))}')
    if any(abs(v) > MAX_PAYLOAD_OFFSET for v in center):
        raise ValueError(f'payload_center_of_mass {show(list(center))}: a coordinate beyond '
                         f'{MAX_PAYLOAD_OFFSET:g} m from the tool frame')
    if len(inertia) not in (0, 3, 6):
        raise ValueError('payload_inertia must be empty (a point mass), 3 principal moments or '
                         '6 values [ixx, iyy, izz, ixy, ixz, iyz] [kg m^2], got '
                         f'{len(inertia)} values')
    for name, value in (('payload_center_of_mass', any(center)),
                        ('payload_inertia', bool(inertia))):
        if value and mass == 0.0:
            raise ValueError(f'{name} is set but payload_mass is 0: it describes a payload, '
                             'which needs a mass (0 = no payload)')
    if inertia:
        payload_inertia_matrix(inertia)   # finite, positive definite, triangle inequality


def require_description_limits(name, values, names):
    """
    Check a limit array of kinematics "model" (ValueError with the reason).

    Either all zeros or empty (every limit from the robot's description), or
    one value >= 0 per joint of ``joint_names`` (0 = from the description).
    """
    for i, v in enumerate(values):
        if not (math.isfinite(v) and v >= 0.0):
            raise ValueError(f'{name}[{i}] = {v}: must be >= 0 and finite (0 = from the '
                             'robot description)')
    if any(v > 0.0 for v in values) and names and len(values) != len(names):
        raise ValueError(f'{name} needs one value per joint ({len(names)}) of joint_names '
                         f'{show_names(names)}, got {len(values)}: give them all (0 = from the '
                         f'robot description for that joint), or -p {name}:=[0.0] to take '
                         'every one from the description')
