"""
The nodes' logic without ROS: validated configs and the planning of requests.

Lives here: the frozen, validated configuration dataclasses of both nodes,
whose fields are the parameter tables (``parameter_table``: each parameter
declared once, its descriptor, checks and doc row generated), the robot
set-up of ``kinematics: model``, the simulated arm's model set-up, and
everything the planner does between a parsed request and a trajectory
to publish (replanning from a running trajectory, stops, the requests of the
plan service and the follow_waypoints action), so it is testable without ROS.

May import: numpy/scipy, :mod:`splines445_ros.planning`,
:mod:`splines445_ros.robot`, :mod:`splines445_ros.cartesian` and
:mod:`splines445_ros.sim`.  Never rclpy or ROS message packages, never
:mod:`~splines445_ros.nodes` or :mod:`~splines445_ros.tools`
(``test/test_layout.py`` checks this).
"""
