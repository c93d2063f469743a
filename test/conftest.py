"""
Test set-up shared by every test module.

* The test folders mirror the package's rooms, as toppra's tests mirror its
  packages: ``planning/`` (with a folder per room of ``planning``),
  ``robot/``, ``cartesian/``, ``sim/``, ``service/``, ``nodes/``,
  ``tools/``; the checks of the whole tree (lint, docs, layout)
  and the helpers stay at the top.

* DDS discovery stays on this machine (ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST)
  and every test process reserves a ROS_DOMAIN_ID of its own unless one is
  set (``splines445_ros.tools.local_dds``), so parallel runs never see each
  other.  Both are set before rclpy is imported.
* Hypothesis: the default profile has moderate example counts and is
  derandomized (each test draws the same examples on every run), so
  ``make test`` and CI are reproducible and a red run means a change broke
  something.  SPLINES445_HYPOTHESIS_PROFILE=long draws fresh random
  examples on every run, 2000 per test or 30 times a test's own count
  (example_counts.py): use it to hunt for new failures.
"""

import os
import sys

# The tests live in folders that mirror the package's rooms (planning/, robot/, ...);
# their shared helpers (file_tree, reference_spline, ...) stay here, and a test that
# builds on another room's test module imports it whichever folder runs first.
_HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [_HERE] + sorted(
    folder for folder, _, _ in os.walk(_HERE)
    if folder != _HERE and not any(
        part.startswith(('.', '_')) for part in os.path.relpath(folder, _HERE).split(os.sep)))

from splines445_ros.tools.local_dds import keep_dds_local  # noqa: E402, I100 (no rclpy)

keep_dds_local()

from hypothesis import HealthCheck, settings  # noqa: E402, I100, I202

settings.register_profile(
    'default', max_examples=60, deadline=None, derandomize=True,
    suppress_health_check=[HealthCheck.too_slow])
settings.register_profile(
    'long', max_examples=2000, deadline=None,
    suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get('SPLINES445_HYPOTHESIS_PROFILE', 'default'))
