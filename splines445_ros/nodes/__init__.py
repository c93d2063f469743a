"""
The two ROS 2 nodes and their glue: thin adapters around the pure core.

Lives here: ``planner_node`` and ``arm_sim_node``, their validated config
dataclasses and parameter binding, topic names and QoS, message conversions,
status reports and the shared ``main()``.

May import: rclpy and ROS messages, :mod:`splines445_ros.planning` and
:mod:`splines445_ros.arm`.  Never :mod:`splines445_ros.tools`
(``test/test_layout.py`` checks this).
"""
