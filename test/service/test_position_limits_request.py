"""
The node's position limits reach the planning core (issue 38's follow-up).

``request_planning.plan_request`` hands the config's ``min_position`` /
``max_position`` and joint names to ``plan_with_options``, so a request
whose waypoints sit on the limits gets what plan() gives it: another plan
where the smoothed one leaves them (here the construction as it was
before, which crept past a start on a limit), and errors that name the
joint.
"""

import os
import re
import sys

import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.request_planning import (plan_request, plan_warnings, summary_values,
                                                     WaypointRequest)

sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', 'planning'))
from test_position_limits import (  # noqa: E402, F401, I100
    creeping_construction, creeping_request, no_pull, one_way_request)


def config_of(limits, low, high, speed_profile='smoothed'):
    n = low.size
    config = PlannerConfig(
        joint_names=tuple(f'j{i}' for i in range(n)),
        max_velocity=tuple(limits['max_velocity']),
        max_acceleration=tuple(limits['max_acceleration']),
        max_jerk=tuple(limits['max_jerk']), method='555', timing='optimal',
        min_position=tuple(low), max_position=tuple(high),
        speed_profile=speed_profile).with_defaults()
    config.validate()
    return config


def request_of(points):
    zeros = np.zeros(points.shape[1])
    return WaypointRequest(points, zeros, zeros, zeros, zeros, None)


@pytest.mark.usefixtures('creeping_construction')
def test_a_request_on_the_limits_is_planned_like_plan_plans_it():
    """The plan asked for, its knots moved within the limits: on the status, without a WARN."""
    points, limits, low, high = creeping_request()
    traj = plan_request(config_of(limits, low, high), request_of(points))
    ours = plan(points, '555', 'optimal', min_position=low, max_position=high, **limits)
    np.testing.assert_array_equal(traj.ppoly.c, ours.ppoly.c)
    status = summary_values(traj, [f'j{i}' for i in range(low.size)])
    assert re.fullmatch(r'knots moved to keep joint \d+ \(j\d+\)(, joint \d+ \(j\d+\))* '
                        r'within the position limits( \(.+\))?',
                        status['position_limit_knots']), status['position_limit_knots']
    assert 'speed_profile_reason' not in status
    assert plan_warnings(traj) is None


@pytest.mark.usefixtures('creeping_construction', 'no_pull')
def test_without_the_pull_a_request_on_the_limits_warns_of_the_other_plan():
    points, limits, low, high = creeping_request()
    traj = plan_request(config_of(limits, low, high), request_of(points))
    ours = plan(points, '555', 'optimal', min_position=low, max_position=high, **limits)
    np.testing.assert_array_equal(traj.ppoly.c, ours.ppoly.c)
    status = summary_values(traj, [f'j{i}' for i in range(low.size)])
    assert 'left the position limits' in status['speed_profile_reason']
    # Another plan than the one asked for: a WARN status says which and why.
    assert status['speed_profile_reason'] in plan_warnings(traj)
    assert plan_warnings(plan(points, '555', 'optimal', **limits)) is None


@pytest.mark.usefixtures('creeping_construction')
def test_a_request_past_the_limits_names_the_joint():
    points, limits, low, high = creeping_request()
    free = plan(points, '555', 'optimal', speed_profile='time_optimal', **limits)
    # Just inside the time-optimal plan's highest position of joint 0 (both profiles leave).
    j = 0
    tight = high.copy()
    tight[j] = min(free.position_extrema()[1][j],
                   plan(points, '555', 'optimal', **limits).position_extrema()[1][j]) - 1e-3
    with pytest.raises(ValueError, match=rf'joint {j} \(j{j}\) goes to .* above '
                                         rf'max_position\[{j}\]'):
        plan_request(config_of(limits, low, tight), request_of(points))


@pytest.mark.usefixtures('no_pull')
@pytest.mark.parametrize('speed_profile', ['smoothed', 'time_optimal'])
def test_a_move_every_profile_swings_out_of_warns_of_the_chord_length_plan(speed_profile):
    """
    The WARN says what the node publishes: the chord-length plan, not "smoothed".

    Seed 1098 of the planning tests' one-way moves: both profiles' paths
    leave the limits there, and (with the pull switched off, which would
    keep the plan asked for) timing "uniform" is what stays within.
    """
    points, limits = one_way_request(np.random.default_rng(1098))
    low, high = points.min(axis=0), points.max(axis=0)
    traj = plan_request(config_of(limits, low, high, speed_profile), request_of(points))
    assert traj.timing == 'uniform'
    np.testing.assert_array_equal(traj.ppoly.c, plan(points, '555', 'uniform', **limits).ppoly.c)
    warning = plan_warnings(traj)
    assert f'speed_profile "{speed_profile}" left the position limits' in warning
    assert warning.endswith('planned with timing "uniform" (chord-length durations) instead, '
                            'slower')
    assert 'planned with speed_profile "smoothed" instead' not in warning
    # A caller's durations start optimal timing; the chord-length plan has its own.
    warm = plan(points, '555', 'optimal', durations=np.ones(len(points) - 1),
                min_position=low, max_position=high, speed_profile=speed_profile, **limits)
    np.testing.assert_array_equal(warm.ppoly.c, traj.ppoly.c)


@pytest.mark.parametrize('low, high, match', [
    ([np.inf, -1.0], None, r'min_position\[0\] = inf leaves no position: use -inf'),
    (None, [1.0, -np.inf], r'max_position\[1\] = -inf leaves no position: use inf'),
])
def test_a_limit_infinite_on_the_side_it_bounds_is_refused(low, high, match):
    """Every request would be refused under it (helper-36): the limit is, naming the fix."""
    with pytest.raises(ValueError, match=match):
        plan(np.array([[0.0, 0.0], [0.5, 0.5]]), '555', 'optimal', max_velocity=[1.0, 1.0],
             max_acceleration=[2.0, 2.0], min_position=low, max_position=high)
    config = PlannerConfig(joint_names=('a', 'b'), min_position=tuple(low or ()),
                           max_position=tuple(high or ()))
    with pytest.raises(ValueError, match=match):
        config.validate_position_limits(2)
