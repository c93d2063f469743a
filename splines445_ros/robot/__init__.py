"""
The robot, pure Python: its description, frames, kinematics, IK, limits and dynamics.

Lives here: the robot model loaded from a URDF or MJCF (MuJoCo compiles it),
the tip of the chain, the kinematics of a tool frame and its inverse, the
paper's planar 3-DOF arm (Section III) and its triangle example, rotations,
a MoveIt ``joint_limits.yaml``, the drives' effort limits, the rigid-body
inverse dynamics with a payload, and the bounded reading of users' files.

May import: numpy/scipy, mujoco and :mod:`splines445_ros.planning`.  Never rclpy
or ROS message packages, never :mod:`~splines445_ros.cartesian`,
:mod:`~splines445_ros.sim`, :mod:`~splines445_ros.service`,
:mod:`~splines445_ros.nodes` or :mod:`~splines445_ros.tools`
(``test/test_layout.py`` checks this).
"""
