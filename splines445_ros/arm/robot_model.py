"""Deprecated: moved to :mod:`splines445_ros.robot.robot_model` (issue 37)."""

import warnings

from ..robot.robot_model import *  # noqa: F401,F403 - the old import path keeps working

warnings.warn('splines445_ros.arm.robot_model moved to '
              'splines445_ros.robot.robot_model', DeprecationWarning, stacklevel=2)
