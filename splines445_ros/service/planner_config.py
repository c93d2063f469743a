"""
Validated configuration of the planner node (pure Python, no rclpy).

The node's ROS parameters map one to one onto :class:`PlannerConfig`, whose
fields are planner_node's parameter table (:mod:`.parameter_table`: default,
description, "not set" value, bounds or choices; ``doc/nodes.md`` is generated
from them); every ``set_parameters`` is checked by building a new config from
the current values overlaid with the request, so a bad value is rejected with
the reason and the old configuration stays.  Also here: the limits' and the
payload's checks shared with the simulated arm (:func:`check_payload`).
"""

from dataclasses import dataclass, replace
import math
from typing import Tuple

from .parameter_table import parameter
from .request_planning import DEFAULT_MAX_TRAJECTORY_POINTS, REPLAN_MAX_DELAY
from .validated_config import ValidatedConfig
from ..planning import DEFAULT_WAYPOINT_TOLERANCE, METHODS, TIMINGS
from ..planning.plan_options import (MAX_INNER_KNOTS, MAX_TIME_OPTIMAL_WAYPOINTS,
                                     MAX_VIBRATION_FREQUENCY, MIN_VIBRATION_FREQUENCY,
                                     smoothing_value,
                                     speed_profile_value, SPEED_PROFILES)
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
# sample_period's upper bound [s]: points further apart are what output "knots"
# gives; beyond 2**31 s a stop's hold (as long as a sample period) overflowed
# its time_from_start, and the cancel was reported done while the arm ran on
# (helper-88).
MAX_SAMPLE_PERIOD = 10.0
MAX_LEAD_TIME = 10.0
# replan_lead_time's lower bound [s]: a stop (a cancel) is planned in 20-50 ms
# here (the planar arm, 2-core machine, scratch timing of plan_stop), and one
# planned after its switch time is refused while the arm runs on; at 0 every
# cancel and every preemption failed (helper-88).
MIN_LEAD_TIME = 0.05
# Values of the ``kinematics`` parameter: '' = joint space only.
KINEMATICS = ('', 'planar_3dof', 'model')
MAX_INSERTED_WAYPOINTS = 100000
# A waypoint tolerance above this [rad or m] would merge distinct taught points.
MAX_WAYPOINT_TOLERANCE = 0.1
# Values of the ``output`` parameter: a point every sample_period, or one per knot.
OUTPUTS = ('sampled', 'knots')
# Tool speed and acceleration limits of tool_waypoints requests and their units
# (0 = no limit).
TOOL_LIMITS = (('max_tool_speed', 'm/s'), ('max_tool_angular_speed', 'rad/s'),
               ('max_tool_acceleration', 'm/s²'))
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
# saturates (doc/nodes.md, "Where the constants come from").
DEFAULT_TORQUE_HEADROOM = 0.1
MAX_TORQUE_HEADROOM = 0.5
# follow_waypoints goals: the arm has settled when joint_states are this close to the
# end [rad or m] and this slow [rad/s or m/s] (joint_trajectory_controller's goal
# and stopped_velocity_tolerance), at most goal_time_tolerance after the end [s].
DEFAULT_GOAL_POSITION_TOLERANCE = 0.01
DEFAULT_GOAL_VELOCITY_TOLERANCE = 0.01
DEFAULT_GOAL_TIME_TOLERANCE = 2.0
MAX_GOAL_TIME_TOLERANCE = 3600.0
# Payloads beyond these are typing errors, not payloads [kg, m]: refused before
# they reach the dynamics as overflowing torques.
MAX_PAYLOAD_MASS = 1e4
MAX_PAYLOAD_OFFSET = 100.0


@dataclass(frozen=True)
class PlannerConfig(ValidatedConfig):
    """
    Everything the planner needs besides the request itself.

    Each field is a row of planner_node's parameter table (see
    :mod:`.parameter_table`): its default, description, declared "not set"
    value and bounds or choices, checked by :meth:`check_table`; the
    cross-field checks are :meth:`validate`'s.
    """

    joint_names: Tuple[str, ...] = parameter(
        DEFAULT_JOINTS, "Joints planned, in the order of the limit arrays. Not set (`['']`, "
        'the default): with `kinematics: model` every actuated joint of the robot, in its '
        "order; otherwise the planar arm's `[joint1, joint2, joint3]`. With `kinematics: "
        'planar_3dof` list them as shoulder, elbow, wrist: its tool kinematics takes the '
        'joints by position, so a reordered list makes the planner take the elbow for the '
        'shoulder (tool requests go elsewhere; joint requests are unaffected).',
        declared=NOT_SET_NAMES)
    max_velocity: Tuple[float, ...] = parameter(
        (PLANAR_VELOCITY,) * 3, 'Per-joint |velocity| limit [rad/s or m/s], > 0. Not set '
        '(`[0.0]`, the default): with `kinematics: model` from the description (URDF '
        '`<limit velocity>`, `joint_limits_file`), 0 entries likewise joint by joint; '
        f"otherwise {PLANAR_VELOCITY:g} for the planar arm's `joint1..3` (other joints need "
        'it set).', declared=NOT_SET_LIMITS)
    max_acceleration: Tuple[float, ...] = parameter(
        (PLANAR_ACCELERATION,) * 3, 'Per-joint |acceleration| limit [rad/s² or m/s²], > 0. '
        'Not set (`[0.0]`, the default): with `kinematics: model` from `joint_limits_file` (a '
        'URDF has none), 0 entries likewise joint by joint; otherwise '
        f"{PLANAR_ACCELERATION:g} for the planar arm's `joint1..3` (other joints need it "
        'set).', declared=NOT_SET_LIMITS)
    max_jerk: Tuple[float, ...] = parameter(
        (0.0, 0.0, 0.0), 'Per-joint |jerk| limit [rad/s³ or m/s³]; 0 = no jerk limit on that '
        'joint. Not set (`[0.0]`, the default): no jerk limit at all (with `kinematics: '
        'model`: from `joint_limits_file`, else none).', declared=NOT_SET_LIMITS)
    method: str = parameter(
        '445', '`445` (jerk-continuous, the paper: Petrinec & Kovacic; the default), `434` '
        '(Ho & Cook, the C2 baseline) or `555` (C4 quintic spline: jerk-continuous and stable '
        'on long paths). Typed as a number (`-p method:=555`) is fine.', choices=METHODS)
    timing: str = parameter(
        'uniform', '`uniform` (chord durations × one common scale factor), `optimal` '
        '(minimum total time) or `fixed` (durations from `time_from_start`).',
        choices=TIMINGS)
    sample_period: float = parameter(
        0.01, '`output: sampled`: period of the published trajectory points [s]; every '
        'knot of the plan (the waypoints among them) is a point too.',
        low=MIN_SAMPLE_PERIOD, high=MAX_SAMPLE_PERIOD, unit='s')
    start_from_current_state: bool = parameter(
        False, 'Start every trajectory from the commanded state at now + `replan_lead_time` '
        f'(continuous replanning), or up to {REPLAN_MAX_DELAY:g} s later along the running '
        'trajectory when no plan exists from that state.')
    replan_lead_time: float = parameter(
        0.2, 'How far ahead of now a replanned trajectory takes over [s]; planning must '
        'finish within it (a stop for a cancel takes 20-50 ms to plan on a 2-core machine; '
        'one planned too late is refused and the arm runs on).', low=MIN_LEAD_TIME,
        high=MAX_LEAD_TIME, unit='s')
    start_delay: float = parameter(
        0.05, 'How long after it is published a trajectory starts [s]: its `header.stamp` (a '
        'replanned one starts at its switch time instead). It must exceed delivery to the '
        'controller: one delivered later starts part-way along, on `arm_sim_node` as on '
        'joint_trajectory_controller. 0 = stamp 0, "start on receipt" (the planner then '
        'counts from publication, early by the delivery time: a later preemption or stop '
        'jumps by that).', low=0.0, high=MAX_LEAD_TIME, unit='s')
    max_trajectory_points: int = parameter(
        DEFAULT_MAX_TRAJECTORY_POINTS, 'Largest number of points a published trajectory may '
        'have (at `sample_period`, or knots); a longer one is rejected (raise `sample_period` '
        'or use `output: knots` instead). `arm_sim_node` refuses more than the default, '
        f'{DEFAULT_MAX_TRAJECTORY_POINTS}, whatever this says.', low=2)
    kinematics: str = parameter(
        '', 'Kinematics for `tool_waypoints` requests: `""` = none (joint space only: tool '
        "requests get an ERROR), `planar_3dof` = the paper's arm with `link_lengths` (needs 3 "
        'joints; elbow branch +1), `model` = a robot from its URDF or MJCF (`model_file` or '
        '`robot_description`: 6-D tool poses; `joint_names`, limits, joint ranges and '
        '`tool_frame` not set = from its description).', choices=KINEMATICS,
        choices_note='"" = joint space only')
    link_lengths: Tuple[float, ...] = parameter(
        (1.1, 0.9), 'd1, d2 of the `planar_3dof` arm [m], > 0.')
    max_path_deviation: float = parameter(
        0.0, 'Largest distance [m] of the tool from the straight lines between tool '
        'waypoints; knots are inserted until it holds (with both deviations 0: no '
        'refinement).', low=0.0, special=(0.0, 'not checked'))
    max_orientation_deviation: float = parameter(
        0.0, 'Largest deviation [rad] of the tool orientation between tool waypoints: '
        '`planar_3dof`, of the tool yaw from its linear interpolation; `kinematics: model`, '
        'the rotation angle between the tool orientation and the slerp of the two '
        "waypoints' orientations.", low=0.0, special=(0.0, 'not checked'))
    max_tool_speed: float = parameter(
        0.0, "Largest linear speed [m/s] of the tool frame's origin on `tool_waypoints` "
        'requests; 0 (the default) = no limit. Held within 0.1 % at a 1 kHz check by timing '
        'the straight lines themselves. Where that timing leaves the tool below 99 % of it '
        'although the joints could get there (and no `vibration_frequency` is set), the lines '
        "are timed again by `speed_profile: time_optimal`'s profile, kept when shorter and at "
        'the speed, and the status says so (`speed_profile_reason`). '
        'Needs `method: 555`, `timing: optimal`, `inner_knots` not 0 (auto or > 0) and a '
        '`kinematics` (`planar_3dof` or `model`): a non-zero value is refused '
        'otherwise, with the reason. Joint-space `waypoints` requests have no tool path and '
        'are planned without it.', low=0.0, unit='m/s', special=(0.0, 'no limit'))
    max_tool_angular_speed: float = parameter(
        0.0, 'Largest angular speed [rad/s] of the tool on `tool_waypoints` requests '
        '(`planar_3dof`: of its yaw); 0 (the default) = no limit. Held and refused like '
        '`max_tool_speed`.', low=0.0, unit='rad/s', special=(0.0, 'no limit'))
    max_tool_acceleration: float = parameter(
        0.0, "Largest linear acceleration [m/s²] of the tool frame's origin on "
        '`tool_waypoints` requests; 0 (the default) = no limit. A constraint of the speed '
        'profile along the lines, held at a 1 kHz check (the plan is slowed down uniformly '
        'when the check finds more). Held and refused like `max_tool_speed`; the angular '
        'acceleration is not limited.', low=0.0, unit='m/s²', special=(0.0, 'no limit'))
    max_inserted_waypoints: int = parameter(
        200, 'Most waypoints the refinement of one tool request may insert (knots, with the '
        'tool lines of 555 optimal); a request that needs more is rejected.',
        low=0, high=MAX_INSERTED_WAYPOINTS)
    max_refinement_time: float = parameter(
        30.0, 'Most time [s] the refinement of one tool request may take; a request not within '
        'its tolerances by then is rejected, saying how far it got (read between rounds, so '
        'a round can run over). The planner serves nothing else meanwhile. 0 = no limit.',
        low=0.0, unit='s', special=(0.0, 'no limit'))
    waypoint_tolerance: float = parameter(
        DEFAULT_WAYPOINT_TOLERANCE, 'Consecutive waypoints whose every joint differs by at '
        'most this [rad or m] are merged (uniform and optimal timing), and a replanning start '
        'state this close to the first waypoint replaces it; the default '
        f"{DEFAULT_WAYPOINT_TOLERANCE:g} is four times the dynamic arm's rest dead band; 0 = "
        'exact duplicates only.', low=0.0, high=MAX_WAYPOINT_TOLERANCE)
    min_position: Tuple[float, ...] = parameter(
        (), 'Per-joint lower position limit [rad or m], checked exactly on every plan, which '
        'is rejected with the joint, time and excess when it leaves them (joint requests with '
        '555 optimal and at most 30 waypoints: after other plans were tried, the knots-only '
        'optimum, the other `speed_profile` and timing `uniform`, as doc/methods.md says; see '
        '`speed_profile_reason` and `speed_profile_skipped`; a `time_optimal` plan gives way '
        'to the default plan at any size; a knots-only optimum that starts '
        'or stops a joint the wrong way past a limit first gets a knot next to each rest end, '
        'see `end_knots`, or gives way to the inner-knot plan, see `knots_only_skipped`; and '
        'a smoothed rest-to-rest 555 optimal plan that leaves them first has its knots moved '
        'within them, see `position_limit_knots`); empty (the default) = none; `-.inf` for a '
        'joint without one; integers as typed are fine.')
    max_position: Tuple[float, ...] = parameter(
        (), 'Per-joint upper position limit [rad or m], as `min_position`; `.inf` for a joint '
        'without one.')
    output: str = parameter(
        'sampled', '`sampled` (the default): a point every `sample_period`; `knots`: one '
        'point per knot of the spline, with its exact position, velocity and acceleration: '
        "joint_trajectory_controller's quintic interpolation between them reproduces the "
        'planned trajectory.', choices=OUTPUTS)
    inner_knots: int = parameter(
        AUTO_INNER_KNOTS, 'Most inner knots per segment for `method: 555` with `timing: '
        'optimal`: a C4 spline with knots between the waypoints too, about the duration of '
        f'TOPP-RA with the jerk limits held. {AUTO_INNER_KNOTS} (the default) = auto: 4, or 6 '
        'for joint-space requests with `limit_torque` and no smoothing windows (fewer on '
        'segments shorter than a few jerk ramp times a/j), and rest to rest without '
        '`limit_torque` or `vibration_frequency` up to 32 on a long segment (one every two '
        'shortest v/a of the joints) where that plan is shorter; 0 = knots at the waypoints '
        'only (longer). Ignored by other methods and timings.',
        low=0, high=MAX_INNER_KNOTS, special=(AUTO_INNER_KNOTS, 'auto'))
    vibration_frequency: float = parameter(
        0.0, "The arm's lowest structural mode [Hz], for `method: 555` with `timing: optimal` "
        'and `inner_knots` not 0 (auto or > 0; refused otherwise): the speed profile is '
        'averaged over two windows of 1/f instead of the default 0.3 s and 0.15 s, so that '
        'the plan leaves little vibration at f (2/f longer; the default windows: 0.45 s). 0 '
        '(the default) = not used: as `smoothing` says. With `speed_profile: smoothed`, '
        'rest-to-rest requests only: with a moving start or end (replanning) the profile is '
        'not averaged and the parameter changes nothing. A rest-to-rest `smoothed` plan then '
        'has its knots moved to cancel the ringing of a mode at f (damping 0.02) after the '
        'stop, each joint as far as its limits allow without a stretch and without ringing '
        "more during the motion (`residual_knots` on `~/status`): 0.02 of TOPP-RA's ringing "
        'at 4 Hz (median; 0.07-0.09 before), for 2-6 times the planning time; not with '
        '`limit_torque`. With `speed_profile: time_optimal` '
        'there are no windows: before a rest end (replanning too) the profile cancels the '
        "ringing of a mode at f (damping 0.02) after the stop, to about 0.05 of TOPP-RA's at "
        '4-8 Hz for 0.2-2 % of the duration (7-9 % of 1-2 s moves with a very high jerk '
        'limit). Narrow, as every cancellation: a mode 10 % off in frequency is left 0.4-0.8 '
        "of TOPP-RA's ringing (about what time_optimal leaves without it), where `smoothed` "
        'leaves about 0.1 of it.',
        low=MIN_VIBRATION_FREQUENCY, high=MAX_VIBRATION_FREQUENCY, special=(0.0, 'not used'),
        unit='Hz')
    smoothing: str = parameter(
        'auto', '`auto` (the default), `windows` or `none`, for `method: 555` with `timing: '
        'optimal`, `inner_knots` not 0 (auto or > 0) and no `vibration_frequency` (refused '
        'otherwise, where it would change nothing). `windows` averages the speed profile over '
        "0.3 s and 0.15 s: 0.45 s longer, and the arm's low modes (4-8 Hz) shake about half "
        "as much as with TOPP-RA; `none` does not (about TOPP-RA's duration and shaking). "
        '`auto` = `windows`, or `none` with `limit_torque: true`. Rest-to-rest requests; the '
        "tool lines of tool requests are never averaged (a refined tool path's inner-knot plan "
        'follows it).')
    speed_profile: str = parameter(
        'smoothed', '`smoothed` (the default) or `time_optimal`, for `method: 555` with '
        '`timing: optimal`. `smoothed`: the speed profile shaped by `inner_knots`, '
        '`vibration_frequency` and `smoothing` (or the knots-only optimum, when shorter). '
        '`time_optimal`: the time-optimal profile under the velocity, acceleration and jerk '
        'limits (velocity and acceleration only on joints with `max_jerk` 0), followed by a '
        'C4 spline with a knot every 15 ms or so: on the vendor arms '
        '5-7 % shorter than `smoothed`, but it shakes their low modes about 1.6 times as '
        'much (still about half as much as TOPP-RA), and it plans in 3-5 times the time. It '
        'plans joint-space `waypoints` requests (replanning from a moving state too) with at '
        'most '
        f'{MAX_TIME_OPTIMAL_WAYPOINTS} waypoints; where it finds no spline (a moving state it '
        'cannot keep, a joint reversing alone, a path nearly turning back) the plan is '
        "`smoothed`'s; where its plan "
        'leaves `min_position` / `max_position` (not where a moving end heads past a limit '
        "it sits on), `smoothed`'s or else timing `uniform`'s (not with a "
        '`vibration_frequency`, nor above 30 waypoints), whichever stays within them first; '
        'each with a warning. '
        '`smoothing` and `inner_knots` are refused with it (it would ignore them); '
        '`vibration_frequency` cancels the ringing of a mode at it after the stop. On '
        'tool_waypoints requests '
        "the tool lines' path is timed again by the "
        'same profile (tool speed and acceleration as its rows), kept when shorter and within '
        'the tolerances.', choices=SPEED_PROFILES)
    model_file: str = parameter(
        '', '`kinematics: model` (a value is refused otherwise, as for the three below): URDF '
        'or MJCF file of the robot; empty = the '
        '`robot_description` topic (std_msgs/String, reliable, transient-local).')
    tool_frame: str = parameter(
        '', '`kinematics: model`: the tool frame (URDF link, MJCF body or site) of '
        '`tool_waypoints` requests; empty (the default) = the tip of the chain, the one link '
        "rigidly attached to the last planned joint (like MoveIt's tip link); where there are "
        'several, tool requests are refused, naming them.')
    base_frame: str = parameter(
        '', '`kinematics: model`: frame of the `tool_waypoints` poses (a link or body fixed to '
        'the world); empty = the world, by either name: `world` or the URDF root link (e.g. '
        '`panda_link0`, the frame of the planned-path markers then).')
    joint_limits_file: str = parameter(
        '', "`kinematics: model`: MoveIt `joint_limits.yaml`; its limits override the URDF's "
        'velocity, explicit (non-zero) `max_*` values override both. At most 64 KiB (some '
        '380 joints). Read when set: set it again (the same path too) after editing the file.')
    limit_torque: bool = parameter(
        False, '`kinematics: model` (refused without it): keep the rigid-body torque of every '
        'planned joint, the payload included (and, with `torque_counts_friction`, the '
        "joints' damping and friction), within `max_effort`, checked every 1 ms (within "
        '0.5 %); rest to rest only. Tool requests hold it too: 555 optimal times the tool '
        'lines with the torque as one more constraint (with `max_tool_speed` / '
        '`max_tool_angular_speed` when set), the other methods and timings are refined, every '
        'plan slowed down as the torque needs. A joint '
        f'without an acceleration limit then gets {TORQUE_STAND_IN_ACCELERATION:g} rad/s²: the '
        'torque limits it.')
    max_effort: Tuple[float, ...] = parameter(
        NOT_SET_LIMITS, '`limit_torque`: per-joint torque limit [N m, or N for a slide], one '
        'value per planned joint, >= 0; 0 entries = from the robot description (as '
        '`arm_sim_node` reads it: MJCF actuator `forcerange`, `ctrlrange` × gear, URDF `<limit '
        'effort>`), `.inf` = no limit on that joint. Not set (`[0.0]`, the default): all from '
        'the description (a joint without one there is refused, naming it).',
        declared=NOT_SET_LIMITS)
    payload_mass: float = parameter(
        0.0, f'`limit_torque`: mass [kg] held by the tool frame, 0 to {MAX_PAYLOAD_MASS:g}; 0 '
        '(the default) = none. Needs a tool frame (`tool_frame`, or the tip of the chain).')
    payload_center_of_mass: Tuple[float, ...] = parameter(
        (0.0, 0.0, 0.0), "`limit_torque`: the payload's centre of mass [m], x, y, z in the "
        f'tool frame, each within ±{MAX_PAYLOAD_OFFSET:g} m.')
    payload_inertia: Tuple[float, ...] = parameter(
        (), "`limit_torque`: the payload's inertia [kg m²] about its centre of mass, in the "
        "tool frame's axes: empty (the default) = a point mass, 3 principal moments, or 6 "
        'values `[ixx, iyy, izz, ixy, ixz, iyz]`; positive definite, the triangle inequality '
        'held.')
    torque_headroom: float = parameter(
        DEFAULT_TORQUE_HEADROOM, '`limit_torque`: the share of every torque limit the plan '
        "leaves to the controller's corrections: the plan holds (1 - `torque_headroom`) × "
        '`max_effort` (`limit_torque` on the status is that, `peak_torque_ratio` is relative '
        f"to it). The default {DEFAULT_TORQUE_HEADROOM:g}: a plan that uses all of a joint's "
        'torque leaves the feedback nothing, and the motor saturates. Refused without '
        '`limit_torque` unless at its default.', low=0.0, high=MAX_TORQUE_HEADROOM,
        high_open=True, note="the share of every torque limit left to the controller's "
        'corrections')
    torque_counts_friction: bool = parameter(
        True, "`limit_torque`: the robot description's joint damping, dry friction and rotor "
        'inertia (URDF `<dynamics damping friction>`; MJCF `damping`, `frictionloss`, '
        '`armature`) count against the torque limit, as the motor gives them too (the dynamic '
        "`arm_sim_node` applies them); the friction adds to a moving joint's torque the way "
        "it moves, and is not counted on to help. False: the links' rigid-body torque alone "
        '(the plan then exceeds the limit on a damped arm by the damping). Refused without '
        '`limit_torque` unless at its default.')
    goal_position_tolerance: float = parameter(
        DEFAULT_GOAL_POSITION_TOLERANCE, '`follow_waypoints` goals: the arm has reached the '
        'end when every joint of `joint_states` is within this of it [rad or m]; a goal '
        'whose start (a tool goal: the joints of its first pose) is further than this from '
        'the arm at rest is aborted.',
        low=0.0, low_open=True)
    goal_velocity_tolerance: float = parameter(
        DEFAULT_GOAL_VELOCITY_TOLERANCE, '`follow_waypoints` goals: ... and every joint '
        'velocity of `joint_states` is within this [rad/s or m/s] '
        "(joint_trajectory_controller's `stopped_velocity_tolerance`).",
        low=0.0, low_open=True)
    goal_time_tolerance: float = parameter(
        DEFAULT_GOAL_TIME_TOLERANCE, '`follow_waypoints` goals: how long after the planned '
        'end the arm may take to settle [s]; later the goal is aborted with the remaining '
        'error.', low=0.0, high=MAX_GOAL_TIME_TOLERANCE, unit='s')

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
        if n or not model:  # with all of a model's joints: checked once it is loaded
            self.validate_position_limits(n)
        # The bounds and choices of the parameter table: method, timing,
        # sample_period, ..., torque_headroom (the fields, in order).
        self.check_table()
        if self.vibration_frequency and not self.has_inner_knots():
            raise ValueError(f'vibration_frequency = {self.vibration_frequency:g} Hz needs '
                             'method "555" with timing "optimal" and inner_knots not 0 (got '
                             f'method {show(self.method)}, timing {show(self.timing)}, '
                             f'inner_knots {self.inner_knots}); 0 = not used')
        # The library's own check: one of auto, windows, none; not with a
        # vibration_frequency, and not where no speed profile is averaged.
        smoothing_value(self.smoothing, self.vibration_frequency, self.has_inner_knots())
        self._validate_speed_profile()
        self._validate_tool_paths()
        self._validate_torque(names)

    def validate_position_limits(self, n):
        """
        Raise ValueError unless the position limits have 0 or ``n`` values, low <= high.

        A lower limit of +inf (or an upper one of -inf) leaves no position: refused.
        """
        for name, unbounded in (('min_position', -math.inf), ('max_position', math.inf)):
            values = getattr(self, name)
            if len(values) not in (0, n):
                raise ValueError(f'{name} needs one value per joint ({n}) or none, '
                                 f'got {len(values)}')
            for i, v in enumerate(values):
                if math.isnan(v):
                    raise ValueError(f'{name}[{i}] is nan')
                if v == -unbounded:
                    raise ValueError(f'{name}[{i}] = {v:g} leaves no position: use '
                                     f'{unbounded:g} for a joint without a limit')
        if self.min_position and self.max_position:
            for i, (low, high) in enumerate(zip(self.min_position, self.max_position)):
                if low > high:
                    raise ValueError(f'min_position[{i}] = {low} is above '
                                     f'max_position[{i}] = {high}')

    def _validate_speed_profile(self):
        """
        Refuse a ``speed_profile`` "time_optimal" that every request would refuse, or ignore.

        The library's check (:func:`speed_profile_value`: 555 optimal, no
        ``inner_knots`` or ``smoothing``).  Its
        profile holds the jerk limits where ``max_jerk`` gives them, and
        torque limits as its rows.
        """
        speed_profile_value(self.speed_profile, self.method, self.timing,
                            self.inner_knots != AUTO_INNER_KNOTS, self.smoothing)

    def _validate_tool_paths(self):
        self.require_positive('link_lengths', 2)
        if self.kinematics == 'planar_3dof' and len(self.joint_names) != 3:
            raise ValueError(f'kinematics "planar_3dof" needs 3 joint_names (shoulder, elbow, '
                             f'tool), got {len(self.joint_names)}')
        self._validate_tool_speeds()

    def _validate_tool_speeds(self):
        """
        Refuse a tool speed or acceleration limit that could never apply (the table checks >= 0).

        A limit (non-zero) is only held by the 'tool lines' construction of
        method 555 with timing "optimal" and inner knots, and only on
        tool_waypoints requests, which need kinematics: anywhere else it
        would be silently ignored, so it is refused with the reason (like
        ``vibration_frequency``).  Joint-space requests (``waypoints``) have
        no tool path and are planned without it.
        """
        for name, unit in TOOL_LIMITS:
            value = getattr(self, name)
            if not value:
                continue
            if not self.has_inner_knots():
                raise ValueError(f'{name} = {value:g} {unit} needs method "555" with timing '
                                 '"optimal" and inner_knots not 0 (got method '
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
                                self.torque_headroom != DEFAULT_TORQUE_HEADROOM),
                               ('torque_counts_friction', not self.torque_counts_friction)):
                if used:
                    raise ValueError(f'{name} is set but limit_torque is false: it only '
                                     'matters to the torque limits (set limit_torque:=true, '
                                     f'or leave {name} at its default)')

    def _require_model_for_torque(self):
        """
        Refuse limit_torque, and the robot's files and frames, without kinematics "model".

        Checked first: it says why.  ``model_file``, ``tool_frame``,
        ``base_frame`` and ``joint_limits_file`` mean nothing to the other
        kinematics, and would be ignored silently (helper-36: a
        ``joint_limits_file`` of ``/dev/zero`` was accepted).
        """
        if self.limit_torque and self.kinematics != 'model':
            raise ValueError('limit_torque needs kinematics "model": the torques come from the '
                             "robot description's masses and inertias (kinematics is "
                             f'{show(self.kinematics)})')
        if self.kinematics != 'model':
            for name in ('model_file', 'tool_frame', 'base_frame', 'joint_limits_file'):
                if getattr(self, name):
                    raise ValueError(f'{name} is set but kinematics is '
                                     f'{show(self.kinematics)}: it only matters to kinematics '
                                     f'"model" (set kinematics:=model with it, in one '
                                     f'set_parameters_atomically, or leave {name} empty)')

    def dynamics_arguments(self):
        """Return the payload and what else counts as ArmDynamics keyword arguments."""
        return {'payload_mass': self.payload_mass,
                'payload_center_of_mass': self.payload_center_of_mass,
                'payload_inertia': self.payload_inertia or None,
                'include_damping': self.torque_counts_friction}

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

    def unused(self):
        """
        Values no request could use in the current mode (:meth:`ValidatedConfig.unused`).

        Not ``sample_period`` with ``output: knots`` nor ``inner_knots``
        outside 555 optimal: a goal's overrides may change ``output``,
        ``method`` or ``timing``, and stops and holds last ``sample_period``
        when it is above 1 s.  ``kinematics`` is the node's alone.
        """
        unused = self._unused_where(
            ('link_lengths',), self.kinematics != 'planar_3dof',
            f"they are the planar_3dof arm's (kinematics {show(self.kinematics)})")
        unused.update(self._unused_where(
            ('max_path_deviation', 'max_orientation_deviation', 'max_inserted_waypoints',
             'max_refinement_time'), not self.kinematics,
            'they bound tool_waypoints requests, which kinematics "" (joint space only) '
            'refuses'))
        return unused

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
