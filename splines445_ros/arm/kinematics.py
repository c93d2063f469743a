"""Deprecated: moved to :mod:`splines445_ros.robot.kinematics` (issue 37)."""

import warnings

from ..robot.kinematics import *  # noqa: F401,F403 - the old import path keeps working

warnings.warn('splines445_ros.arm.kinematics moved to '
              'splines445_ros.robot.kinematics', DeprecationWarning, stacklevel=2)
