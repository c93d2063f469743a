"""
The two ROS 2 nodes and their glue: thin adapters around the pure core.

Lives here: ``planner_node`` and ``arm_sim_node``, their parameter binding,
the follow_waypoints action server, topic names and QoS, message conversions,
markers, status reports and the shared ``main()``; their logic without ROS is
in :mod:`splines445_ros.service`.

May import: rclpy and ROS messages, :mod:`splines445_ros.service`,
:mod:`splines445_ros.sim`, :mod:`splines445_ros.cartesian`,
:mod:`splines445_ros.robot` and :mod:`splines445_ros.planning`.  Never
:mod:`splines445_ros.tools` or the deprecated :mod:`splines445_ros.arm`
(``test/test_layout.py`` checks this).
"""
