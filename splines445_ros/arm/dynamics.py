"""Deprecated: moved to :mod:`splines445_ros.robot.dynamics` (issue 37)."""

import warnings

from ..robot.dynamics import *  # noqa: F401,F403 - the old import path keeps working

warnings.warn('splines445_ros.arm.dynamics moved to '
              'splines445_ros.robot.dynamics', DeprecationWarning, stacklevel=2)
