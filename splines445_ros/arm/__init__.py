"""
The arm, pure Python: kinematics, the paper's example, playback, MuJoCo dynamics.

Lives here: what describes or moves the arm itself without ROS, i.e. the
paper's planar 3-DOF kinematics (Section III), its triangle example, the
playback of a sampled trajectory the way joint_trajectory_controller
interpolates it, and the dynamic arm: the MuJoCo model (built-in MJCF or a
user's file) with its joint controller and tracking metrics.

May import: numpy/scipy, mujoco and :mod:`splines445_ros.planning`.  Never rclpy or
ROS message packages, never :mod:`splines445_ros.nodes` or
:mod:`splines445_ros.tools` (``test/test_layout.py`` checks this).
"""
