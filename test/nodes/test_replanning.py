"""Replanning from a moving arm: no jump in position, velocity or acceleration."""

import time

from diagnostic_msgs.msg import DiagnosticStatus
import numpy as np
import pytest
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import JointState
from sim_clock import ClockDriver
from splines445_ros.nodes import topics
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.nodes.ros_conversions import sampled_trajectory_from_msg
from splines445_ros.planning import plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.service.request_planning import REPLAN_MAX_DELAY
from splines445_ros.tools.in_process import (InProcessSystem, LocalRos, overrides, stamp_ns,
                                             waypoint_message)
from trajectory_msgs.msg import JointTrajectory

W = pe.joint_waypoints()
SECOND = np.array([[0.2, 2.0, -2.0], [0.6, 1.6, -2.2], [0.9, 1.2, -1.5]])
RATE = 100.0  # joint_states per second
VMAX, AMAX = 2.0, 10.0


def test_replanning_mid_motion_is_continuous_and_reaches_the_new_goal():
    # A lead of 1 s: on a loaded 2-core machine planning from a stuck state
    # (several later switch times tried) took up to 0.95 s.
    planner = {'start_from_current_state': True, 'replan_lead_time': 1.0,
               'max_velocity': [VMAX] * 3, 'max_acceleration': [AMAX] * 3,
               'max_jerk': [0.0] * 3}
    with InProcessSystem(planner_parameters=planner,
                         arm_parameters={'initial_positions': W[0].tolist(),
                                         'publish_rate': RATE}) as system:
        assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
        # First request: nothing runs yet, so it starts from joint_states (at rest at W[0]).
        status1, traj1 = system.request(waypoint_message(pe.JOINT_NAMES, W))
        assert status1.level == DiagnosticStatus.OK, status1.message
        t1 = Time.from_msg(traj1.header.stamp).nanoseconds
        assert t1 == int(status_values(status1)['switch_time_ns']) > 0
        np.testing.assert_allclose(traj1.points[0].positions, W[0], atol=1e-12)
        # Mid-motion, a new request; it takes over at its stamp.
        system.spin_for(1.2)  # the first trajectory runs (it starts 1 s after its request)
        n_arm_status = len(system.arm_status)
        status2, traj2 = system.request(waypoint_message(pe.JOINT_NAMES, SECOND))
        assert status2.level == DiagnosticStatus.OK, status2.message
        t2 = Time.from_msg(traj2.header.stamp).nanoseconds
        assert t2 > t1
        switch = (t2 - t1) * 1e-9
        first = sampled_trajectory_from_msg(traj1, pe.JOINT_NAMES)
        assert 0.0 < switch < first.duration  # the switch happens mid-motion
        # Position, velocity and acceleration of the new trajectory's first point are
        # the old trajectory's state at the switch (between samples: Hermite playback).
        p, v, a = first.state_at(switch)
        start = traj2.points[0]
        np.testing.assert_allclose(start.positions, p, atol=1e-6)
        np.testing.assert_allclose(start.velocities, v, atol=1e-5)
        np.testing.assert_allclose(start.accelerations, a, atol=1e-3)
        # The arm follows: consecutive joint_states can change velocity by at most
        # a_max * dt and position by at most v_max * dt, also across the switch.
        played, final = system.wait_until_played(n_arm_status,
                                                 sampled_trajectory_from_msg(
                                                     traj2, pe.JOINT_NAMES).duration)
        states = [s for s in system.joint_states if t1 <= stamp_ns(s) <= stamp_ns(final)]
        times = np.array([stamp_ns(s) for s in states]) * 1e-9
        positions = np.array([s.position for s in states])
        velocities = np.array([s.velocity for s in states])
        assert times[0] < t2 * 1e-9 < times[-1]
        dt = np.diff(times)[:, None]
        assert np.all(np.abs(np.diff(velocities, axis=0)) <= AMAX * dt * (1 + 1e-6) + 1e-9)
        assert np.all(np.abs(np.diff(positions, axis=0)) <= VMAX * dt * (1 + 1e-6) + 1e-9)
        np.testing.assert_allclose(final.position, SECOND[-1], atol=1e-9)


def replanning_planner(ros, **parameters):
    """Return a replanning planner alone, a client publishing requests, its statuses."""
    node = ros.add(PlannerNode(context=ros.context, parameter_overrides=overrides(
        {'start_from_current_state': True, **parameters})))
    client = ros.add(Node('client', context=ros.context))
    statuses = []
    client.create_subscription(DiagnosticStatus, '/planner_node/status', statuses.append,
                               topics.STATUS_QOS)
    publisher = client.create_publisher(JointTrajectory, topics.WAYPOINTS, topics.REQUEST_QOS)
    assert ros.spin_until(lambda: publisher.get_subscription_count()
                          and node.status_publisher.get_subscription_count(), 10.0)
    return node, client, publisher, statuses


def test_replanning_without_any_state_says_so():
    with LocalRos() as ros:
        _, _, publisher, statuses = replanning_planner(ros)
        publisher.publish(waypoint_message(pe.JOINT_NAMES, W))
        assert ros.spin_until(lambda: statuses, 10.0)
        assert statuses[0].level == DiagnosticStatus.ERROR
        assert 'no joint_states have been received' in statuses[0].message


def test_a_missed_switch_time_is_rejected_and_the_old_trajectory_continues():
    """Planning that outlasts replan_lead_time (held here) is refused: the arm would jump."""
    lead = 0.05     # the least replan_lead_time
    with InProcessSystem(planner_parameters={'start_from_current_state': True,
                                             'replan_lead_time': lead},
                         arm_parameters={'initial_positions': W[0].tolist()}) as system:
        assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
        original = system.planner._replan

        def slow(*args, **kwargs):
            time.sleep(lead + 0.1)
            return original(*args, **kwargs)
        system.planner._replan = slow
        status, traj = system.request(waypoint_message(pe.JOINT_NAMES, W))
        assert status.level == DiagnosticStatus.ERROR and traj is None
        assert 'longer than replan_lead_time' in status.message


def test_a_request_planned_while_the_waiting_trajectory_starts_is_planned_again_from_it():
    """
    Request B is planned from the arm at rest while A waits for its stamp; A starts meanwhile.

    B's planning is held (a wrapped ``_replan``, first call only) until A
    has started: B's plan would start from the wrong state, so it is
    planned again from A, and takes over from A without a jump (it was
    rejected: "send the request again").
    """
    lead = 0.4
    with InProcessSystem(planner_parameters={'start_from_current_state': True,
                                             'replan_lead_time': lead},
                         arm_parameters={'initial_positions': W[0].tolist()}) as system:
        assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
        node = system.planner
        original, calls = node._replan, []

        def held(*args):
            calls.append(args[-1])      # the trajectory it is planned from
            if len(calls) == 2:         # B's first planning: until A has started
                time.sleep(lead + 0.2)
            return original(*args)

        node._replan = held
        status_a, traj_a = system.request(waypoint_message(pe.JOINT_NAMES, W))
        assert status_a.level == DiagnosticStatus.OK, status_a.message
        status_b, traj_b = system.request(waypoint_message(pe.JOINT_NAMES, SECOND))
        assert status_b.level == DiagnosticStatus.OK, status_b.message
        assert len(calls) == 3 and calls[1] is None and calls[2] is not None
        first = sampled_trajectory_from_msg(traj_a, pe.JOINT_NAMES)
        switch = (Time.from_msg(traj_b.header.stamp).nanoseconds
                  - Time.from_msg(traj_a.header.stamp).nanoseconds) * 1e-9
        assert 0.0 < switch < first.duration
        p, v, _ = first.state_at(switch)
        np.testing.assert_allclose(traj_b.points[0].positions, p, atol=1e-6)
        np.testing.assert_allclose(traj_b.points[0].velocities, v, atol=1e-5)


def test_replanning_from_malformed_joint_states_is_a_clear_error():
    with LocalRos() as ros:
        node, client, publisher, statuses = replanning_planner(ros)
        states = client.create_publisher(JointState, topics.JOINT_STATES, topics.STATE_QOS)
        assert ros.spin_until(lambda: states.get_subscription_count(), 10.0)
        # Three names, two positions: before, an IndexError reported as internal.
        states.publish(JointState(name=list(pe.JOINT_NAMES), position=[0.0, 0.0]))
        assert ros.spin_until(lambda: node._joint_states.latest() is not None, 10.0)
        publisher.publish(waypoint_message(pe.JOINT_NAMES, W))
        assert ros.spin_until(lambda: statuses, 10.0)
        assert statuses[0].level == DiagnosticStatus.ERROR
        assert '2 positions for 3 names' in statuses[0].message, statuses[0].message


def test_a_switch_state_without_a_plan_switches_later_on_the_running_trajectory():
    limits = {'max_velocity': [VMAX] * 3, 'max_acceleration': [AMAX] * 3}
    running = plan(W, method='445', **limits)

    def plannable(t):
        p, v, a = (running.evaluate([t], d)[0] for d in (0, 1, 2))
        try:
            plan(np.vstack([p, SECOND]), start_velocity=v, start_acceleration=a, **limits)
        except ValueError:
            return False
        return True
    stuck = next(t for t in np.arange(0.5, running.duration - 1.0, 0.01) if not plannable(t))
    with LocalRos() as ros:
        node, client, publisher, statuses = replanning_planner(
            ros, use_sim_time=True, replan_lead_time=0.5, max_jerk=[0.0] * 3, **limits)
        driver = ClockDriver(ros, arm=False, clock_of=node)
        states = client.create_publisher(JointState, topics.JOINT_STATES, topics.STATE_QOS)
        assert ros.spin_until(lambda: states.get_subscription_count(), 10.0)
        states.publish(JointState(name=list(pe.JOINT_NAMES), position=W[0].tolist(),
                                  velocity=[0.0] * 3))
        assert ros.spin_until(lambda: node._joint_states.latest() is not None, 10.0)
        driver.set_clock(100.0)
        publisher.publish(waypoint_message(pe.JOINT_NAMES, W))
        assert ros.spin_until(lambda: statuses, 10.0)
        assert statuses[0].level == DiagnosticStatus.OK, statuses[0].message
        assert int(status_values(statuses[0])['switch_time_ns']) == 100_500_000_000
        # Simulated time stands still while the node plans: the switch is requested
        # exactly at a state from which the planning core finds no plan.
        driver.set_clock(100.0 + stuck)
        publisher.publish(waypoint_message(pe.JOINT_NAMES, SECOND))
        assert ros.spin_until(lambda: len(statuses) > 1, 10.0)
        status = statuses[1]
        assert status.level == DiagnosticStatus.OK, status.message
        values = status_values(status)
        delay = float(values['switch_delay'])
        assert 0.0 < delay <= REPLAN_MAX_DELAY
        assert 'switching' in status.message
        switch = (int(values['switch_time_ns']) - 100_500_000_000) * 1e-9
        assert switch == pytest.approx(stuck + delay, abs=1e-9)
        assert plannable(switch)
