"""
The simulated arm, pure Python: MuJoCo dynamics, its joint controller, playback.

Lives here: the dynamic arm (the paper's planar arm as built-in MJCF, or a
user's model) under a PD + inverse-dynamics feed-forward controller with
torque limits and tracking metrics, the gains of a model's drives from its
inertia (:mod:`model_drives`), and the playback of a sampled trajectory
the way joint_trajectory_controller interpolates it.

May import: numpy/scipy, mujoco, :mod:`splines445_ros.planning` and
:mod:`splines445_ros.robot`.  Never rclpy or ROS message packages, never
:mod:`~splines445_ros.cartesian`, :mod:`~splines445_ros.service`,
:mod:`~splines445_ros.nodes` or :mod:`~splines445_ros.tools`
(``test/test_layout.py`` checks this).
"""
