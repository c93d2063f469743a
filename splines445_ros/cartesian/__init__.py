"""
Tool paths, pure Python: joint trajectories whose tool follows straight lines.

Lives here: the bounded-deviation refinement of a tool path (Taylor's
method), the measurement of its deviation, the tool lines timed along their
own inverse kinematics within tool speed and acceleration limits, the
kinematics protocol they are planned with, and the one-dimensional search
they share.

May import: numpy/scipy, :mod:`splines445_ros.planning` and
:mod:`splines445_ros.robot`.  Never rclpy or ROS message packages, never
:mod:`~splines445_ros.sim`, :mod:`~splines445_ros.service`,
:mod:`~splines445_ros.nodes` or :mod:`~splines445_ros.tools`
(``test/test_layout.py`` checks this).
"""
