"""arm_sim_node plays trajectories on the node's clock: with use_sim_time, on /clock."""

from builtin_interfaces.msg import Time as TimeMsg
import numpy as np
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from splines445_ros.nodes import topics
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.tools.in_process import LocalRos, overrides, stamp_ns
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

GOAL = [1.0, 2.0, 3.0]


def test_arm_follows_simulated_time():
    with LocalRos() as ros:
        ros.add(ArmSimNode(context=ros.context, parameter_overrides=overrides(
            {'use_sim_time': True, 'publish_rate': 50.0})))
        client = ros.add(Node('clock_driver', context=ros.context))
        clock = client.create_publisher(Clock, '/clock', 10)
        trajectories = client.create_publisher(JointTrajectory, topics.JOINT_TRAJECTORY,
                                               topics.LATCHED)
        states = []
        client.create_subscription(JointState, topics.JOINT_STATES, states.append,
                                   topics.STATE_QOS)

        def set_clock(seconds):
            clock.publish(Clock(clock=TimeMsg(sec=int(seconds),
                                              nanosec=int(round(seconds % 1 * 1e9)))))
            ros.spin_for(0.3)

        assert ros.spin_until(lambda: clock.get_subscription_count()
                              and trajectories.get_subscription_count(), 3.0)
        set_clock(100.0)
        msg = JointTrajectory(joint_names=['joint1', 'joint2', 'joint3'])
        point = JointTrajectoryPoint(positions=GOAL)
        point.time_from_start.sec = 1
        msg.points = [point]
        trajectories.publish(msg)
        ros.spin_for(0.3)  # wall time only
        # Wall time passes, simulated time does not: the arm has not moved.
        np.testing.assert_allclose(states[-1].position, 0.0, atol=1e-12)
        set_clock(100.5)
        halfway = [s for s in states if stamp_ns(s) == 100_500_000_000]
        assert halfway, [stamp_ns(s) for s in states[-5:]]
        # Positions only: linear interpolation from the start state, half-way at 0.5 s.
        np.testing.assert_allclose(halfway[-1].position, 0.5 * np.array(GOAL), atol=1e-9)
        set_clock(101.5)
        assert stamp_ns(states[-1]) == 101_500_000_000
        np.testing.assert_allclose(states[-1].position, GOAL, atol=1e-12)
