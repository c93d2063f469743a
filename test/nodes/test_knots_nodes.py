"""
``output: knots`` end to end: planner_node publishes knots, arm_sim_node plays them exactly.

Joint requests, tool requests and replanning, each checked against the
planning library's own trajectory (planned here with the node's parameters).
"""

import os

from diagnostic_msgs.msg import DiagnosticStatus
from node_status import assert_planned
import numpy as np
from rclpy.time import Time
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.ros_conversions import sampled_trajectory_from_msg
from splines445_ros.planning import plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.service.request_planning import plan_tool_request
from splines445_ros.tools.in_process import (InProcessSystem, stamp_ns, tool_waypoint_message,
                                             waypoint_message)

CONFIG = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'planar_arm.yaml')
W = pe.joint_waypoints()
BOUNDARY = (pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION,
            pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION)
NANOS = 1_000_000_000
RTOL = 1e-9


def arrays(msg):
    """Integer-ns times (K,) and positions, velocities, accelerations (K, n) of a message."""
    ns = np.array([p.time_from_start.sec * NANOS + p.time_from_start.nanosec
                   for p in msg.points], dtype=np.int64)
    return ns, [np.array([getattr(p, f) for p in msg.points])
                for f in ('positions', 'velocities', 'accelerations')]


def assert_knots_of(msg, traj):
    """``msg`` is ``traj``'s knots: one per breakpoint, its state at the published time."""
    ns, states = arrays(msg)
    assert len(ns) == traj.ppoly.x.size
    assert np.all(np.abs(ns - traj.ppoly.x * NANOS) <= 0.5 + 1e-3)
    dense = np.linspace(0.0, traj.duration, 2001)
    for d, values in enumerate(states):
        scale = float(np.max(np.abs(traj.evaluate(dense, d))))
        # traj.evaluate holds the end state after the end: the ppoly extends the last segment.
        np.testing.assert_allclose(values, traj.ppoly(ns * 1e-9, d), rtol=0, atol=RTOL * scale)


def test_knots_through_both_nodes():
    with InProcessSystem(planner_parameters={'output': 'knots'},
                         arm_parameters={'initial_positions': W[0].tolist(),
                                         'simulation': 'kinematic', 'publish_rate': 200.0},
                         params_file=CONFIG) as system:
        # A bad value is rejected with the reason, and the ERROR is on ~/status too.
        n_status = len(system.planner_status)
        result = system.set_planner_parameters({'output': 'sample'})[0]
        assert not result.successful and 'output must be one of' in result.reason
        assert system.planner.get_parameter('output').value == 'knots'
        assert system.spin_until(lambda: len(system.planner_status) > n_status, 5.0)
        rejected = system.planner_status[n_status]
        assert rejected.level == DiagnosticStatus.ERROR
        assert 'output must be one of' in rejected.message
        assert status_values(rejected)['parameters'] == 'output'

        # The paper's example (445, the params file's jerk limit): 12 knots, played exactly.
        n_arm_status = len(system.arm_status)
        status, msg = system.request(waypoint_message(pe.JOINT_NAMES, W, *BOUNDARY))
        assert_planned(status)
        reference = plan(W, '445', 'uniform', max_velocity=pe.MAX_VELOCITY,
                         max_acceleration=pe.MAX_ACCELERATION, max_jerk=[200.0] * 3,
                         start_velocity=BOUNDARY[0], start_acceleration=BOUNDARY[1],
                         end_velocity=BOUNDARY[2], end_acceleration=BOUNDARY[3])
        assert status_values(status)['points'] == '12'
        assert_knots_of(msg, reference)
        ns, _ = arrays(msg)
        played, final = system.wait_until_played(n_arm_status, ns[-1] * 1e-9)
        start = int(status_values(system.arm_status[n_arm_status])['start_ns'])
        t = np.array([stamp_ns(s) - start for s in played]) * 1e-9
        assert len(t) > 100
        dense = np.linspace(0.0, reference.duration, 2001)
        for d, field in ((0, 'position'), (1, 'velocity')):
            got = np.array([getattr(s, field) for s in played])
            scale = float(np.max(np.abs(reference.evaluate(dense, d))))
            np.testing.assert_allclose(got, reference.evaluate(t, d), rtol=0,
                                       atol=RTOL * scale)
        # It holds the last knot: the last waypoint, moved by the end velocity for at
        # most the half nanosecond of rounding of its time.
        np.testing.assert_allclose(final.position, W[-1], rtol=0, atol=2.0 * 0.5e-9)

        # A tool request, refined to 1 mm (555: 68 inserted waypoints): every knot.
        assert system.set_planner_parameters({'method': '555'})[0].successful
        xy = pe.triangle_points()
        poses = np.column_stack([xy, np.zeros(len(xy))])
        status, msg = system.request(tool_waypoint_message(poses))
        assert_planned(status)
        tool_path = plan_tool_request(system.planner.parameters.config, poses)
        assert tool_path.inserted > 0
        assert_knots_of(msg, tool_path.trajectory)
        assert int(status_values(status)['points']) == tool_path.trajectory.ppoly.x.size


SECOND = np.array([[0.2, 2.0, -2.0], [0.6, 1.6, -2.2], [0.9, 1.2, -1.5]])


def test_replanning_from_a_knots_trajectory_starts_from_its_exact_state():
    planner = {'output': 'knots', 'start_from_current_state': True, 'replan_lead_time': 0.5,
               'max_velocity': [2.0] * 3, 'max_acceleration': [10.0] * 3,
               'max_jerk': [0.0] * 3, 'method': '555'}
    with InProcessSystem(planner_parameters=planner,
                         arm_parameters={'initial_positions': W[0].tolist(),
                                         'publish_rate': 100.0}) as system:
        assert system.spin_until(lambda: len(system.joint_states) > 2, 5.0)
        status1, traj1 = system.request(waypoint_message(pe.JOINT_NAMES, W))
        assert status1.level == DiagnosticStatus.OK, status1.message
        system.spin_for(1.0)
        n_arm_status = len(system.arm_status)
        status2, traj2 = system.request(waypoint_message(pe.JOINT_NAMES, SECOND))
        assert status2.level == DiagnosticStatus.OK, status2.message
        t1 = Time.from_msg(traj1.header.stamp).nanoseconds
        t2 = Time.from_msg(traj2.header.stamp).nanoseconds
        first = sampled_trajectory_from_msg(traj1, pe.JOINT_NAMES)
        switch = (t2 - t1) * 1e-9
        assert 0.0 < switch < first.duration
        # The new trajectory starts in the state the controller's interpolation of the
        # first one's knots (= the first plan) has at the switch: exactly, not to the
        # 1e-3 that samples allow.
        _, (p, v, a) = arrays(traj2)
        dense = np.linspace(0.0, first.duration, 2001)
        for d, value in enumerate((p[0], v[0], a[0])):
            scale = float(np.max(np.abs(first.states_at(dense)[d])))
            np.testing.assert_allclose(value, first.state_at(switch)[d], rtol=0,
                                       atol=RTOL * scale)
        # Only the knots are published; the arm plays the second to its end.
        assert len(traj2.points) == int(status_values(status2)['waypoints'])
        _, final = system.wait_until_played(n_arm_status, arrays(traj2)[0][-1] * 1e-9)
        np.testing.assert_allclose(final.position, SECOND[-1], rtol=0, atol=1e-9)


def test_a_knots_plan_that_ends_at_rest_is_not_warned_of_as_moving():
    """Its last knot, at a time rounded to the nanosecond, carries 1e-18 rad/s (helper-78)."""
    with InProcessSystem(planner_parameters={'output': 'knots'},
                         arm_parameters={'initial_positions': [0.0, 0.0, 0.0],
                                         'simulation': 'kinematic'},
                         params_file=CONFIG) as system:
        n = len(system.arm_status)
        rest = np.array([[0.0, 0.0, 0.0], [0.5, 1.0, -0.5], [1.0, 0.5, 0.0]])
        status, msg = system.request(waypoint_message(pe.JOINT_NAMES, rest))
        assert_planned(status)
        assert np.max(np.abs(msg.points[-1].velocities)) < 1e-9
        assert system.spin_until(lambda: any('accepted' in s.message
                                             for s in system.arm_status[n:]), 5.0)
        accepted = next(s for s in system.arm_status[n:] if 'accepted' in s.message)
        assert accepted.level == DiagnosticStatus.OK, accepted.message
