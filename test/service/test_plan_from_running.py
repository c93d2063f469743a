"""Replanning from a running trajectory: a later switch where the state admits no plan."""

from hypothesis import given, strategies as st
import numpy as np
import pytest
from reference_spline import random_limits
from splines445_ros.nodes.ros_conversions import WaypointRequest
from splines445_ros.planning import DEFAULT_WAYPOINT_TOLERANCE, plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.request_planning import (ends_at_rest, plan_from_running,
                                                     REPLAN_MAX_DELAY, REPLAN_RETRY_STEP,
                                                     running_in_order)

SECOND = np.array([[0.2, 2.0, -2.0], [0.6, 1.6, -2.2], [0.9, 1.2, -1.5]])
VMAX, AMAX = 2.0, 10.0


def request_to(waypoints):
    zero = np.zeros(waypoints.shape[1])
    # A copy: a test that spoils its request must not spoil the module's SECOND.
    return WaypointRequest(np.array(waypoints, dtype=float), zero, zero, zero, zero, None)


def config_for(n_joints, method, vmax, amax, jmax):
    return PlannerConfig(
        joint_names=tuple(f'j{i}' for i in range(n_joints)), max_velocity=tuple(vmax),
        max_acceleration=tuple(amax),
        max_jerk=() if jmax is None else tuple(jmax), method=method)


def direct_plan(running, t, waypoints, method, vmax, amax, jmax=None):
    """Plan from the running state at t with the planning core itself, or None."""
    p, v, a = (running.evaluate([t], d)[0] for d in (0, 1, 2))
    try:
        return plan(np.vstack([p, waypoints]), method=method, max_velocity=vmax,
                    max_acceleration=amax, max_jerk=jmax, start_velocity=v,
                    start_acceleration=a)
    except ValueError:
        return None


def assert_continues(running, t, traj, waypoints, vmax, amax, jmax=None):
    """Check that traj starts in running's state at t, passes the waypoints, holds the limits."""
    for d in (0, 1, 2):
        np.testing.assert_allclose(traj.evaluate([0.0], d)[0], running.evaluate([t], d)[0],
                                   rtol=1e-9, atol=1e-9 * 10 ** d)
    # Every waypoint is passed; one within the merging tolerance of its neighbour (or of
    # the start state) is merged with it (the long hypothesis run drew pairs 4e-4 apart).
    kept = traj.waypoints
    for point in waypoints:
        assert np.min(np.max(np.abs(kept - point), axis=1)) <= DEFAULT_WAYPOINT_TOLERANCE
    far = np.all(np.max(np.abs(np.diff(np.vstack([kept[:1], waypoints]), axis=0)), axis=1)
                 > DEFAULT_WAYPOINT_TOLERANCE)
    if far:
        np.testing.assert_allclose(kept[-len(waypoints):], waypoints, atol=1e-12)
    np.testing.assert_allclose(traj.evaluate([traj.duration])[0], waypoints[-1], atol=1e-9)
    t_dense = np.linspace(0.0, traj.duration, 4001)
    assert np.all(np.abs(traj.evaluate(t_dense, 1)) <= np.asarray(vmax) * (1 + 1e-6))
    assert np.all(np.abs(traj.evaluate(t_dense, 2)) <= np.asarray(amax) * (1 + 1e-6))
    if jmax is not None:
        assert np.all(np.abs(traj.evaluate(t_dense, 3)) <= np.asarray(jmax) * (1 + 1e-6))


@pytest.fixture(scope='module')
def paper_running():
    limits = {'max_velocity': [VMAX] * 3, 'max_acceleration': [AMAX] * 3}
    return plan(pe.joint_waypoints(), method='445', **limits)


def test_a_state_without_a_plan_switches_at_the_first_later_time_that_has_one(paper_running):
    config = config_for(3, '445', [VMAX] * 3, [AMAX] * 3, None)
    vmax, amax = [VMAX] * 3, [AMAX] * 3
    times = np.arange(0.0, paper_running.duration - 0.3, 0.02)
    stuck = [t for t in times
             if direct_plan(paper_running, t, SECOND, '445', vmax, amax) is None]
    assert stuck, 'precondition: the paper example has states without a 445 uniform plan'
    for t in stuck:
        used, traj = plan_from_running(config, request_to(SECOND), paper_running, t)
        assert t < used <= t + REPLAN_MAX_DELAY + 1e-12
        # the first candidate on the grid that the planning core can plan from
        k = int(round((used - t) / REPLAN_RETRY_STEP))
        assert used == pytest.approx(t + k * REPLAN_RETRY_STEP, abs=1e-12)
        for earlier in range(k):
            assert direct_plan(paper_running, t + earlier * REPLAN_RETRY_STEP, SECOND,
                               '445', vmax, amax) is None
        reference = direct_plan(paper_running, used, SECOND, '445', vmax, amax)
        assert reference is not None
        np.testing.assert_allclose(traj.durations, reference.durations, rtol=1e-12)
        assert_continues(paper_running, used, traj, SECOND, vmax, amax)


def test_a_plannable_state_switches_when_asked(paper_running):
    config = config_for(3, '445', [VMAX] * 3, [AMAX] * 3, None)
    for t in np.arange(0.0, paper_running.duration, 0.25):
        if direct_plan(paper_running, t, SECOND, '445', [VMAX] * 3, [AMAX] * 3) is None:
            continue
        used, traj = plan_from_running(config, request_to(SECOND), paper_running, t)
        assert used == t
        assert_continues(paper_running, t, traj, SECOND, [VMAX] * 3, [AMAX] * 3)


def test_candidates_the_clock_has_passed_are_not_tried(paper_running):
    config = config_for(3, '445', [VMAX] * 3, [AMAX] * 3, None)
    stuck = next(t for t in np.arange(0.0, paper_running.duration - 1.5, 0.01)
                 if direct_plan(paper_running, t, SECOND, '445', [VMAX] * 3,
                                [AMAX] * 3) is None)
    with pytest.raises(ValueError, match='infeasible') as error:
        plan_from_running(config, request_to(SECOND), paper_running, stuck,
                          clock=lambda: np.inf)
    assert 'later times' not in str(error.value)
    calls = []

    def clock():  # the clock is at the requested switch time, then halfway to the next
        calls.append(None)
        return stuck + REPLAN_RETRY_STEP * (len(calls) - 0.5)
    used, _ = plan_from_running(config, request_to(SECOND), paper_running, stuck, clock)
    assert used > stuck
    assert calls


def test_a_bad_request_is_rejected_with_its_own_reason(paper_running):
    config = config_for(3, '445', [VMAX] * 3, [AMAX] * 3, None)
    bad = request_to(SECOND)
    bad.waypoints[1, 2] = np.nan
    with pytest.raises(ValueError, match='finite|NaN|nan') as error:
        plan_from_running(config, bad, paper_running, 0.5)
    assert 'later times' in str(error.value)


@given(seed=st.integers(0, 2**32 - 1), method=st.sampled_from(['434', '445', '555']),
       fraction=st.floats(0.0, 1.0))
def test_replanning_from_a_running_trajectory_continues_it_or_says_why(
        seed, method, fraction):
    rng = np.random.default_rng(seed)
    n_joints = int(rng.integers(1, 4))
    vmax, amax, jmax, _ = random_limits(rng, n_joints, 0.0)
    running = plan(np.cumsum(rng.uniform(-1, 1, (int(rng.integers(2, 6)), n_joints)), axis=0),
                   method=method, max_velocity=vmax, max_acceleration=amax, max_jerk=jmax)
    waypoints = running.waypoints[-1] + np.cumsum(
        rng.uniform(-1, 1, (int(rng.integers(1, 4)), n_joints)), axis=0)
    t = fraction * running.duration
    config = config_for(n_joints, method, vmax, amax, jmax)
    try:
        used, traj = plan_from_running(config, request_to(waypoints), running, t)
    except ValueError as exc:
        # Only possible when the end (at rest, always plannable) is out of reach.
        assert running.duration > t + REPLAN_MAX_DELAY, str(exc)
        assert direct_plan(running, t, waypoints, method, vmax, amax, jmax) is None
        return
    assert t <= used <= min(t + REPLAN_MAX_DELAY, max(t, running.duration)) + 1e-12
    assert_continues(running, used, traj, waypoints, vmax, amax, jmax)


def test_ends_at_rest_is_the_stop_rule_at_the_trajectory_end():
    """A rest-to-rest plan ends at rest; one with an end velocity only below the tolerance."""
    config = config_for(3, '555', [VMAX] * 3, [AMAX] * 3, None)
    kwargs = {'method': '555', 'max_velocity': [VMAX] * 3, 'max_acceleration': [AMAX] * 3}
    assert ends_at_rest(config, plan(SECOND, **kwargs))
    # Braking from v at the acceleration limit a travels v**2 / 2a (no jerk limit): written
    # out here against the tolerance, just above and just below it.
    tolerance = config.waypoint_tolerance
    for share, expected in ((1.05, False), (0.95, True)):
        speed = np.sqrt(2.0 * AMAX * tolerance * share)
        moving = plan(SECOND, end_velocity=[0.0, speed, 0.0], **kwargs)
        assert ends_at_rest(config, moving) is expected, (share, speed)


def test_the_running_trajectory_in_another_joint_order(paper_running):
    """Reordered names read the same columns; other joints give None."""
    names = ('a', 'b', 'c')
    assert running_in_order(paper_running, names, names) is paper_running
    assert running_in_order(paper_running, names, ('a', 'b')) is None
    assert running_in_order(paper_running, names, ('a', 'b', 'd')) is None
    view = running_in_order(paper_running, names, ('c', 'a', 'b'))
    assert view.duration == paper_running.duration
    t = np.linspace(0.0, paper_running.duration, 7)
    for d in (0, 1, 2):
        np.testing.assert_array_equal(view.evaluate(t, d),
                                      paper_running.evaluate(t, d)[:, [2, 0, 1]])
