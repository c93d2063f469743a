"""arm_sim_node plays trajectories on the node's clock: with use_sim_time, on /clock."""

import numpy as np
from sim_clock import ClockDriver
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.tools.in_process import LocalRos, overrides, stamp_ns
from trajectory_msgs.msg import JointTrajectoryPoint

GOAL = [1.0, 2.0, 3.0]


def test_arm_follows_simulated_time():
    with LocalRos() as ros:
        ros.add(ArmSimNode(context=ros.context, parameter_overrides=overrides(
            {'use_sim_time': True, 'publish_rate': 50.0})))
        driver = ClockDriver(ros)
        states, set_clock = driver.states, driver.set_clock
        set_clock(100.0)
        point = JointTrajectoryPoint(positions=GOAL)
        point.time_from_start.sec = 1
        driver.send(['joint1', 'joint2', 'joint3'], point)
        ros.spin_for(0.2)  # wall time only (the arm has the trajectory: send waited)
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
