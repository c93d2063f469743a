"""
Goals on simulated time when the simulator resets: the planner follows the clock's jump.

Both nodes use ``use_sim_time``; the test publishes /clock itself, in 20 ms
steps, and resets it from about 102 s to 10 s mid-goal.  The arm goes on
from where it was (``arm_sim_node._follow_clock``); a cancel or a new goal
after the reset must plan from that same state, so the commanded state
never moves faster than the velocity limit between two joint_states.
"""

from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Time as TimeMsg
import numpy as np
import pytest
from rclpy.action import ActionClient
from rosgraph_msgs.msg import Clock
from splines445_interfaces.action import FollowWaypoints
from splines445_ros.tools.in_process import InProcessSystem, stamp_ns, waypoint_message

NAMES = ('joint1', 'joint2', 'joint3')
V = 2.0     # config/planar_arm.yaml's velocity limit [rad/s]
LONG = np.array([[0.0, 0.0, 0.0], [1.5, 2.0, -1.5], [3.0, 0.0, 1.5], [0.0, -1.0, 0.0]])
STEP = 0.02     # [s] of simulated time between two /clock messages


@pytest.fixture
def system():
    import os
    config = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'planar_arm.yaml')
    with InProcessSystem(planner_parameters={'kinematics': 'planar_3dof', 'use_sim_time': True,
                                             'replan_lead_time': 0.5},
                         params_file=config,
                         arm_parameters={'simulation': 'kinematic', 'use_sim_time': True,
                                         'initial_positions': [0.0, 0.0, 0.0]}) as s:
        s.clock_publisher = s.client.create_publisher(Clock, '/clock', 10)
        s.action_client = ActionClient(s.client, FollowWaypoints,
                                       '/planner_node/follow_waypoints')
        assert s.spin_until(lambda: s.action_client.server_is_ready()
                            and s.clock_publisher.get_subscription_count() >= 2, 10.0)
        yield s


def run_clock(system, start, end):
    """Publish /clock from ``start`` to ``end`` [s] in STEP steps, spinning between them."""
    for k in range(int(round((end - start) / STEP)) + 1):
        t = start + k * STEP
        system.clock_publisher.publish(Clock(clock=TimeMsg(
            sec=int(t), nanosec=int(round(t % 1 * 1e9)) % 1_000_000_000)))
        system.spin_for(0.02)


def send_goal(system, waypoints):
    goal = FollowWaypoints.Goal()
    goal.waypoints = waypoint_message(NAMES, waypoints)
    sent = system.action_client.send_goal_async(goal)
    assert system.spin_until(sent.done, 10.0) and sent.result().accepted
    return sent.result()


def assert_no_jump(states):
    """Between two joint_states (on the same timeline) no joint moves faster than V."""
    times = 1e-9 * np.array([stamp_ns(s) for s in states])
    positions = np.array([s.position for s in states])
    same = np.diff(times) > 0.0     # (the jump back itself is between two timelines)
    steps = np.max(np.abs(np.diff(positions, axis=0)), axis=1)
    allowed = V * np.diff(times) + 1e-6
    assert np.all(steps[same] <= allowed[same]), (steps[same] - allowed[same]).max()
    assert np.all(steps[~same] <= V * STEP + 1e-6), steps[~same]


def test_a_cancel_after_a_reset_brakes_from_where_the_arm_is(system):
    run_clock(system, 100.0, 100.2)
    handle = send_goal(system, LONG)
    run_clock(system, 100.22, 102.0)
    moving = np.array(system.joint_states[-1].velocity)
    assert np.max(np.abs(moving)) > 0.5
    n = len(system.joint_states)
    run_clock(system, 10.0, 10.6)    # the simulator resets
    cancel = handle.cancel_goal_async()
    run_clock(system, 10.62, 12.0)
    assert cancel.done()
    result = handle.get_result_async()
    run_clock(system, 12.02, 14.0)
    assert result.done() and result.result().status == GoalStatus.STATUS_CANCELED, (
        result.result().result.message)
    after = system.joint_states[n - 1:]
    assert_no_jump(after)
    # Braked to rest long before the goal's end, not back at its start.
    np.testing.assert_array_equal(after[-1].velocity, 0.0)
    assert np.max(np.abs(np.array(after[-1].position))) > 0.3


def test_a_goal_after_a_reset_preempts_from_where_the_arm_is(system):
    run_clock(system, 100.0, 100.2)
    send_goal(system, LONG)
    run_clock(system, 100.22, 101.5)
    send_goal(system, np.array([[0.0, 0.0, 0.0], [-0.5, 0.5, 0.2]]))
    run_clock(system, 101.52, 102.5)
    n = len(system.joint_states)
    run_clock(system, 10.0, 10.4)    # the simulator resets
    third = send_goal(system, np.array([[0.0, 0.0, 0.0], [0.2, -0.2, 0.1]]))
    result = third.get_result_async()
    run_clock(system, 10.42, 14.0)
    assert result.done() and result.result().status == GoalStatus.STATUS_SUCCEEDED, (
        result.result().result.message)
    assert_no_jump(system.joint_states[n - 1:])
    np.testing.assert_allclose(system.joint_states[-1].position, [0.2, -0.2, 0.1], atol=1e-6)


def test_a_cancel_while_the_clock_is_paused_stops_the_arm_when_it_resumes(system):
    """The stop is planned and sent during the pause (the action ticked on the paused clock)."""
    run_clock(system, 100.0, 100.2)
    handle = send_goal(system, LONG)
    run_clock(system, 100.22, 101.5)
    n_status = len(system.planner_status)
    cancel = handle.cancel_goal_async()
    # Paused at 101.5 s: wall time passes, simulated time does not.
    assert system.spin_until(lambda: any('stopping: braking' in s.message
                                         for s in system.planner_status[n_status:]), 5.0)
    n = len(system.joint_states)
    result = handle.get_result_async()
    run_clock(system, 101.52, 104.0)
    assert cancel.done()
    assert result.done() and result.result().status == GoalStatus.STATUS_CANCELED, (
        result.result().result.message)
    assert_no_jump(system.joint_states[n - 1:])
    np.testing.assert_array_equal(system.joint_states[-1].velocity, 0.0)
