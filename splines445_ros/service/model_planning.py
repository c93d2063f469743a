"""
Planning with ``kinematics: model``: a robot description in, 6-D tool paths out (no rclpy).

The planner node keeps one :class:`RobotSetup`, built by :func:`build_robot_setup`
from its config and the robot description (``model_file``, else the latest
``robot_description`` string): the compiled model, the tool kinematics of
``tool_frame`` in ``base_frame``, the joint limits in use (explicit
parameters over ``joint_limits_file`` over the URDF, see
:mod:`splines445_ros.robot.joint_limits_file`) and the *effective* planner
config, with ``joint_names``, the limit arrays and the position limits
(``min_position``/``max_position`` when set, else the model's joint
ranges) filled in, which every
other planning path of the node uses unchanged.  Building raises ValueError
with the reason and leaves nothing half-done, so the node can keep its last
good setup.

With ``limit_torque`` the setup also holds a :class:`TorqueSetup`: the
torque limit of every planned joint (``max_effort``, 0 entries from the
description as the simulated arm reads it) and the arm's inverse dynamics
with the payload (:class:`~splines445_ros.robot.dynamics.ArmDynamics`), built
once per robot, joint set, tool frame and payload, never per request.  A
joint without an acceleration limit then gets
:data:`~.planner_config.TORQUE_STAND_IN_ACCELERATION`: the torque limits it.
"""

from dataclasses import dataclass, replace
import math
from typing import Optional, Tuple

import numpy as np

from .interface_requests import check_request_size
from .planner_config import TORQUE_STAND_IN_ACCELERATION
from .request_planning import plan_tool_poses, TorqueOptions
from ..robot.chain_tip import chain_tips
from ..robot.dynamics import ArmDynamics
from ..robot.inverse_kinematics import ModelKinematics
from ..robot.joint_limits_file import read_joint_limits_file, resolve_limits, ResolvedLimits
from ..robot.robot_model import load_robot_model, model_file_where, RobotModel
from ..robot.torque_limits import model_torque_limits
from ..robot.user_text import show, show_names

# The parameters a RobotSetup is built from: a change to any other one (method,
# timing, ...) never rebuilds the robot.
ROBOT_FIELDS = ('kinematics', 'model_file', 'tool_frame', 'base_frame', 'joint_names',
                'max_velocity', 'max_acceleration', 'max_jerk', 'joint_limits_file',
                'min_position', 'max_position', 'limit_torque', 'max_effort',
                'payload_mass', 'payload_center_of_mass', 'payload_inertia',
                'torque_counts_friction')
# The fields a torque setup is built from: planning with another one's would
# hold the wrong limits or payload.
TORQUE_FIELDS = ('limit_torque', 'max_effort', 'payload_mass', 'payload_center_of_mass',
                 'payload_inertia', 'tool_frame', 'torque_counts_friction')
# Source of an acceleration limit that limit_torque stood in for (ResolvedLimits.report).
STAND_IN = 'limit_torque'
# Why a request cannot be planned while kinematics "model" waits for its robot.
NO_ROBOT_YET = ('kinematics "model" has no robot yet: set model_file or publish '
                'robot_description')


def robot_fields(config):
    """Return the values of ``config`` that its RobotSetup depends on."""
    return tuple(getattr(config, name) for name in ROBOT_FIELDS)


@dataclass(frozen=True)
class TorqueSetup:
    """The torque limits of ``limit_torque`` and the dynamics that gives the torques."""

    max_torque: np.ndarray       # (n,) [N m or N]; inf = no limit
    sources: Tuple[str, ...]     # per joint: 'max_effort', or where the description has it
    dynamics: ArmDynamics        # with the payload; not thread-safe: the planning worker's

    def options(self, headroom=0.0):
        """
        Return the :class:`~.request_planning.TorqueOptions` of a request.

        The limits less the share ``headroom`` (``torque_headroom``) left to
        the controller's corrections; the dynamics gives its torques and its
        gravity pass.
        """
        return TorqueOptions(self.max_torque * (1.0 - headroom), self.dynamics)

    def report(self, joint_names):
        """Return status values: the torque limits with their sources, and the payload."""
        dynamics = self.dynamics
        values = {'limit_torque_sources': ', '.join(
            f'{name}={limit:.6g} ({source})'
            for name, limit, source in zip(joint_names, self.max_torque, self.sources))}
        if dynamics.payload_mass > 0.0:
            center = ', '.join(f'{v:.6g}' for v in dynamics.payload_center_of_mass)
            values['payload'] = (f'{dynamics.payload_mass:.6g} kg at [{center}] m in '
                                 f'{dynamics.tool_frame}')
        if dynamics.include_damping:
            counted = [f'{name}={d:.6g}/{f:.6g}/{a:.6g}' for name, d, f, a in zip(
                joint_names, *dynamics.passive()) if d or f or a]
            values['torque_counts_friction'] = (
                'damping [N m s/rad] / friction [N m] / armature [kg m^2]: '
                + (', '.join(counted) if counted else 'none in the description'))
        else:
            values['torque_counts_friction'] = ('false: the rigid-body torque alone (the '
                                                "description's damping and friction not "
                                                'counted)')
        return values


@dataclass(frozen=True)
class RobotSetup:
    """Everything ``kinematics: model`` needs, built from one config and one description."""

    robot: RobotModel
    kinematics: Optional[ModelKinematics]  # None when the tool frame is not known
    limits: ResolvedLimits
    config: object          # the effective PlannerConfig it was built from
    source: str             # 'model_file ...' or 'robot_description'
    tool_frame: str         # in use: tool_frame, else the tip of the chain; '' = none
    tool_problem: str = ''  # why tool requests cannot be planned (tool_frame == '')
    torque: Optional[TorqueSetup] = None  # limit_torque: limits and dynamics

    def summary(self):
        """Return a one-line description for the status and log."""
        names = self.config.joint_names
        if self.tool_frame and not self.config.tool_frame:
            tool = f'tool_frame {self.tool_frame!r} (the tip of the chain)'
        elif self.tool_frame:
            tool = f'tool_frame {self.tool_frame!r}'
        else:
            tool = f'no tool frame ({self.tool_problem})'
        torque = ''
        if self.torque is not None:
            mass = self.torque.dynamics.payload_mass
            torque = ', torque limited' + (f' with a {mass:g} kg payload' if mass else '')
        return (f'{self.source}: {len(names)} joints {show_names(names)}, {tool} in base_frame '
                f'{self.config.base_frame or "world"!r}{torque}')

    def torque_options(self, config):
        """
        Return the :class:`~.request_planning.TorqueOptions` under ``config``, or None.

        None without ``limit_torque``.  ValueError when ``config`` limits the
        torque and this setup (built for another config, its new description
        still compiling) does not.
        """
        if not config.limit_torque:
            return None
        stale = any(getattr(self.config, name) != getattr(config, name)
                    for name in TORQUE_FIELDS)
        if self.torque is None or stale:
            raise ValueError('limit_torque: the robot is still being set up for the torque '
                             'parameters in force (its description is compiling); send the '
                             'request again')
        return self.torque.options(config.torque_headroom)

    def effective(self, config):
        """
        Return ``config`` with the robot's joint names and limits filled in.

        ``config`` differs from the one the setup was built from in other
        parameters only (see :data:`ROBOT_FIELDS`): the request's method,
        timing and so on.
        """
        built = self.config
        return replace(config, joint_names=built.joint_names, max_velocity=built.max_velocity,
                       max_acceleration=built.max_acceleration, max_jerk=built.max_jerk,
                       min_position=built.min_position, max_position=built.max_position,
                       tool_frame=self.tool_frame)


def description_source(config, description=None):
    """
    Return what the robot of ``config`` is loaded from, or None while there is none.

    ``('model_file', path)`` or ``('robot_description', text)``: two
    configs with the same source share one compiled model.
    """
    if config.model_file:
        return ('model_file', config.model_file)
    if description is not None:
        return ('robot_description', description)
    return None


def load_model(source):
    """Compile the robot of a :func:`description_source` (ValueError): the slow step."""
    kind, value = source
    if kind == 'model_file':
        return load_robot_model(value)
    return load_robot_model(urdf_string=value, where='robot_description')


def build_robot_setup(config, description=None, robot=None):
    """
    Set up the robot of ``config`` (a PlannerConfig with kinematics "model").

    ``robot`` is the compiled model of ``config``'s :func:`description_source`
    when the caller has it (then nothing is compiled: this is quick);
    otherwise it is loaded from ``model_file``, else from ``description``, the
    latest ``robot_description`` string.  Returns None when there is neither
    (waiting for the topic); raises ValueError with the reason otherwise.
    """
    source = description_source(config, description)
    if source is None:
        return None
    if robot is None:
        robot = load_model(source)
    where = (model_file_where(config.model_file) if source[0] == 'model_file'
             else 'robot_description')
    names = tuple(n for n in config.joint_names if n)  # [''] or [] = all actuated joints
    joints = robot.select(names)
    if not joints:
        raise ValueError(f'{where} has no actuated (hinge or slide) joints')
    tool_frame, problem = config.tool_frame, ''
    if not tool_frame:
        tips, why = chain_tips(robot, joints)
        if len(tips) == 1:
            tool_frame = tips[0]
        elif tips:
            problem = (f'tool_frame is not set and the chain ends in {len(tips)} links: '
                       f'{show_names(tips)}; '
                       'set -p tool_frame:=<one of them> (or any link, body or site)')
        else:
            problem = f'tool_frame is not set and there is no tip: {why}'
    kinematics = None
    if tool_frame:
        kinematics = ModelKinematics(robot, tool_frame, config.base_frame,
                                     tuple(j.name for j in joints))
    joint_names = tuple(j.name for j in joints)
    file_limits = (read_joint_limits_file(config.joint_limits_file)
                   if config.joint_limits_file else None)
    velocity, acceleration, jerk = config.description_limits()
    stand_in = ()
    if config.limit_torque:
        acceleration, stand_in = _stand_in_accelerations(joint_names, acceleration,
                                                         file_limits)
    limits = resolve_limits(joint_names, {j.name: j.velocity for j in joints}, file_limits,
                            velocity, acceleration, jerk, known_joints=robot.all_joint_names)
    if any(stand_in):
        sources = tuple(STAND_IN if s else source
                        for s, source in zip(stand_in, limits.sources['acceleration']))
        limits = replace(limits, sources=dict(limits.sources, acceleration=sources))
    torque = (build_torque_setup(config, robot, joints, tool_frame, problem)
              if config.limit_torque else None)
    # Position limits: the parameters when set, else the model's joint ranges.
    lower = config.min_position or tuple(float(j.lower) for j in joints)
    upper = config.max_position or tuple(float(j.upper) for j in joints)
    effective = replace(
        config, joint_names=joint_names,
        max_velocity=tuple(float(v) for v in limits.velocity),
        max_acceleration=tuple(float(v) for v in limits.acceleration),
        max_jerk=tuple(float(v) if math.isfinite(v) else 0.0 for v in limits.jerk),
        min_position=lower, max_position=upper)
    effective.validate_position_limits(len(joint_names))
    source_text = where if source[0] == 'robot_description' else model_file_where(source[1])
    return RobotSetup(robot, kinematics, limits, effective, source_text, tool_frame, problem,
                      torque)


def _stand_in_accelerations(joint_names, explicit, file_limits):
    """
    Return (max_acceleration for resolve_limits, per joint True where the stand-in is used).

    A joint whose acceleration limit is neither given (non-zero entry of
    ``explicit``) nor in the joint_limits_file gets
    :data:`TORQUE_STAND_IN_ACCELERATION`.  ``explicit`` of another length
    is returned as it is, for resolve_limits to refuse.
    """
    n = len(joint_names)
    if len(explicit) not in (0, n):
        return explicit, ()
    values = list(explicit) or [0.0] * n
    missing = tuple(not values[i] and (file_limits or {}).get(name, {}).get('acceleration')
                    is None for i, name in enumerate(joint_names))
    return (tuple(TORQUE_STAND_IN_ACCELERATION if m else v for m, v in zip(missing, values)),
            missing)


def build_torque_setup(config, robot, joints, tool_frame, tool_problem=''):
    """
    Return the :class:`TorqueSetup` of ``config`` for ``joints`` of ``robot`` (ValueError).

    ``max_effort``: empty (all from the description) or one value per
    joint, 0 = from the description (an MJCF actuator's forcerange, its
    ctrlrange times the gear, the joint's actuatorfrcrange or URDF
    ``<limit effort>``, as the simulated arm reads them).  The payload is
    held by ``tool_frame``; a payload without one is refused, with
    ``tool_problem`` (why there is none).
    """
    names = tuple(j.name for j in joints)
    n = len(names)
    if config.payload_mass > 0.0 and not tool_frame:
        raise ValueError(f'payload_mass = {config.payload_mass:g} kg needs the tool frame that '
                         f'holds the payload: {tool_problem or "set tool_frame"}')
    explicit = np.array(config.max_effort or (0.0,) * n, dtype=float)
    if explicit.size != n:
        raise ValueError(f'max_effort needs one value per joint ({n}) of {show_names(names)}, got '
                         f'{explicit.size}: give them all (0 = from the robot description for '
                         'that joint), or -p max_effort:=[0.0] to take every one from it')
    limits, sources = explicit.copy(), ['max_effort'] * n
    for i, joint in enumerate(joints):
        if explicit[i] > 0.0:
            continue
        try:
            value, kind = model_torque_limits(robot.model, [joint.joint_id], [joint.name])
        except ValueError:
            raise ValueError(
                f'limit_torque: joint {show(joint.name)} has no torque limit in the robot '
                'description (no URDF <limit effort>, MJCF actuator forcerange or ctrlrange, '
                f'or actuatorfrcrange): set max_effort, one value per joint of '
                f'{show_names(names)} (0 = from the description, inf = no limit)') from None
        limits[i], sources[i] = value[0], kind[0]
    dynamics = ArmDynamics(robot, names, tool_frame, **config.dynamics_arguments())
    return TorqueSetup(limits, tuple(sources), dynamics)


def tool_poses_from_message(msg, base_frame, root_link=None):
    """
    Turn a ``PoseArray`` into (N, 7) rows (x, y, z, qw, qx, qy, qz) (ValueError).

    The poses must be in ``base_frame`` (an empty ``header.frame_id`` is
    taken to be): the planner does no tf lookups.  With ``base_frame`` empty
    (the model's world) ``world`` and the URDF's ``root_link`` (the same
    frame, :attr:`RobotModel.root_link`, as TF names it) are both taken.
    """
    frame = msg.header.frame_id
    expected = (base_frame,) if base_frame else ('world',) + ((root_link,) if root_link else ())
    if frame and frame not in expected:
        shown = (f'{expected[0]!r}' if base_frame else
                 'empty (the world: ' + ' or '.join(repr(e) for e in expected) + ')')
        raise ValueError(f'tool_waypoints are in frame {frame!r}, but base_frame is {shown} '
                         '(no tf lookup: send them in base_frame)')
    check_request_size(len(msg.poses), 'tool_waypoints')
    if len(msg.poses) < 2:
        raise ValueError(f'need at least 2 tool waypoints, got {len(msg.poses)}')
    rows = np.empty((len(msg.poses), 7))
    for k, pose in enumerate(msg.poses):
        p, q = pose.position, pose.orientation
        rows[k] = (p.x, p.y, p.z, q.w, q.x, q.y, q.z)
    return rows


def plan_model_tool_request(setup, rows, seed=None, config=None, torque=None):
    """
    Plan tool poses ``rows`` (N, 7) with a RobotSetup; return a ToolPath (ValueError).

    ``seed`` (joint positions of ``setup.config.joint_names``, e.g. the
    latest joint_states) selects the IK branch; None = the model's default.
    Rest to rest, refined to ``max_path_deviation`` and
    ``max_orientation_deviation`` (the angle from the slerp) of ``config``
    (the node's current PlannerConfig; default: the one the setup was built from).
    ``torque``: the :meth:`RobotSetup.torque_options` the caller
    took already, from the user's config (None: taken here from
    ``config``).  Not from ``effective(config)``: that one names the chain
    tip as its tool frame where the user left it empty, and the setup
    would call itself stale.
    """
    kinematics = setup.kinematics
    if kinematics is None:
        raise ValueError(f'tool requests need a tool frame: {setup.tool_problem}')
    kinematics.seed = (kinematics.robot.default_seed(kinematics.joints) if seed is None
                       else kinematics.check_seed(seed))
    config = config or setup.config
    if torque is None:
        torque = setup.torque_options(config)
    return plan_tool_poses(setup.effective(config), rows, kinematics, torque)
