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
import sys

import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.request_planning import (plan_request, plan_warnings, summary_values,
                                                     WaypointRequest)

sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', 'planning'))
from test_position_limits import creeping_construction, creeping_request  # noqa: E402, F401, I100


def config_of(limits, low, high):
    n = low.size
    config = PlannerConfig(
        joint_names=tuple(f'j{i}' for i in range(n)),
        max_velocity=tuple(limits['max_velocity']),
        max_acceleration=tuple(limits['max_acceleration']),
        max_jerk=tuple(limits['max_jerk']), method='555', timing='optimal',
        min_position=tuple(low), max_position=tuple(high)).with_defaults()
    config.validate()
    return config


def request_of(points):
    zeros = np.zeros(points.shape[1])
    return WaypointRequest(points, zeros, zeros, zeros, zeros, None)


@pytest.mark.usefixtures('creeping_construction')
def test_a_request_on_the_limits_is_planned_like_plan_plans_it():
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
