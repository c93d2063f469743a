"""Deprecated: moved to :mod:`splines445_ros.robot.inverse_kinematics` (issue 37)."""

import warnings

from ..robot.inverse_kinematics import *  # noqa: F401,F403 - the old import path keeps working

warnings.warn('splines445_ros.arm.inverse_kinematics moved to '
              'splines445_ros.robot.inverse_kinematics', DeprecationWarning, stacklevel=2)
