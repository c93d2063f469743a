"""Every bad input to plan() is a ValueError that names the problem (and index)."""

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.planning.plan_options import PlanOptions

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
    # None is not NaN (it read "waypoints[] is nan"; helper-89).
    ('no waypoints', {'waypoints': None}, r'waypoints must be numbers, got None$'),
    ('a None boundary value', {'start_velocity': [None, 0.0]},
     r'start_velocity must be numbers, got None among them'),
    ('a None limit', {'max_velocity': [1.0, None]},
     r'max_velocity must be numbers, got None among them'),
    ('a vibration frequency of days', {'method': '555', 'timing': 'optimal',
                                       'vibration_frequency': 1e-6},
     r'vibration_frequency must be 0 \(not used\) or between 0\.1 and 1000 Hz, got 1e-06'),
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
    ('complex waypoints', {'waypoints': W + 1e-3j}, r'waypoints must be real'),
    ('complex limit', {'max_velocity': [1.0 + 1j, 1.0]}, r'max_velocity must be real'),
    # Planned as 1.0 before (helper-69); the scalar options refused booleans already.
    ('boolean limits', {'max_velocity': [True, True]}, r'max_velocity must be real numbers, '
                                                       r'got booleans'),
    ('a boolean boundary value', {'start_velocity': np.array([True, False])},
     r'start_velocity must be real numbers, got booleans'),
    ('boolean waypoints', {'waypoints': np.ones((3, 2), dtype=bool)},
     r'waypoints must be real numbers, got booleans'),
    ('timing as an array', {'timing': np.array(['uniform'])}, r'unknown timing'),
    ('position limit shape', {'max_position': [1.0]}, r'max_position must have one value'),
    ('NaN position limit', {'min_position': [np.nan, 0.0]}, r'min_position\[0\] is nan'),
    ('crossed position limits', {'min_position': [0.0, 1.0], 'max_position': [5.0, 0.0]},
     r'min_position\[1\] = 1\.0 is above max_position\[1\]'),
    # Issue 18: these gave inf/NaN coefficients and no error.
    ('huge limits', {'max_velocity': [1e300] * 2, 'max_acceleration': [1e300] * 2},
     r'not finite|no finite time scale'),
    ('tiny limits', {'max_velocity': [1e-81] * 2, 'max_acceleration': [1e-81] * 2},
     r'not finite|no finite time scale'),
    ('tiny fixed durations', {'timing': 'fixed', 'durations': [1e-63] * 3},
     r'not finite|numerically singular'),
    ('huge fixed durations', {'timing': 'fixed', 'durations': [1e100] * 3}, r'not finite'),
    ('segment below time resolution', {'timing': 'fixed', 'durations': [1e20, 1e-3, 1.0]},
     r'segment 1 .* shorter than the resolution'),
]


@pytest.mark.parametrize('name, change, message', CASES, ids=[c[0] for c in CASES])
def test_bad_input_raises_value_error_naming_the_problem(name, change, message):
    kwargs = {'waypoints': W, 'method': '445', 'timing': 'uniform', **LIM}
    kwargs.update(change)
    with pytest.raises(ValueError, match=message):
        plan(**kwargs)


BOUNDARY_NAMES = ('start_velocity', 'start_acceleration', 'end_velocity', 'end_acceleration')


@pytest.mark.parametrize('sign', [1.0, -1.0])
@pytest.mark.parametrize('name', BOUNDARY_NAMES)
def test_a_boundary_value_a_hair_past_its_limit_is_refused_and_on_it_is_planned(name, sign):
    # Joint 0's limits are above joint 1's: each value is checked against its own joint's.
    limits = {'max_velocity': [1.5, 1.0], 'max_acceleration': [3.0, 2.0]}
    own = np.array(limits['max_velocity' if name.endswith('velocity') else 'max_acceleration'])
    on = sign * own  # exactly on both joints' limits
    for timing in ('fixed', 'uniform'):
        durations = [1.0, 1.0, 1.0] if timing == 'fixed' else None
        past = on * np.array([1.0, 1.0 + 1e-9])
        with pytest.raises(ValueError, match=rf'infeasible: \|{name}\[1\]\| = .* of joint 1$'):
            plan(W, '445', timing, durations=durations, **limits, **{name: past})
        past = on * np.array([1.0 + 1e-9, 1.0 - 1e-9])
        with pytest.raises(ValueError, match=rf'infeasible: \|{name}\[0\]\| = .* of joint 0$'):
            plan(W, '445', timing, durations=durations, **limits, **{name: past})
        # The nodes' path names the joint too (helper-62: it said "joint 0" alone).
        boundary = [on * (1.0 + 1e-9) if b == name else None for b in BOUNDARY_NAMES]
        with pytest.raises(ValueError, match=rf'\|{name}\[0\]\| = .* of joint 0 \(elbow\)$'):
            PlanOptions.from_validated(2, '445', timing, *limits.values(), boundary=boundary,
                                       joint_names=('elbow', 'wrist'))
    traj = plan(W, '445', 'fixed', durations=[1.0, 1.0, 1.0], **limits, **{name: on})
    derivative = 1 if name.endswith('velocity') else 2
    time = 0.0 if name.startswith('start') else traj.duration
    np.testing.assert_allclose(traj.evaluate([time], derivative)[0], on, atol=1e-9)


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
    for period in (0.0, -1.0, np.nan, None, 'a', [0.01]):
        with pytest.raises(ValueError, match='sample period'):
            traj.sample(period)
    # A period that would need more than MAX_SAMPLES samples (44 TiB, issue 18).
    with pytest.raises(ValueError, match='more than'):
        traj.sample(1e-12)
    assert len(traj.sample(traj.duration / 1000).times) == 1001


def test_coefficients_are_built_on_the_widths_the_ppoly_uses():
    # cumsum([1e4, 1e-4]) leaves the second width off by 2e-12 s: with
    # coefficients built on 1e-4 the end acceleration came out as -7.1e-6.
    traj = plan([[0.0], [1.0], [1.0 + 1e-6]], '555', 'fixed', durations=[1e4, 1e-4])
    widths = np.diff(traj.ppoly.x)
    np.testing.assert_array_equal(traj.durations, widths)
    end = traj.duration
    assert abs(traj.evaluate([end], 2)[0, 0]) < 1e-9
    assert traj.evaluate([end])[0, 0] == pytest.approx(1.0 + 1e-6, abs=1e-12)
    assert abs(traj.evaluate([end], 1)[0, 0]) < 1e-9


def test_a_plan_whose_derivatives_overflow_is_refused():
    # Durations of 1e-61 s: finite coefficients, but the jerk's (60 c5) overflow,
    # and the plan was returned with an infinite jerk and NaN at its knots.
    with pytest.raises(ValueError, match='not finite'):
        plan(W, '445', 'fixed', durations=[10.0 ** -61.375] * 3)
    traj = plan(W, '445', 'fixed', durations=[1e-20] * 3)
    assert np.all(np.isfinite(traj.evaluate(traj.breakpoints, 3)))


# What plan() says when limits or durations are beyond what doubles carry.
FINITE_REFUSALS = ('is not finite', 'numerically singular')


@settings(max_examples=examples(40))
@given(st.floats(-90, 300), st.floats(-90, 300), st.floats(-70, 110),
       st.sampled_from(['445', '434', '555']), st.sampled_from(['uniform', 'optimal', 'fixed']))
def test_every_returned_trajectory_is_finite(log_v, log_a, log_t, method, timing):
    kwargs = {'max_velocity': [10.0 ** log_v] * 2, 'max_acceleration': [10.0 ** log_a] * 2}
    if timing == 'fixed':
        kwargs['durations'] = [10.0 ** log_t] * 3
    try:
        traj = plan(W, method, timing, **kwargs)
    except ValueError as exc:
        # Refused only for the number range itself, and saying so: within
        # 1e-6..1e6 every one of these requests plans.
        assert any(reason in str(exc) for reason in FINITE_REFUSALS), str(exc)
        exponents = [log_v, log_a] + ([log_t] if timing == 'fixed' else [])
        assert max(abs(e) for e in exponents) > 6.0, (exponents, str(exc))
        return
    assert np.all(np.isfinite(traj.ppoly.c)) and np.all(np.isfinite(traj.breakpoints))
    samples = traj.sample(traj.duration / 50)
    for values in samples:
        assert np.all(np.isfinite(values))
    assert np.all(np.isfinite(traj.evaluate(traj.breakpoints, 3)))
