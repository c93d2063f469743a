"""
Planning with ``kinematics: model``: a robot description in, 6-D tool paths out (no rclpy).

The planner node keeps one :class:`RobotSetup`, built by :func:`build_robot_setup`
from its config and the robot description (``model_file``, else the latest
``robot_description`` string): the compiled model, the tool kinematics of
``tool_frame`` in ``base_frame``, the joint limits in use (explicit
parameters over ``joint_limits_file`` over the URDF, see
:mod:`splines445_ros.arm.joint_limits_file`) and the *effective* planner
config, with ``joint_names``, the limit arrays and the position limits
(``min_position``/``max_position`` when set, else the model's joint
ranges) filled in, which every
other planning path of the node uses unchanged.  Building raises ValueError
with the reason and leaves nothing half-done, so the node can keep its last
good setup.
"""

from dataclasses import dataclass, replace
import math

import numpy as np

from .request_planning import plan_tool_poses
from ..arm.inverse_kinematics import ModelKinematics
from ..arm.joint_limits_file import JointLimits, read_joint_limits_file, resolve_limits
from ..arm.robot_model import load_robot_model, RobotModel


@dataclass(frozen=True)
class RobotSetup:
    """Everything ``kinematics: model`` needs, built from one config and one description."""

    robot: RobotModel
    kinematics: ModelKinematics
    limits: JointLimits
    config: object          # the effective PlannerConfig
    source: str             # 'model_file ...' or 'robot_description'

    def summary(self):
        """Return a one-line description for the status and log."""
        return (f'{self.source}: {len(self.config.joint_names)} joints '
                f'{list(self.config.joint_names)}, tool_frame {self.config.tool_frame!r} in '
                f'base_frame {self.config.base_frame or "world"!r}')


def build_robot_setup(config, description=None):
    """
    Load the robot of ``config`` (a PlannerConfig with kinematics "model").

    ``description`` is the latest ``robot_description`` string, used when
    ``model_file`` is empty.  Returns None when neither exists (waiting for
    the topic); raises ValueError with the reason otherwise.
    """
    if config.model_file:
        robot = load_robot_model(config.model_file)
        source = f'model_file {config.model_file!r}'
    elif description is not None:
        robot = load_robot_model(urdf_string=description, where='robot_description')
        source = 'robot_description'
    else:
        return None
    names = tuple(n for n in config.joint_names if n)  # [''] or [] = all actuated joints
    kinematics = ModelKinematics(robot, config.tool_frame, config.base_frame, names)
    file_limits = (read_joint_limits_file(config.joint_limits_file)
                   if config.joint_limits_file else None)
    velocity, acceleration, jerk = config.description_limits()
    limits = resolve_limits(kinematics.joint_names,
                            {j.name: j.velocity for j in kinematics.joints}, file_limits,
                            velocity, acceleration, jerk)
    # Position limits: the parameters when set, else the model's joint ranges.
    lower = config.min_position or tuple(float(j.lower) for j in kinematics.joints)
    upper = config.max_position or tuple(float(j.upper) for j in kinematics.joints)
    effective = replace(
        config, joint_names=kinematics.joint_names,
        max_velocity=tuple(float(v) for v in limits.velocity),
        max_acceleration=tuple(float(v) for v in limits.acceleration),
        max_jerk=tuple(float(v) if math.isfinite(v) else 0.0 for v in limits.jerk),
        min_position=lower, max_position=upper)
    effective.validate_position_limits(len(kinematics.joint_names))
    return RobotSetup(robot, kinematics, limits, effective, source)


def tool_poses_from_message(msg, base_frame):
    """
    Turn a ``PoseArray`` into (N, 7) rows (x, y, z, qw, qx, qy, qz) (ValueError).

    The poses must be in ``base_frame`` (an empty ``header.frame_id`` is
    taken to be): the planner does no tf lookups.
    """
    frame = msg.header.frame_id
    expected = base_frame or 'world'
    if frame and frame != expected:
        raise ValueError(f'tool_waypoints are in frame {frame!r}, but base_frame is '
                         f'{expected!r} (no tf lookup: send them in base_frame)')
    if len(msg.poses) < 2:
        raise ValueError(f'need at least 2 tool waypoints, got {len(msg.poses)}')
    rows = np.empty((len(msg.poses), 7))
    for k, pose in enumerate(msg.poses):
        p, q = pose.position, pose.orientation
        rows[k] = (p.x, p.y, p.z, q.w, q.x, q.y, q.z)
    return rows


def plan_model_tool_request(setup, rows, seed=None):
    """
    Plan tool poses ``rows`` (N, 7) with a RobotSetup; return a ToolPath (ValueError).

    ``seed`` (joint positions of ``setup.config.joint_names``, e.g. the
    latest joint_states) selects the IK branch; None = the model's default.
    Rest to rest, refined to ``max_path_deviation`` and
    ``max_orientation_deviation`` (the angle from the slerp).
    """
    kinematics = setup.kinematics
    kinematics.seed = (kinematics.robot.default_seed(kinematics.joints) if seed is None
                       else kinematics.check_seed(seed))
    return plan_tool_poses(setup.config, rows, kinematics)
