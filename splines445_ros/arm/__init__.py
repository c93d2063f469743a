"""
Deprecated: the old home of the robot side, split into rooms (issue 37).

``splines445_ros.arm`` moved to :mod:`splines445_ros.robot` (description,
kinematics, IK, limits, dynamics, the paper's arm), :mod:`splines445_ros.sim`
(the simulated arm, playback) and :mod:`splines445_ros.cartesian` (tool
paths).  The modules the documentation showed (``dynamics``,
``inverse_kinematics``, ``kinematics``, ``robot_model``, ``tool_paths``) are
re-exported here with a DeprecationWarning for one release.

May import: :mod:`splines445_ros.planning`, :mod:`splines445_ros.robot`,
:mod:`splines445_ros.sim` and :mod:`splines445_ros.cartesian` (re-exports only;
``test/test_layout.py`` checks this).
"""
