"""
The planner node's ``inner_knots`` parameter (issue 17).

Declared with a descriptor, validated on set_parameters, used for 555
optimal waypoint requests only, and the status reports waypoints and knots
separately.
"""

from dataclasses import replace

import numpy as np
import pytest
from rclpy.parameter import Parameter
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.nodes.ros_conversions import WaypointRequest
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.request_planning import (plan_request, plan_warnings, start_from_state,
                                                     summary_values)
from splines445_ros.tools.in_process import LocalRos
from test_position_limits import one_way_request

WAYPOINTS = np.array([[0.0, 0.0, 0.0], [1.0, -0.5, 0.3], [1.5, 0.5, -0.2], [0.5, 1.0, 0.4],
                      [-0.5, 0.2, 0.0], [-1.0, -0.6, 0.5], [-0.2, -1.2, 1.0],
                      [0.8, -0.4, 0.6], [1.4, 0.3, -0.3], [0.6, 0.9, -0.8]])


def request(waypoints=WAYPOINTS):
    zero = np.zeros(waypoints.shape[1])
    return WaypointRequest(waypoints, zero, zero, zero, zero, None)


def config(**overrides):
    values = {'method': '555', 'timing': 'optimal', 'max_jerk': (100.0, 100.0, 100.0),
              'inner_knots': 2}
    values.update(overrides)
    return PlannerConfig(**values)


def test_555_optimal_request_uses_inner_knots_and_reports_knots():
    traj = plan_request(config(), request())
    values = summary_values(traj, config().joint_names)
    assert values['waypoints'] == len(WAYPOINTS)
    assert values['knots'] == traj.breakpoints.size
    assert traj.optimizer['inner_knots'] == 2
    assert values['knots'] == np.sum(np.asarray(traj.optimizer['inner_knots_per_segment']) + 1) + 1
    assert values['knots'] > len(WAYPOINTS)
    # The binding limit is named by its waypoint segment, not by its piece.
    segment = int(values['binding'].split(' segment ')[1].split()[0])
    assert 0 <= segment < len(WAYPOINTS) - 1
    knots_only = plan_request(config(inner_knots=0), request())
    assert traj.duration < knots_only.duration
    assert summary_values(knots_only, config().joint_names)['knots'] == len(WAYPOINTS)


def test_the_default_is_auto_four_inner_knots_at_most_without_torque_limits():
    # The documented default (doc/nodes.md, issues 23 and 25): plan()'s.
    assert PlannerConfig().inner_knots == -1
    assert config(inner_knots=-1).plan_inner_knots() is None
    assert config(inner_knots=-1, method='445').plan_inner_knots() == 0
    traj = plan_request(config(inner_knots=PlannerConfig().inner_knots), request())
    assert traj.optimizer['inner_knots'] == 4
    assert max(traj.optimizer['inner_knots_per_segment']) == 4


def test_vibration_frequency_reaches_plan_and_is_refused_where_it_would_be_ignored():
    traj = plan_request(config(vibration_frequency=5.0), request())
    assert traj.optimizer['smoothing_windows'] == [0.2, 0.2]
    assert plan_request(config(), request()).optimizer['smoothing_windows'] == [0.3, 0.15]
    for overrides in ({'method': '445'}, {'timing': 'uniform'}, {'inner_knots': 0},
                      {'vibration_frequency': -1.0}, {'vibration_frequency': float('nan')},
                      {'vibration_frequency': 1e4}):
        with pytest.raises(ValueError, match='vibration_frequency'):
            config(**dict({'vibration_frequency': 4.0}, **overrides)).validate()


def test_smoothing_reaches_plan_and_is_refused_where_it_would_be_ignored():
    assert PlannerConfig().smoothing == 'auto'
    assert plan_request(config(smoothing='none'), request()).optimizer['smoothing_windows'] == []
    windows = plan_request(config(smoothing='windows'), request()).optimizer['smoothing_windows']
    assert windows == [0.3, 0.15]
    config(smoothing='none').with_defaults().validate()
    for overrides, message in (({'method': '445'}, 'needs method'),
                               ({'inner_knots': 0}, 'needs method'),
                               ({'vibration_frequency': 4.0}, 'sets the windows itself'),
                               ({'smoothing': 'smooth'}, 'must be one of'),
                               ({'smoothing': 'n' * 5000}, 'must be one of')):
        with pytest.raises(ValueError, match=message) as refused:
            config(**dict({'smoothing': 'none'}, **overrides)).validate()
        assert len(str(refused.value)) < 300
    # The default needs nothing of the method.
    config(method='445', smoothing='auto').with_defaults().validate()


def test_a_bad_smoothing_is_rejected_by_set_parameters_with_the_reason():
    with LocalRos() as ros:
        node = ros.add(PlannerNode(context=ros.context, cli_args=[
            '--ros-args', '-p', 'method:=555', '-p', 'timing:=optimal']))
        assert 'limit_torque' in node.describe_parameter('smoothing').description
        result = node.set_parameters([Parameter('smoothing', value='soft')])[0]
        assert not result.successful and 'smoothing' in result.reason
        assert node.parameters.config.smoothing == 'auto'
        assert node.set_parameters([Parameter('smoothing', value='none')])[0].successful
        assert node.parameters.config.smoothing == 'none'


@pytest.mark.parametrize('overrides', [{'method': '445'}, {'timing': 'uniform'}])
def test_other_methods_and_timings_ignore_inner_knots(overrides):
    traj = plan_request(config(**overrides), request())
    assert traj.breakpoints.size == len(WAYPOINTS)


def test_replanning_from_a_moving_state_gets_inner_knots_and_keeps_the_state():
    velocity = np.array([0.3, -0.2, 0.1])
    moving = start_from_state(request(), WAYPOINTS[0], velocity, np.zeros(3))
    traj = plan_request(config(), moving)
    # Moving ends: the inner-knot plan only when it gains more than 5 %.
    if traj.optimizer['inner_knots'] == 0:
        assert traj.optimizer['inner_knots_duration'] * 1.05 >= traj.duration
    else:
        assert traj.optimizer['inner_knots'] == 2
    assert np.allclose(traj.evaluate([0.0], 1)[0], velocity, atol=1e-9)
    assert np.allclose(traj.evaluate(traj.waypoint_times), traj.waypoints, atol=1e-9)
    assert traj.within_limits()


@pytest.mark.parametrize('bad', [-2, 9])
def test_config_rejects_out_of_range_inner_knots(bad):
    with pytest.raises(ValueError, match='inner_knots'):
        config(inner_knots=bad).validate()


def test_node_declares_and_validates_inner_knots():
    with LocalRos() as ros:
        node = ros.add(PlannerNode(context=ros.context, cli_args=['--ros-args', '-p',
                                                                  'inner_knots:=3']))
        assert node.parameters.config.inner_knots == 3
        descriptor = node.describe_parameter('inner_knots')
        assert '555' in descriptor.description
        bad = node.set_parameters([Parameter('inner_knots', value=9)])[0]
        assert not bad.successful and 'inner_knots' in bad.reason
        assert node.parameters.config.inner_knots == 3
        assert node.set_parameters([Parameter('inner_knots', value=0)])[0].successful
        assert node.parameters.config.inner_knots == 0


# A short move that starts fast, found by search: the inner-knot construction
# finds no spline within the limits that keeps this start (it is rare: 2 of
# 300 random 2-joint moving starts).
HARD_START = (np.array([[-0.5881802352290555, 0.853233012826621],
                        [-0.9330973371466107, 1.02063692501268]]),
              np.array([-1.1904513350556383, 1.4892150511173892]),
              np.array([1.5414110854238139, -0.3821436653181589]))


def test_no_inner_knot_spline_is_a_warning_and_the_plan_still_holds_every_limit():
    points, start_velocity, start_acceleration = HARD_START
    names = ('a', 'b')
    cfg = PlannerConfig(joint_names=names, max_velocity=(2.0, 2.0),
                        max_acceleration=(10.0, 10.0), method='555', timing='optimal')
    zero = np.zeros(2)
    traj = plan_request(cfg, WaypointRequest(points, start_velocity, start_acceleration,
                                             zero, zero, None))
    # Knots at the waypoints only, every limit held, the start kept.
    assert traj.breakpoints.size == len(points)
    assert traj.within_limits(rtol=1e-9)
    np.testing.assert_allclose(traj.evaluate([0.0], 1)[0], start_velocity, atol=1e-9)
    np.testing.assert_allclose(traj.evaluate([0.0], 2)[0], start_acceleration, atol=1e-9)
    warning = plan_warnings(traj)
    assert warning is not None and 'no spline with inner knots found' in warning
    assert 'knots at the waypoints only' in warning
    assert summary_values(traj, names)['inner_knots_skipped'] == \
        'no spline with inner knots found'
    # From rest the same move plans without a warning (one segment: its
    # knots-only optimum is the shorter plan, which is no failure).
    rested = plan_request(cfg, WaypointRequest(points, zero, zero, zero, zero, None))
    assert plan_warnings(rested) is None
    assert summary_values(rested, names).get('inner_knots_skipped') != \
        'no spline with inner knots found'
    # A longer move from rest gets its inner knots.
    longer = 2.0 * WAYPOINTS[:, :2]
    knotted = plan_request(cfg, WaypointRequest(longer, zero, zero, zero, zero, None))
    assert knotted.breakpoints.size > len(longer)
    assert plan_warnings(knotted) is None
    assert 'inner_knots_skipped' not in summary_values(knotted, names)


def test_a_knots_only_plan_turned_at_its_ends_says_so_without_a_warning():
    # A move from limit to limit (seed 1000 of test_position_limits' one-way
    # requests, the joints' limits at its waypoints' range) whose knots-only
    # optimum, shorter than the inner-knot plan, starts a joint past its limit.
    points, limits = one_way_request(np.random.default_rng(1000))
    names = tuple(f'j{k}' for k in range(points.shape[1]))
    cfg = PlannerConfig(joint_names=names, **{k: tuple(v) for k, v in limits.items()},
                        method='555', timing='optimal', min_position=tuple(points.min(axis=0)),
                        max_position=tuple(points.max(axis=0)))
    traj = plan_request(cfg, request(points))
    values = summary_values(traj, names)
    assert 'next to each rest end' in values['end_knots']
    assert plan_warnings(traj) is None
    assert traj.breakpoints.size == len(points) + 2
    samples = traj.evaluate(np.linspace(0.0, traj.duration, 20001))
    assert np.all(samples >= points.min(axis=0) - 1e-12)
    assert np.all(samples <= points.max(axis=0) + 1e-12)
    # Without the limits the same request is the knots-only optimum, past them.
    free = plan_request(replace(cfg, min_position=(), max_position=()), request(points))
    assert free.breakpoints.size == len(points)
    q = free.evaluate(np.linspace(0.0, free.duration, 20001))
    assert np.any(q < points.min(axis=0) - 1e-9) or np.any(q > points.max(axis=0) + 1e-9)


def test_the_warning_names_the_knots_a_knots_only_plan_got_at_the_position_limits():
    """
    A knots-only plan turned at its rest ends or pulled within its limits has more knots.

    The warning of a construction that found no spline then names them
    (``end_knots``, ``position_limit_knots``) instead of "the waypoints only".
    """
    points, start_velocity, start_acceleration = HARD_START
    cfg = PlannerConfig(joint_names=('a', 'b'), max_velocity=(2.0, 2.0),
                        max_acceleration=(10.0, 10.0), method='555', timing='optimal')
    zero = np.zeros(2)
    traj = plan_request(cfg, WaypointRequest(points, start_velocity, start_acceleration,
                                             zero, zero, None))
    record = dict(traj.optimizer)
    for keys in (('end_knots',), ('position_limit_knots',), ('end_knots', 'position_limit_knots')):
        traj.optimizer = dict(record, **dict.fromkeys(keys, 'said'))
        warning = plan_warnings(traj)
        assert 'no spline with inner knots found' in warning
        assert 'waypoints only' not in warning
        assert all(f'`{key}`' in warning for key in keys)
    traj.optimizer = record
    assert 'knots at the waypoints only' in plan_warnings(traj)
