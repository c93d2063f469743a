"""planner_node with waypoints as users send them: tolerance, position limits, WARN status."""

from diagnostic_msgs.msg import DiagnosticStatus
from node_status import assert_planned
import numpy as np
import pytest
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.ros_conversions import WaypointRequest
from splines445_ros.planning import DEFAULT_WAYPOINT_TOLERANCE, plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.service.request_planning import start_from_state
from splines445_ros.tools.in_process import InProcessSystem, overrides, waypoint_message

W = pe.joint_waypoints()
GOAL = np.array([0.5, 1.0, -0.5])
LIMITS = {'max_velocity': [2.0] * 3, 'max_acceleration': [10.0] * 3}
# The dynamic arm rests up to 2.5e-4 rad from its command (friction dead band).
DEAD_BAND = 2.5e-4


def request(waypoints, times=None):
    n = np.shape(waypoints)[1]
    return WaypointRequest(np.asarray(waypoints, dtype=float), np.zeros(n), np.zeros(n),
                           np.zeros(n), np.zeros(n), times)


def test_a_start_state_within_the_tolerance_replaces_the_first_waypoint():
    measured = W[0] + DEAD_BAND * np.array([1.0, -1.0, 0.5])
    sent = request([W[0], GOAL, W[3]], times=np.array([0.1, 1.0, 2.0]))
    replaced = start_from_state(sent, measured, np.zeros(3), np.zeros(3),
                                DEFAULT_WAYPOINT_TOLERANCE)
    np.testing.assert_array_equal(replaced.waypoints, [measured, GOAL, W[3]])
    np.testing.assert_array_equal(replaced.times, [0.0, 1.0, 2.0])
    # Beyond the tolerance (or with 0) the state is prepended, as before.
    kept = start_from_state(sent, measured, np.zeros(3), np.zeros(3), 0.0)
    np.testing.assert_array_equal(kept.waypoints, [measured, W[0], GOAL, W[3]])
    np.testing.assert_array_equal(kept.times, [0.0, 0.1, 1.0, 2.0])
    far = W[0] + 2.0 * DEFAULT_WAYPOINT_TOLERANCE
    assert start_from_state(sent, far, np.zeros(3), np.zeros(3),
                            DEFAULT_WAYPOINT_TOLERANCE).waypoints.shape[0] == 4
    # A replaced first waypoint takes its time with it; the next must be > 0.
    with pytest.raises(ValueError, match='must be > 0'):
        start_from_state(request([W[0], GOAL], times=np.array([0.5, 0.0])), measured,
                         np.zeros(3), np.zeros(3), DEFAULT_WAYPOINT_TOLERANCE)


def test_default_tolerance_covers_the_dynamic_arms_dead_band():
    assert DEFAULT_WAYPOINT_TOLERANCE >= DEAD_BAND


@pytest.fixture
def system():
    planner = {'start_from_current_state': True, 'replan_lead_time': 0.5,
               'max_jerk': [0.0] * 3, **LIMITS}
    with InProcessSystem(planner_parameters=planner,
                         arm_parameters={'initial_positions': W[0].tolist(),
                                         'simulation': 'kinematic'}) as s:
        assert s.spin_until(lambda: len(s.joint_states) > 2, 5.0)
        yield s


def test_replanning_from_joint_states_with_the_commanded_pose_as_first_waypoint(system):
    # The user sends [commanded pose, goal]; the arm measures a pose 2.5e-4 off.
    commanded = W[0] + DEAD_BAND * np.array([1.0, -1.0, 0.5])
    status, msg = system.request(waypoint_message(pe.JOINT_NAMES, [commanded, GOAL]))
    assert_planned(status)
    values = status_values(status)
    assert values['waypoints'] == '2'
    np.testing.assert_allclose(msg.points[0].positions, W[0], atol=1e-12)
    direct = plan([W[0], GOAL], '445', 'uniform', **LIMITS)
    assert float(values['duration']) == pytest.approx(direct.duration, rel=1e-6)
    assert max(float(v) for v in values['max_excursion'].split(',')) < 0.05
    # With the tolerance set to 0 the near-duplicate stays: the plan swings, and
    # the status says so (WARN, suggesting optimal timing).
    assert system.set_planner_parameters({'waypoint_tolerance': 0.0,
                                          'start_from_current_state': False})[0].successful
    status, _ = system.request(waypoint_message(pe.JOINT_NAMES, [W[0], commanded, GOAL]))
    assert status.level == DiagnosticStatus.WARN, status.message
    assert 'optimal' in status.message and 'waypoint_tolerance' in status.message
    assert float(status_values(status)['duration']) > 20.0 * direct.duration


def test_position_limits_from_parameters(system):
    # Integer arrays, as typed on the command line, are accepted.
    assert system.set_planner_parameters({'min_position': [-3, -3, -3],
                                          'max_position': [3, 3, 3],
                                          'start_from_current_state': False})[0].successful
    assert system.planner.parameters.config.max_position == (3.0, 3.0, 3.0)
    status, _ = system.request(waypoint_message(pe.JOINT_NAMES, [W[0], GOAL]))
    assert_planned(status)
    assert system.set_planner_parameters({'max_position': [3.0, 0.9, 3.0]})[0].successful
    status, _ = system.request(waypoint_message(pe.JOINT_NAMES, [W[0], GOAL]))
    assert status.level == DiagnosticStatus.ERROR
    assert 'joint 1 (joint2)' in status.message and 'max_position[1]' in status.message
    # The node serves the next request.
    assert system.set_planner_parameters({'max_position': [3.0, 3.0, 3.0]})[0].successful
    status, _ = system.request(waypoint_message(pe.JOINT_NAMES, [W[0], GOAL]))
    assert_planned(status)


@pytest.mark.parametrize('values, reason', [
    ({'waypoint_tolerance': -1e-3}, 'waypoint_tolerance'),
    ({'waypoint_tolerance': 0.5}, 'waypoint_tolerance'),
    ({'min_position': [0.0, 0.0]}, 'min_position needs one value per joint (3)'),
    ({'max_position': ['a', 'b', 'c']}, 'max_position must be an array of numbers'),
    ({'min_position': [1.0, 0.0, 0.0], 'max_position': [0.0, 1.0, 1.0]},
     'min_position[0] = 1.0 is above max_position[0]'),
])
def test_bad_tolerance_and_position_limits_are_rejected(system, values, reason):
    before = system.planner.parameters.config
    result = system.planner.set_parameters_atomically(overrides(values))
    assert not result.successful and reason in result.reason, result.reason
    assert system.planner.parameters.config == before
