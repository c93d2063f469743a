"""arm_sim_node plays trajectories on the node's clock: with use_sim_time, on /clock."""

from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticStatus
import numpy as np
from rosgraph_msgs.msg import Clock
from sim_clock import ClockDriver
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.tools.in_process import LocalRos, overrides, stamp_ns
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

GOAL = [1.0, 2.0, 3.0]


def test_arm_follows_simulated_time():
    with LocalRos() as ros:
        driver = simulated_arm(ros)
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


def simulated_arm(ros):
    """Add an arm on simulated time to ``ros``; return the ClockDriver of its clock."""
    ros.add(ArmSimNode(context=ros.context, parameter_overrides=overrides(
        {'use_sim_time': True, 'publish_rate': 50.0})))
    return ClockDriver(ros)


def one_second_to_goal():
    point = JointTrajectoryPoint(positions=GOAL)
    point.time_from_start.sec = 1
    return point


def reach(ros, states, seconds):
    """Spin until the arm published a state stamped exactly at ``seconds``."""
    target = int(round(seconds * 1e9))
    assert ros.spin_until(lambda: stamp_ns(states[-1]) == target, 10.0), stamp_ns(states[-1])
    return np.array(states[-1].position)


def test_a_clock_that_jumps_back_leaves_the_motion_where_it_was():
    """A simulated clock restarting mid-trajectory: the arm goes on, it does not jump back."""
    with LocalRos() as ros:
        driver = simulated_arm(ros)
        driver.set_clock(100.0)
        driver.send(['joint1', 'joint2', 'joint3'], one_second_to_goal())
        driver.set_clock(100.5)
        halfway = reach(ros, driver.states, 100.5)
        np.testing.assert_allclose(halfway, 0.5 * np.array(GOAL), atol=1e-9)
        # Back by 3.5 s, then on in 20 ms steps (the timer fires on simulated time).
        after = len(driver.states)
        for k in range(16):
            driver._clock.publish(Clock(clock=TimeMsg(sec=97, nanosec=20_000_000 * k)))
            ros.spin_for(0.02)
        assert ros.spin_until(lambda: any(stamp_ns(s) >= 97_200_000_000
                                          for s in driver.states[after:]), 10.0)
        later = [s for s in driver.states[after:] if stamp_ns(s) < 100_000_000_000]
        assert len(later) > 3
        # The clock jumped from 100.5 s to 97 s: the motion goes on from where it was
        # then, by the jump's exact size (the clock's jump callback; the planner moves
        # its own times by the same amount), without a step or a pause.
        for state in later:
            since = stamp_ns(state) * 1e-9 - 97.0
            np.testing.assert_allclose(state.position, (0.5 + since) * np.array(GOAL),
                                       atol=1e-9)


def test_a_trajectory_sent_before_the_clock_starts_starts_with_it():
    """Accepted at simulated time 0, it starts when /clock does, not at its end."""
    with LocalRos() as ros:
        driver = simulated_arm(ros)
        driver.send(['joint1', 'joint2', 'joint3'], one_second_to_goal())
        driver._clock.publish(Clock(clock=TimeMsg(sec=100)))
        np.testing.assert_allclose(reach(ros, driver.states, 100.0), 0.0, atol=1e-9)
        driver._clock.publish(Clock(clock=TimeMsg(sec=100, nanosec=500_000_000)))
        np.testing.assert_allclose(reach(ros, driver.states, 100.5), 0.5 * np.array(GOAL),
                                   atol=1e-9)


def test_a_pending_trajectory_replaced_before_it_starts_is_reported():
    """Two stamped trajectories in a row: the first never runs, and the status says so."""
    with LocalRos() as ros:
        driver = simulated_arm(ros)
        driver.set_clock(100.0)
        for second in (101, 102):
            msg = JointTrajectory(joint_names=['joint1', 'joint2', 'joint3'],
                                  points=[one_second_to_goal()])
            msg.header.stamp = TimeMsg(sec=second)
            n = len(driver.arm_status)
            driver._trajectories.publish(msg)
            assert ros.spin_until(lambda: len(driver.arm_status) > n, 10.0)
        replaced = [s for s in driver.arm_status if 'replaced before it started' in s.message]
        assert len(replaced) == 1 and replaced[0].level == DiagnosticStatus.WARN
        assert status_values(replaced[0])['start_ns'] == str(101_000_000_000)


def test_a_stall_on_the_system_clock_is_time_passing_not_a_jump():
    """
    Gaps between the arm's readings move its trajectories only on a simulated clock.

    On the system clock an 11 s gap is the process stalling: the planner,
    which sees no jump, keeps the trajectory where the clock has it, and so
    must the arm (it moved it 11 s later, and the next replanned trajectory
    jumped the arm 0.49 rad, helper-90).  On simulated time the same gap
    still moves it (rcl reports such jumps to both nodes).
    """
    for sim_time in (False, True):
        with LocalRos() as ros:
            arm = ros.add(ArmSimNode(context=ros.context, parameter_overrides=overrides(
                {'use_sim_time': sim_time})))
            arm._last_ns = last = 5_000_000_000
            arm._active = ('a trajectory', 7_000_000_000)
            arm._follow_clock(last + 11_000_000_000)
            moved = arm._active[1] - 7_000_000_000
            assert moved == (11_000_000_000 if sim_time else 0), (sim_time, moved)
            assert arm._last_ns == last + 11_000_000_000
