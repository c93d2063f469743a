"""Every bad input to plan() is a ValueError that names the problem (and index)."""

import numpy as np
import pytest
from splines445_ros.planning import plan

W = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, -0.5], [2.5, 0.0]])
LIM = {'max_velocity': [1.0, 1.0], 'max_acceleration': [2.0, 2.0]}


def with_nan(array, index, value=np.nan):
    out = np.array(array, dtype=float)
    out[index] = value
    return out


CASES = [
    ('NaN waypoint', {'waypoints': with_nan(W, (2, 1))}, r'waypoints\[2, 1\] is nan'),
    ('inf waypoint', {'waypoints': with_nan(W, (0, 0), np.inf)}, r'waypoints\[0, 0\] is inf'),
    ('1-D waypoints', {'waypoints': [0.0, 1.0, 2.0]}, r'2-D'),
    ('one waypoint', {'waypoints': [[0.0, 1.0]]}, r'at least 2 waypoints'),
    ('no joints', {'waypoints': np.zeros((3, 0))}, r'at least one joint'),
    ('text waypoints', {'waypoints': [['a', 'b'], ['c', 'd']]}, r'numeric'),
    ('ragged waypoints', {'waypoints': [[0.0, 1.0], [1.0]]}, r'waypoints'),
    ('unknown method', {'method': '345'}, r'unknown method'),
    ('unknown timing', {'timing': 'fast'}, r'unknown timing'),
    ('zero velocity limit', {'max_velocity': [1.0, 0.0]}, r'max_velocity\[1\] = 0\.0'),
    ('negative acceleration limit', {'max_acceleration': [-1.0, 1.0]},
     r'max_acceleration\[0\] = -1\.0'),
    ('NaN jerk limit', {'max_jerk': [np.nan, 1.0]}, r'max_jerk\[0\] = nan'),
    ('inf velocity limit', {'max_velocity': [np.inf, 1.0]}, r'max_velocity\[0\] = inf'),
    ('limit shape', {'max_velocity': [1.0, 1.0, 1.0]}, r'max_velocity must have one value'),
    ('missing acceleration limit', {'max_acceleration': None}, r'given together'),
    ('uniform without limits', {'max_velocity': None, 'max_acceleration': None},
     r'needs max_velocity'),
    ('start velocity over limit', {'start_velocity': [0.0, 1.5]},
     r'infeasible: \|start_velocity\[1\]\|'),
    ('end acceleration over limit', {'end_acceleration': [-2.5, 0.0]},
     r'infeasible: \|end_acceleration\[0\]\|'),
    ('NaN boundary', {'start_acceleration': [0.0, np.nan]},
     r'start_acceleration\[1\] is nan'),
    ('boundary shape', {'end_velocity': [0.0]}, r'end_velocity must have shape \(2,\)'),
    ('fixed without durations', {'timing': 'fixed'}, r'needs durations'),
    ('zero duration', {'timing': 'fixed', 'durations': [1.0, 0.0, 1.0]},
     r'durations\[1\] = 0\.0'),
    ('negative duration', {'timing': 'fixed', 'durations': [1.0, 1.0, -2.0]},
     r'durations\[2\] = -2\.0'),
    ('NaN duration', {'timing': 'fixed', 'durations': [np.nan, 1.0, 1.0]},
     r'durations\[0\] is nan'),
    ('durations count', {'timing': 'fixed', 'durations': [1.0, 1.0]}, r'one value per segment'),
    ('durations with uniform', {'durations': [1.0, 1.0, 1.0]}, r'only used with timing'),
    ('optimal start count', {'timing': 'optimal', 'durations': [1.0, 1.0]},
     r'one value per segment'),
    ('optimal start negative', {'timing': 'optimal', 'durations': [1.0, -1.0, 1.0]},
     r'durations\[1\] = -1\.0'),
    ('all waypoints equal', {'waypoints': np.ones((4, 2))}, r'all waypoints coincide'),
    ('integer method not a method', {'method': 345},
     r'unknown method 345: expected one of \(.445., .434., .555.\)'),
    ('boolean method', {'method': True}, r'unknown method True'),
]


@pytest.mark.parametrize('name, change, message', CASES, ids=[c[0] for c in CASES])
def test_bad_input_raises_value_error_naming_the_problem(name, change, message):
    kwargs = {'waypoints': W, 'method': '445', 'timing': 'uniform', **LIM}
    kwargs.update(change)
    with pytest.raises(ValueError, match=message):
        plan(**kwargs)


@pytest.mark.parametrize('method', ['445', '434', '555'])
def test_consecutive_duplicates_are_merged_and_reported(method):
    dup = np.array([W[0], W[1], W[1], W[2], W[2], W[2], W[3], W[3]])
    traj = plan(dup, method, 'uniform', **LIM)
    assert traj.dropped_waypoints == (2, 4, 5, 7)
    reference = plan(W, method, 'uniform', **LIM)
    np.testing.assert_allclose(traj.durations, reference.durations, rtol=1e-12)
    # The trajectory still passes through every waypoint the caller sent.
    np.testing.assert_allclose(traj.evaluate(traj.breakpoints), W, atol=1e-12)
    assert np.all(np.isfinite(traj.ppoly.c))


def test_fixed_timing_keeps_duplicates_with_given_durations():
    dup = np.array([W[0], W[1], W[1], W[2]])
    traj = plan(dup, '445', 'fixed', durations=[1.0, 0.5, 1.0])
    assert traj.dropped_waypoints == ()
    np.testing.assert_allclose(traj.evaluate(traj.breakpoints), dup, atol=1e-12)


def test_fixed_timing_reports_limit_violation_without_raising():
    traj = plan(W, '445', 'fixed', durations=[0.1, 0.1, 0.1], **LIM)
    assert not traj.within_limits()
    assert traj.binding.ratio > 1.0
    slow = plan(W, '445', 'fixed', durations=[10.0, 10.0, 10.0], **LIM)
    assert slow.within_limits()


def test_evaluate_rejects_unknown_derivative_and_sample_bad_period():
    traj = plan(W, '445', 'uniform', **LIM)
    with pytest.raises(ValueError, match='derivative'):
        traj.evaluate([0.0], derivative=4)
    for period in (0.0, -1.0, np.nan):
        with pytest.raises(ValueError, match='sample period'):
            traj.sample(period)
