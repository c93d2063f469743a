"""
The node builds a request's PlanOptions once, from its validated config (issue 37).

``request_planning.plan_options`` takes the config's values as they are
(``PlanOptions.from_validated``) and checks only what comes with the
request.  The cross-check here is plan()'s own validation,
``PlanOptions.from_arguments``, fed the same values as plan()'s keyword
arguments: on random valid configs and random boundaries (feasible,
infeasible, of the wrong length) both must give the same options, field by
field, or the same error text.
"""

import math
import re

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.planning.plan_options import PlanOptions
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.request_planning import plan_options, TorqueOptions

# 555 optimal (the only one with inner knots, vibration_frequency and smoothing):
# a third of the draws.
METHOD_TIMINGS = ([(m, t) for m in ('434', '445', '555') for t in ('uniform', 'optimal', 'fixed')]
                  + [('555', 'optimal')] * 4)


def _gravity(n):
    """Return an inverse dynamics of n joints: a constant-gravity load plus the inertia terms."""
    def inverse_dynamics(q, qd, qdd):
        return 0.5 * np.sin(q) + np.asarray(qdd) + 0.1 * np.asarray(qd)
    return inverse_dynamics


@st.composite
def configs(draw):
    """Draw a PlannerConfig its parameter layer accepts (others are discarded)."""
    n = draw(st.integers(1, 7))
    method, timing = draw(st.sampled_from(METHOD_TIMINGS))
    limit = st.floats(0.1, 50.0)
    jerk_value = st.one_of(st.just(0.0), st.floats(1.0, 500.0))
    jerk = draw(st.one_of(st.just(()), st.lists(jerk_value, min_size=n, max_size=n)))
    optimal_555 = (method, timing) == ('555', 'optimal')
    knots = draw(st.sampled_from([-1, 0, 1, 3]) if optimal_555 else st.just(-1))
    vibration = draw(st.sampled_from([0.0, 2.5, 8.0])) if optimal_555 and knots else 0.0
    smoothing = (draw(st.sampled_from(['auto', 'windows', 'none']))
                 if optimal_555 and knots and not vibration else 'auto')
    # Position limits: none, one side or both (the node's config is validated).
    sides = draw(st.sampled_from([(), ('min',), ('max',), ('min', 'max')]))
    low = tuple(draw(st.lists(st.floats(-5.0, 0.0), min_size=n, max_size=n))
                if 'min' in sides else ())
    high = tuple(draw(st.lists(st.floats(0.0, 5.0), min_size=n, max_size=n))
                 if 'max' in sides else ())
    config = PlannerConfig(
        joint_names=tuple(f'j{i}' for i in range(n)), min_position=low, max_position=high,
        max_velocity=tuple(draw(st.lists(limit, min_size=n, max_size=n))),
        max_acceleration=tuple(draw(st.lists(limit, min_size=n, max_size=n))),
        max_jerk=tuple(jerk), method=method, timing=timing, inner_knots=knots,
        vibration_frequency=vibration, smoothing=smoothing,
        waypoint_tolerance=draw(st.sampled_from([0.0, 1e-6, 1e-3]))).with_defaults()
    config.validate()
    return config


@st.composite
def boundaries(draw, n):
    """
    Draw start/end velocity and acceleration.

    Mostly at rest (None or zeros), often moving within a fraction of the
    limits, sometimes beyond them (maybe infeasible) or of the wrong length.
    """
    kind = draw(st.sampled_from(['rest'] * 5 + ['moving'] * 3 + ['large', 'short']))

    def vector(scale):
        if kind == 'rest':
            return draw(st.sampled_from([None, np.zeros(n)]))
        size = n if kind != 'short' else n + 1
        return scale * np.array(draw(st.lists(st.floats(-1.0, 1.0), min_size=size,
                                              max_size=size)))
    scale = {'rest': 0.0, 'moving': 0.05, 'large': 60.0, 'short': 1.0}[kind]
    return tuple(vector(scale) for _ in range(4))


def _outcome(build):
    """Return ('ok', options) or ('error', text) of one way of building the options."""
    try:
        return 'ok', build()
    except ValueError as exc:
        return 'error', str(exc)


def _same_field(a, b):
    if a is None or b is None:
        return a is None and b is None
    if isinstance(a, tuple):
        return len(a) == len(b) and all(_same_field(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a, float), np.asarray(b, float))
    return a == b


def _assert_same_options(ours, theirs):
    for field in ('method', 'timing', 'boundary', 'waypoint_tolerance', 'inner_knots',
                  'inner_knots_auto', 'vibration_frequency', 'smoothing', 'windows',
                  'min_position', 'max_position'):
        assert _same_field(getattr(ours, field), getattr(theirs, field)), field
    assert (ours.limits is None) == (theirs.limits is None)
    if ours.limits is not None:
        for part in ('velocity', 'acceleration', 'jerk'):
            assert np.array_equal(getattr(ours.limits, part), getattr(theirs.limits, part)), part
    assert (ours.torque is None) == (theirs.torque is None)
    if ours.torque is not None:
        assert np.array_equal(ours.torque.max_torque, theirs.torque.max_torque)
        assert ours.torque.inverse_dynamics is theirs.torque.inverse_dynamics


def _from_arguments(config, n, boundary, torque):
    start_v, start_a, end_v, end_a = boundary
    return PlanOptions.from_arguments(
        n, method=config.method, timing=config.timing, max_velocity=list(config.max_velocity),
        max_acceleration=list(config.max_acceleration), max_jerk=config.jerk_limits(),
        start_velocity=start_v, start_acceleration=start_a, end_velocity=end_v,
        end_acceleration=end_a, waypoint_tolerance=config.waypoint_tolerance,
        min_position=config.min_position or None, max_position=config.max_position or None,
        inner_knots=config.plan_inner_knots(), vibration_frequency=config.vibration_frequency,
        smoothing=config.smoothing,
        max_torque=None if torque is None else torque.max_torque,
        inverse_dynamics=None if torque is None else torque.inverse_dynamics)


def _named(text, names, width):
    """plan()'s text of an infeasible boundary value, with the joint's name the node adds."""
    found = re.search(r'of joint (\d+)$', text)
    if found is None or len(names) != width:
        return text
    return f'{text} ({names[int(found.group(1))]})'


@settings(max_examples=examples(150), deadline=None)
@given(data=st.data())
def test_node_options_are_plans_own(data):
    """Same options or the same error as plan()'s validation, for any request of a valid config."""
    config = data.draw(configs())
    n = len(config.joint_names)
    # Mostly the config's own joint count; sometimes a request of another width.
    width = data.draw(st.sampled_from([n] * 5 + [n + 1]))
    boundary = data.draw(boundaries(width))
    torque = None
    if data.draw(st.booleans()):
        effort = data.draw(st.lists(st.floats(0.6, 40.0), min_size=n, max_size=n))
        torque = TorqueOptions(np.array(effort), _gravity(n))
    ours = _outcome(lambda: plan_options(config, width, boundary, torque))
    theirs = _outcome(lambda: _from_arguments(config, width, boundary, torque))
    assert ours[0] == theirs[0], (ours, theirs)
    if ours[0] == 'error':
        assert ours[1] == _named(theirs[1], config.joint_names, width)
    else:
        _assert_same_options(ours[1], theirs[1])


def test_infeasible_boundary_is_refused_with_plans_text():
    """A start velocity above the limit: the node's options refuse it as plan() does."""
    config = PlannerConfig(joint_names=('a', 'b'), max_velocity=(1.0, 1.0),
                           max_acceleration=(5.0, 5.0), method='555',
                           timing='optimal').with_defaults()
    config.validate()
    boundary = (np.array([2.0, 0.0]), None, None, None)
    with pytest.raises(ValueError) as ours:
        plan_options(config, 2, boundary)
    with pytest.raises(ValueError) as theirs:
        _from_arguments(config, 2, boundary, None)
    assert str(ours.value) == _named(str(theirs.value), config.joint_names, 2)
    assert str(ours.value).endswith('of joint 0 (a)')
    assert 'velocity' in str(ours.value)
    assert math.isfinite(config.max_velocity[0])
