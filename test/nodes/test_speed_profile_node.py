"""
The planner node's ``speed_profile`` parameter (issue 38).

Declared with its choices, validated on set_parameters with the reason,
passed to plan() for joint-space requests (a moving start too) and to the
tool lines, and reported on the status (a fallback as a warning).
"""

from dataclasses import replace

import numpy as np
import pytest
from rclpy.parameter import Parameter
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.nodes.ros_conversions import WaypointRequest
from splines445_ros.planning import planner
from splines445_ros.planning.path_following import time_optimal
from splines445_ros.planning.speed_profile.residual_vibration import trajectory_residual
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.request_planning import (plan_request, plan_tool_request,
                                                     plan_warnings, start_from_state,
                                                     summary_values)
from splines445_ros.tools.in_process import LocalRos

WAYPOINTS = np.array([[0.0, 0.0, 0.0], [1.0, -0.5, 0.3], [1.5, 0.5, -0.2], [0.5, 1.0, 0.4],
                      [-0.5, 0.2, 0.0]])
NAMES = ('joint1', 'joint2', 'joint3')


def request(waypoints=WAYPOINTS):
    zero = np.zeros(waypoints.shape[1])
    return WaypointRequest(waypoints, zero, zero, zero, zero, None)


def config(**overrides):
    values = {'method': '555', 'timing': 'optimal', 'max_jerk': (100.0, 100.0, 100.0),
              'speed_profile': 'time_optimal'}
    values.update(overrides)
    return PlannerConfig(**values)


def test_the_default_is_smoothed_and_time_optimal_reaches_plan():
    assert PlannerConfig().speed_profile == 'smoothed'
    traj = plan_request(config(), request())
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    assert summary_values(traj, NAMES)['speed_profile'] == 'time_optimal'
    assert plan_warnings(traj) is None
    assert traj.within_limits(rtol=1e-9)
    assert np.allclose(traj.evaluate(traj.waypoint_times), WAYPOINTS, atol=1e-9)
    # The same request with the default profile lasts longer (its 0.45 s of windows).
    smoothed = plan_request(config(speed_profile='smoothed'), request())
    assert traj.duration < smoothed.duration
    assert 'speed_profile' not in summary_values(smoothed, NAMES)


@pytest.mark.parametrize('overrides, message', [
    ({'speed_profile': 'fastest'}, 'speed_profile'),
    ({'method': '445'}, 'needs method "555"'),
    ({'timing': 'uniform'}, 'needs method "555"'),
    ({'inner_knots': 4}, 'leave inner_knots unset'),
    ({'smoothing': 'none'}, "smoothing 'none' would be ignored"),
])
def test_config_refuses_what_it_would_ignore_or_cannot_hold(overrides, message):
    with pytest.raises(ValueError, match='speed_profile') as refused:
        config(**overrides).with_defaults().validate()
    assert message in str(refused.value)
    assert len(str(refused.value)) < 400


@pytest.mark.parametrize('max_jerk', [(0.0,), (100.0, 0.0, 100.0)])
def test_joints_with_max_jerk_0_are_planned_without_a_jerk_limit(max_jerk):
    cfg = config(max_jerk=max_jerk).with_defaults()
    cfg.validate()
    traj = plan_request(cfg, request())
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    assert plan_warnings(traj) is None
    assert traj.within_limits(rtol=1e-9)
    jerk = np.max(np.abs(np.diff(traj.evaluate(np.arange(0.0, traj.duration, 1e-3)), 3,
                                 axis=0)), axis=0) / 1e-9
    limited = np.resize(np.array(max_jerk) > 0.0, 3)
    assert np.all(jerk[limited] <= 1.01 * 100.0)
    # Without a jerk limit the same request is no longer (the profile has fewer rows).
    assert traj.duration <= plan_request(config(), request()).duration * (1 + 1e-3)


def test_vibration_frequency_cancels_the_ringing_after_the_stop():
    cfg = config(vibration_frequency=4.0).with_defaults()
    cfg.validate()
    traj = plan_request(cfg, request())
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    assert traj.within_limits(rtol=1e-9)
    plain = plan_request(config(), request())
    assert plain.optimizer['vibration_residual'] is None
    # The mode's content of the acceleration (test_time_optimal checks the
    # figure against an oscillator of its own), a share of a / w**2.
    assert traj.optimizer['vibration_residual'] <= 0.2
    assert plain.duration <= traj.duration <= plain.duration + 0.25
    # On ~/status as the plan's figure; the plain plan has none.
    shown = float(summary_values(traj, NAMES)['vibration_residual'])
    assert shown == pytest.approx(traj.optimizer['vibration_residual'], rel=1e-2)
    assert 'vibration_residual' not in summary_values(plain, NAMES)


def test_replanning_from_a_moving_state_keeps_the_state():
    velocity = np.array([0.3, -0.2, 0.1])
    moving = start_from_state(request(), WAYPOINTS[0], velocity, np.zeros(3))
    traj = plan_request(config(), moving)
    assert np.allclose(traj.evaluate([0.0], 1)[0], velocity, atol=1e-9)
    assert np.allclose(traj.evaluate(traj.waypoint_times), WAYPOINTS, atol=1e-9)
    assert traj.within_limits(rtol=1e-9)
    # Followed, or the default's plan with a warning that says so.
    assert traj.optimizer.get('speed_profile') == 'time_optimal' or plan_warnings(traj)


def test_tool_waypoints_are_timed_again_along_the_lines_path():
    cfg = config(kinematics='planar_3dof', max_path_deviation=0.002).with_defaults()
    cfg.validate()
    poses = np.array([[1.2, 0.3, 0.0], [1.0, 0.6, 0.2], [0.8, 0.2, -0.1]])
    tool = plan_tool_request(cfg, poses)
    smoothed = plan_tool_request(replace(cfg, speed_profile='smoothed'), poses)
    assert tool.construction == smoothed.construction == 'tool lines'
    optimizer = tool.trajectory.optimizer or {}
    # Timed again when that is shorter; the lines' own timing otherwise (here
    # it is: this planar path's), with a warning only if the profile failed.
    assert tool.trajectory.duration <= smoothed.trajectory.duration * (1 + 1e-12)
    assert (plan_warnings(tool.trajectory) is None) == ('speed_profile_skipped' not in optimizer)
    assert tool.trajectory.within_limits(rtol=1e-9)
    assert tool.max_deviation <= cfg.max_path_deviation


def test_tool_waypoints_with_vibration_frequency_cancel_the_retimed_ringing():
    cfg = config(kinematics='planar_3dof', max_path_deviation=0.002,
                 vibration_frequency=4.0).with_defaults()
    cfg.validate()
    poses = np.array([[1.2, 0.3, 0.0], [1.0, 0.6, 0.2], [0.8, 0.2, -0.1]])
    tool = plan_tool_request(cfg, poses)
    # The lines' own timing is averaged over two windows of 1 / f; timed
    # again with the mode's ringing cancelled instead, this path is the shorter.
    smoothed = plan_tool_request(replace(cfg, speed_profile='smoothed'), poses)
    assert smoothed.trajectory.optimizer['smoothing_windows'] == [0.25, 0.25]
    optimizer = tool.trajectory.optimizer
    assert optimizer['speed_profile'] == 'time_optimal'
    # A 1 s move: 0.08 here, where the same lines without the mode leave 0.41.
    unshaped = plan_tool_request(replace(cfg, vibration_frequency=0.0), poses).trajectory
    assert optimizer['vibration_residual'] <= 0.3 * trajectory_residual(
        unshaped, 4.0, unshaped.limits.acceleration)
    assert tool.trajectory.duration < smoothed.trajectory.duration
    assert tool.trajectory.within_limits(rtol=1e-9)
    assert tool.max_deviation <= cfg.max_path_deviation


def test_no_spline_is_a_warning_and_the_plan_holds_every_limit(monkeypatch):
    def no_spline(*args):
        raise time_optimal.NoSpline('the profile stops inside the path')

    monkeypatch.setattr(planner, 'plan_time_optimal', no_spline)
    traj = plan_request(config(), request())
    warning = plan_warnings(traj)
    why = 'no time-optimal spline found: the profile stops inside the path'
    assert warning is not None and why in warning
    assert summary_values(traj, NAMES)['speed_profile_skipped'] == why
    assert traj.within_limits(rtol=1e-9)


def test_node_declares_and_validates_speed_profile():
    with LocalRos() as ros:
        node = ros.add(PlannerNode(context=ros.context, cli_args=[
            '--ros-args', '-p', 'method:=555', '-p', 'timing:=optimal']))
        assert node.parameters.config.speed_profile == 'smoothed'
        assert 'time_optimal' in node.describe_parameter('speed_profile').description
        # With an option it would ignore: refused with the reason, the old values kept.
        bad = node.set_parameters_atomically([
            Parameter('smoothing', value='none'),
            Parameter('speed_profile', value='time_optimal')])
        assert not bad.successful and 'would be ignored' in bad.reason
        assert node.parameters.config.speed_profile == 'smoothed'
        assert node.parameters.config.smoothing == 'auto'
        # The planar default has no jerk limit: the profile holds velocity and acceleration.
        good = node.set_parameters([Parameter('speed_profile', value='time_optimal')])[0]
        assert good.successful, good.reason
        assert node.parameters.config.speed_profile == 'time_optimal'
        unknown = node.set_parameters([Parameter('speed_profile', value='fast')])[0]
        assert not unknown.successful and 'speed_profile' in unknown.reason
        assert node.parameters.config.speed_profile == 'time_optimal'
