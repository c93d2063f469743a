"""Deprecated: moved to :mod:`splines445_ros.cartesian.tool_paths` (issue 37)."""

import warnings

from ..cartesian.path_deviation import *  # noqa: F401,F403 - the old import path keeps working
from ..cartesian.tool_paths import *  # noqa: F401,F403

warnings.warn('splines445_ros.arm.tool_paths moved to '
              'splines445_ros.cartesian.tool_paths', DeprecationWarning, stacklevel=2)
