"""
The limits along a path as constraint objects: one class per limit, one file per class.

Every limit is one of three canonical forms (``canonical_forms``, after
Pham & Pham's TOPP-RA): a bound on the squared path speed (joint velocity,
tool speed), rows linear in the path acceleration and the squared speed
(joint acceleration, tool acceleration, joint torque) or a bound on their
time derivative (joint jerk).  Each object gives its bounds on a
``GriddedPath`` and knows nothing of the solver, so the speed profiles
never ask which kind they hold; adding a limit means adding a file.
``torque`` holds the request's torque limit and its 1 kHz check along a
finished trajectory.

May import: numpy, scipy, the ``spline`` room and ``planning.validation``.
"""

from .canonical_forms import AccelerationConstraint, JerkConstraint, SpeedConstraint
from .gridded_path import GriddedPath
from .joint_acceleration import JointAcceleration
from .joint_jerk import JointJerk
from .joint_torque import GRAVITY_RTOL, GravityOverload, JointTorque, refuse_gravity_overload
from .joint_velocity import JointVelocity
from .tool_acceleration import TOOL_ACCELERATION_SIDES, ToolAcceleration
from .tool_speed import ToolSpeed

__all__ = [
    'AccelerationConstraint', 'GRAVITY_RTOL', 'GravityOverload', 'GriddedPath', 'JerkConstraint',
    'JointAcceleration', 'JointJerk', 'JointTorque', 'JointVelocity', 'refuse_gravity_overload',
    'SpeedConstraint', 'TOOL_ACCELERATION_SIDES', 'ToolAcceleration', 'ToolSpeed',
]
