"""
The planar arm, pure Python: kinematics, the paper's example, trajectory playback.

Lives here: what describes or moves the arm itself without ROS, i.e. the
paper's planar 3-DOF kinematics (Section III), its triangle example and the
playback of a sampled trajectory the way joint_trajectory_controller
interpolates it.

May import: numpy/scipy and :mod:`splines445_ros.planning`.  Never rclpy or
ROS message packages, never :mod:`splines445_ros.nodes` or
:mod:`splines445_ros.tools` (``test/test_layout.py`` checks this).
"""
