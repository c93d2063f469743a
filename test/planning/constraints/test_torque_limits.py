"""
Torque limits in plan() (issue 25): the rigid-body torque within its limits at dense samples.

The torques are computed here, at 10 kHz, by the two-link arm's closed-form
dynamics of ``test_path_constraints`` (the planner only calls it), and on the
UR5 with a payload by :class:`ArmDynamics` (checked against a Newton-Euler
written in ``test_dynamics``).
"""

import math
import os
import re

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.planning.constraints import GriddedPath, JointTorque
from splines445_ros.planning.constraints.torque import GravityOverload, TorqueLimit
from test_path_constraints import two_link_torques
from test_position_limit_knots import cut_limits

EXAMPLES = int(os.environ.get('SPLINES445_PROPERTY_EXAMPLES', str(examples(12))))
# The 1 kHz check holds the torque within 0.5 % between its samples (issue 25).
TORQUE_RTOL = 5e-3
ROUTES = [('555', 'optimal'), ('555', 'uniform'), ('445', 'uniform'), ('434', 'optimal')]
# With torque limits and no smoothing windows there is no knots-only rival:
# the inner-knot plan was up to 1.95 % longer than plan(inner_knots=0) on a
# few requests in a thousand (test_with_torque_limits_a_plan_is_not_longer_...).
NO_RIVAL_GAP = 0.03


def dense_torques(traj, dynamics, rate=10000.0):
    """Return the torques (K, n) of ``traj`` sampled at ``rate``."""
    t = np.linspace(0.0, traj.duration, int(traj.duration * rate) + 2)
    return dynamics(traj.evaluate(t), traj.evaluate(t, 1), traj.evaluate(t, 2))


def random_request(rng):
    """Waypoints of the two-link arm and torque limits gravity alone stays well within."""
    n = int(rng.integers(3, 8))
    points = np.cumsum(rng.uniform(-0.8, 0.8, (n, 2)), axis=0)
    s = np.linspace(0.0, 1.0, 400)
    path = plan(points, '555', 'fixed', durations=np.ones(n - 1))
    q = path.evaluate(s * path.duration)
    gravity = np.max(np.abs(two_link_torques(q, 0 * q, 0 * q)), axis=0)
    # Gravity along the chord spline; another timing's path is the same
    # curve only for the same method: keep a wide margin.
    limit = gravity * rng.uniform(1.5, 3.0, 2) + rng.uniform(3.0, 10.0, 2)
    return points, limit


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), route=st.sampled_from(ROUTES))
def test_torque_held_at_dense_samples_and_something_binds(seed, route):
    rng = np.random.default_rng(seed)
    points, limit = random_request(rng)
    method, timing = route
    kwargs = {'max_velocity': [4.0, 4.0], 'max_acceleration': [200.0, 200.0],
              'max_jerk': [4000.0, 4000.0]}
    try:
        traj = plan(points, method, timing, max_torque=limit, inverse_dynamics=two_link_torques,
                    **kwargs)
    except ValueError as exc:
        # Gravity alone beyond a limit on another timing's path: refused by name.
        assert 'gravity alone' in str(exc)
        return
    tau = dense_torques(traj, two_link_torques)
    peak = np.max(np.abs(tau), axis=0) / limit
    assert np.all(peak <= 1.0 + TORQUE_RTOL), peak
    assert traj.within_limits(rtol=1e-6)
    # Through every waypoint at its time.
    np.testing.assert_allclose(traj.evaluate(traj.waypoint_times), traj.waypoints, atol=1e-9)
    # The reported ratios are the peaks.
    np.testing.assert_allclose(traj.torque_ratios, peak, rtol=2e-2, atol=1e-3)
    # Not slower than it must be: a torque, or a v/a/j limit, is reached.
    vaj = np.max(traj.limit_ratios())
    assert max(peak.max(), vaj) >= 0.98


@pytest.mark.parametrize('points, timing, limits, limit', [
    # The torque peaked at a knot, 0.78 % over its limit, reported at 1.0 (helper-37).
    ([[0.2545308251862506, 0.6827233510361046], [1.0146447711011617, 0.64173246416802],
      [0.6645234755702696, 0.5874201306232414]], 'uniform',
     {'max_velocity': [17.411794626001193] * 2, 'max_acceleration': [1452.688135899128] * 2},
     [33.529843843939176, 5.819234915390972]),
    # Slowed down 9 times, 0.67 % over between the check's rescaled samples.
    ([[2.9131226674704447, 1.2712139062355705], [3.4495207258760825, 1.9279430183484896],
      [3.7354054460392545, 2.3781641551832817], [4.303362392360823, 2.95421926713308],
      [4.999323994894189, 3.1600079071996032], [5.448165853422575, 3.487498076881947],
      [6.162738335674174, 3.720812796218737], [6.663294831801214, 3.8429031936156224]],
     'optimal', {'max_velocity': [711.8134680567863, 1774.17807426649],
                 'max_acceleration': [1211.252298787869, 1802.5700052921238],
                 'max_jerk': [11877189.69769385, 5212402.017236341]},
     [25.650537508817287, 6.8964883554266105]),
])
def test_a_434_plan_holds_its_torque_at_its_knots(points, timing, limits, limit):
    """434's jerk jumps at its knots: the torque has a kink there, sampled since (100 kHz here)."""
    limit = np.array(limit)
    traj = plan(np.array(points), '434', timing, max_torque=limit,
                inverse_dynamics=two_link_torques, **limits)
    peak = np.max(np.abs(dense_torques(traj, two_link_torques, rate=1e5)), axis=0) / limit
    assert np.all(peak <= 1.0), peak
    assert np.all(traj.torque_ratios >= peak - 1e-9)     # reported at least as high


def test_torque_binds_where_the_acceleration_limit_does_not():
    """High acceleration limits: the torque sets the time, and it is shorter than its uniform."""
    rng = np.random.default_rng(4)
    points, limit = random_request(rng)
    kwargs = {'max_velocity': [20.0, 20.0], 'max_acceleration': [1e4, 1e4],
              'max_jerk': [1e6, 1e6]}
    optimal = plan(points, '555', 'optimal', max_torque=limit,
                   inverse_dynamics=two_link_torques, **kwargs)
    uniform = plan(points, '555', 'uniform', max_torque=limit,
                   inverse_dynamics=two_link_torques, **kwargs)
    for traj in (optimal, uniform):
        peak = np.max(np.abs(dense_torques(traj, two_link_torques)), axis=0) / limit
        assert 0.99 <= peak.max() <= 1.0 + TORQUE_RTOL
    assert optimal.duration < uniform.duration


def test_gravity_alone_beyond_a_limit_is_refused_with_the_joint():
    points = np.array([[0.0, 0.0], [0.5, 0.3], [1.0, -0.2]])
    with pytest.raises(ValueError, match='joint 0: gravity alone needs'):
        plan(points, '555', 'optimal', max_velocity=[2, 2], max_acceleration=[20, 20],
             max_torque=[5.0, 50.0], inverse_dynamics=two_link_torques)


def test_gravity_beyond_a_limit_is_refused_even_where_the_motion_holds_the_torque():
    """
    A bump of gravity above the limit, crossed while accelerating against it.

    The torque ``qdd + g(q)`` stays within 1 at these durations (peak about
    0.93), but no slower timing would hold it at the bump: the request is
    refused, whatever the timing (an optimisation once skipped the gravity
    pass of a check that held).
    """
    def bump(q, qd, qdd):
        return qdd + 1.5 * np.exp(-((q - 0.75) / 0.03) ** 2)

    with pytest.raises(ValueError, match='gravity alone needs'):
        plan(np.array([[0.0], [1.0]]), '445', 'fixed', durations=[2.6], max_torque=[1.0],
             inverse_dynamics=bump)


def test_fixed_timing_is_checked_not_slowed():
    points = np.array([[0.0, 0.0], [1.0, 0.5], [0.5, 1.0]])
    with pytest.raises(ValueError, match='torque limit with the given durations'):
        plan(points, '555', 'fixed', durations=[0.1, 0.1], max_torque=[60.0, 30.0],
             inverse_dynamics=two_link_torques)
    slow = plan(points, '555', 'fixed', durations=[5.0, 5.0], max_torque=[60.0, 30.0],
                inverse_dynamics=two_link_torques)
    assert slow.duration == pytest.approx(10.0) and np.all(slow.torque_ratios < 1.0)


@pytest.mark.parametrize('kwargs, message', [
    ({'max_torque': [50.0, 50.0]}, 'given together'),
    ({'inverse_dynamics': two_link_torques}, 'given together'),
    ({'max_torque': [50.0], 'inverse_dynamics': two_link_torques}, 'one value per joint'),
    ({'max_torque': [50.0, -1.0], 'inverse_dynamics': two_link_torques}, r'max_torque\[1\]'),
    ({'max_torque': [50.0, 50.0], 'inverse_dynamics': 'tau'}, 'inverse_dynamics'),
    ({'max_torque': [50.0, 50.0], 'inverse_dynamics': two_link_torques,
      'start_velocity': [0.1, 0.0]}, 'rest to rest'),
])
def test_bad_torque_arguments_are_refused(kwargs, message):
    points = np.array([[0.0, 0.0], [0.5, 0.3], [1.0, -0.2]])
    with pytest.raises(ValueError, match=message):
        plan(points, '555', 'optimal', max_velocity=[2, 2], max_acceleration=[20, 20], **kwargs)


def loaded_arm(robot_name, payload_mass, seed, n_points):
    """
    Return a vendor arm's ArmDynamics with a payload, its effort limits and random waypoints.

    ``robot_name`` 'ur5' or 'panda'; the payload's centre of mass is 0.1 m
    out along the tool; the waypoints (n_points, n) are a random walk of
    steps up to 0.3 rad from the ready pose.
    """
    from splines445_ros.robot.dynamics import ArmDynamics, effort_limits
    from splines445_ros.robot.robot_model import load_robot_model
    from splines445_ros.tools import vendor_robots as vr
    urdf, joints, tool, ready = {
        'ur5': (vr.ur5_urdf, vr.UR5_JOINTS, 'tool0', vr.UR5_READY),
        'panda': (vr.panda_urdf, vr.PANDA_ARM_JOINTS, 'panda_hand_tcp', vr.PANDA_READY),
    }[robot_name]
    robot = load_robot_model(urdf())
    joints = list(joints)
    dynamics = ArmDynamics(robot, joints, tool, payload_mass=payload_mass,
                           payload_center_of_mass=(0.0, 0.0, 0.1))
    rng = np.random.default_rng(seed)
    steps = rng.uniform(-0.3, 0.3, (n_points, len(joints)))
    return dynamics, effort_limits(robot, joints), np.array(ready) + np.cumsum(steps, axis=0)


def test_ur5_with_a_payload_holds_its_effort_limits():
    dynamics, limit, points = loaded_arm('ur5', 5.0, 7, 6)
    kwargs = {'max_velocity': [3.15] * 3 + [3.2] * 3, 'max_acceleration': [1000.0] * 6,
              'max_jerk': [500.0] * 6}
    traj = plan(points, '555', 'optimal', max_torque=limit, inverse_dynamics=dynamics.torques,
                **kwargs)
    peak = np.max(np.abs(dense_torques(traj, dynamics.torques, 5000.0)), axis=0) / limit
    assert np.all(peak <= 1.0 + TORQUE_RTOL)
    assert max(peak.max(), np.max(traj.limit_ratios())) >= 0.98


class WithGravity:
    """An inverse dynamics with a ``gravity`` attribute, counting the calls of both."""

    def __init__(self, torques, gravity):
        self.torques, self.gravity_of = torques, gravity
        self.at_rest = self.calls = self.gravity_calls = 0

    def __call__(self, q, qd, qdd):
        self.calls += 1
        self.at_rest += int(not np.any(qd) and not np.any(qdd))
        return self.torques(q, qd, qdd)

    def gravity(self, q):
        self.gravity_calls += 1
        return self.gravity_of(q)


def test_an_inverse_dynamics_gravity_is_taken_for_every_torque_at_rest():
    """The torques at rest of TorqueLimit and its path constraint: gravity(q), same factors."""
    rng = np.random.default_rng(3)
    points, limit = random_request(rng)
    traj = plan(points, '555', 'fixed', durations=rng.uniform(0.3, 0.8, len(points) - 1))
    wrapped = WithGravity(two_link_torques, lambda q: two_link_torques(q, 0 * q, 0 * q))
    plain, fast = TorqueLimit(limit, two_link_torques, 2), TorqueLimit(limit, wrapped, 2)
    samples = [traj.evaluate(np.linspace(0.0, traj.duration, 300), d) for d in range(3)]
    for torque in (plain, fast):    # the same, to round-off
        torque.results = [torque.squared_factors(*samples), torque.time_factor(traj)[0],
                          torque.factor_at_least(traj),
                          torque.piece_factors(traj.coefficients, traj.durations),
                          *torque.check(traj).needs(1.3), torque.check(traj).slow_down()]
        torque.rows = torque.constraint().rows(GriddedPath(*samples[:1], *samples))
    for mine, theirs in zip(fast.results + list(fast.rows), plain.results + list(plain.rows)):
        np.testing.assert_allclose(mine, theirs, rtol=1e-12, atol=1e-12 * np.max(np.abs(theirs)))
    assert wrapped.gravity_calls >= 7 and wrapped.calls >= 7 and wrapped.at_rest == 0
    # plan() takes it too: the same trajectory.
    kwargs = {'max_velocity': [4.0, 4.0], 'max_acceleration': [200.0, 200.0],
              'max_jerk': [4000.0, 4000.0], 'max_torque': limit}
    calls = wrapped.gravity_calls
    mine = plan(points, '555', 'optimal', inverse_dynamics=wrapped, **kwargs)
    theirs = plan(points, '555', 'optimal', inverse_dynamics=two_link_torques, **kwargs)
    assert wrapped.gravity_calls > calls and wrapped.at_rest == 0
    assert mine.duration == pytest.approx(theirs.duration, rel=1e-9)
    # Its output is checked as the torques are; a gravity that is not callable is not one.
    broken = TorqueLimit(limit, WithGravity(two_link_torques, lambda q: q[:, :1]), 2)
    with pytest.raises(ValueError, match='inverse_dynamics.gravity returned'):
        broken.check(traj)
    broken = TorqueLimit(limit, WithGravity(two_link_torques, lambda q: q * math.nan), 2)
    with pytest.raises(ValueError, match='non-finite'):
        broken.squared_factors(*samples)
    vector = WithGravity(two_link_torques, None)
    vector.gravity = np.array([0.0, 0.0, -9.81])
    assert TorqueLimit(limit, vector, 2).time_factor(traj)[0] == plain.time_factor(traj)[0]
    assert vector.at_rest > 0


def test_arm_dynamics_as_the_inverse_dynamics():
    """An ArmDynamics itself (its gravity pass) and its torques: the same factors and plan."""
    dynamics, limit, points = loaded_arm('panda', 3.0, 11, 5)
    traj = plan(points, '555', 'fixed', durations=[0.4, 0.3, 0.5, 0.4])
    plain, fast = TorqueLimit(limit, dynamics.torques, 7), TorqueLimit(limit, dynamics, 7)
    assert plain.gravity is None and fast.gravity == dynamics.gravity
    samples = [traj.evaluate(np.linspace(0.0, traj.duration, 400), d) for d in range(3)]
    pieces = (traj.coefficients, traj.durations)
    # The trajectory as a path in time: it starts at rest (q' = q'' = 0, exactly), where
    # the torque's rows are exactly 0, as ID(q, 0, 0) - ID(q, 0, 0).
    path = GriddedPath(np.linspace(0.0, traj.duration, 400), *samples)
    assert not np.any(samples[1][0]) and not np.any(samples[2][0])
    a, b, _, _ = JointTorque(limit, dynamics).rows(path)
    assert not np.any(a[0]) and not np.any(b[0]) and np.all(np.any(a[1:], axis=1))
    # So is the torque's dynamic part, hence its need.
    assert not np.any(fast.squared_factors(*samples)[0])
    assert not np.any(fast.check(traj).dynamic[0])
    for mine, theirs in [([fast.squared_factors(*samples)], [plain.squared_factors(*samples)]),
                         (fast.time_factor(traj), plain.time_factor(traj)),
                         (fast.check(traj).needs(1.2), plain.check(traj).needs(1.2)),
                         ([fast.check(traj).gravity], [plain.check(traj).gravity]),
                         ([fast.piece_factors(*pieces)], [plain.piece_factors(*pieces)]),
                         (JointTorque(limit, dynamics).rows(path),
                          JointTorque(limit, dynamics.torques).rows(path))]:
        for a, b in zip(mine, theirs):      # round-off against the largest
            np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-12 * np.max(np.abs(b)))
    kwargs = {'max_velocity': [2.0] * 7, 'max_acceleration': [1000.0] * 7,
              'max_jerk': [400.0] * 7, 'max_torque': limit}
    mine = plan(points, '555', 'optimal', inverse_dynamics=dynamics, **kwargs)
    theirs = plan(points, '555', 'optimal', inverse_dynamics=dynamics.torques, **kwargs)
    assert mine.duration == pytest.approx(theirs.duration, rel=1e-9)
    assert mine.torque_factor <= 1.0


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), smoothing=st.sampled_from(['auto', 'windows']))
def test_with_torque_limits_a_plan_is_not_longer_than_its_knots_only_plan(seed, smoothing):
    """
    With the smoothing windows the knots-only rival is compared as returned.

    Slowed down for the torque: a rival whose slow-down makes it longer than
    the inner-knot plan is dropped without a second check; one that stays
    shorter must win.  With torque limits the rival is cold-started, as
    plan(inner_knots=0) is, so the plan is never longer than that (a warm
    start was up to 1.5 % longer: a long hypothesis run's seed 68540, and
    145 of 301 seeds longer, 7 by more than 0.5 %).  Without windows (the
    default with torque limits)
    there is no rival: the inner-knot plan is the shorter by itself on
    nearly all requests (a median 0.78 of the knots-only plan on 1000 seeds
    of these requests, and shorter on bench_torque.py's 160), but not on
    all: 4 of those 1000 seeds were longer, by up to 1.5 %, and a long
    hypothesis run found 1.95 % (seed 2368): :data:`NO_RIVAL_GAP`.
    """
    rng = np.random.default_rng(seed)
    points, limit = random_request(rng)
    kwargs = {'max_velocity': [4.0, 4.0], 'max_acceleration': [200.0, 200.0],
              'max_jerk': [4000.0, 4000.0], 'max_torque': limit,
              'inverse_dynamics': two_link_torques}
    try:
        knots_only = plan(points, '555', 'optimal', inner_knots=0, **kwargs)
        traj = plan(points, '555', 'optimal', smoothing=smoothing, **kwargs)
    except ValueError as exc:
        assert 'gravity alone' in str(exc)
        return
    gap = 1e-9 if smoothing == 'windows' else NO_RIVAL_GAP
    assert traj.duration <= knots_only.duration * (1.0 + gap)
    assert traj.torque_factor <= 1.0


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), factor=st.floats(1.0, 4.0))
def test_a_check_rescaled_is_the_check_of_the_slowed_down_trajectory(seed, factor):
    """
    TorqueCheck.needs(f) and slow_down() against 10 kHz torques of the slowed-down spline.

    The spline with every duration times f is built here from the
    waypoints (not by rescaling the checked one) and its torque computed
    by the two-link arm's closed-form dynamics.
    """
    rng = np.random.default_rng(seed)
    points, limit = random_request(rng)
    durations = rng.uniform(0.1, 0.6, len(points) - 1)
    fast = plan(points, '555', 'fixed', durations=durations)
    check = TorqueLimit(limit, two_link_torques, 2).check(fast)
    slow = plan(points, '555', 'fixed', durations=durations * factor)
    peak = np.max(np.abs(dense_torques(slow, two_link_torques)), axis=0) / limit
    need, ratios = check.needs(factor)
    # An upper bound of the peaks (the excess between samples), and a close one.
    assert np.all(ratios >= peak * (1.0 - 1e-9)), (ratios, peak)
    assert np.all(ratios <= peak + 2e-3 * np.max(peak)), (ratios, peak)
    assert (need <= 1.0) == np.all(ratios <= 1.0 + 1e-12)
    # slow_down() is where the limits are just held.
    least = check.slow_down()
    held = plan(points, '555', 'fixed', durations=durations * least * (1.0 + 1e-9))
    peak = np.max(np.abs(dense_torques(held, two_link_torques)), axis=0) / limit
    assert np.all(peak <= 1.0 + 1e-9)
    if least > 1.0:
        assert np.max(peak) >= 0.99
        assert check.needs(least * (1.0 + 1e-9))[0] <= 1.0


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_the_coarse_torque_factor_is_a_lower_bound_of_the_dense_one(seed):
    """factor_at_least (10 ms samples) against the slow-down 10 kHz samples need, computed here."""
    from splines445_ros.planning.constraints.torque import TorqueLimit
    rng = np.random.default_rng(seed)
    points, limit = random_request(rng)
    traj = plan(points, '555', 'fixed', durations=rng.uniform(0.2, 1.0, len(points) - 1))
    t = np.linspace(0.0, traj.duration, int(traj.duration * 1e4) + 2)
    q, qd, qdd = (traj.evaluate(t, d) for d in range(3))
    gravity = two_link_torques(q, 0 * q, 0 * q)
    dynamic = two_link_torques(q, qd, qdd) - gravity
    room = np.where(dynamic >= 0.0, limit - gravity, -limit - gravity)
    dense = np.sqrt(np.max(np.where(dynamic == 0.0, 0.0, dynamic / room)))
    torque = TorqueLimit(limit, two_link_torques, 2)
    # Both references are sampled too: 10 kHz samples miss a peak by about (h / 2)**2 / 2
    # of its curvature, and the 1 kHz check's excess h**2 / 8 |tau''| is a second
    # difference's.  The long hypothesis run found 3e-9 and 1.2e-7 (relative).
    assert torque.factor_at_least(traj) <= dense * (1.0 + 1e-6)
    assert torque.factor_at_least(traj) <= torque.time_factor(traj)[0] * (1.0 + 1e-6)
    # Not a vacuous bound: within 5 % of the dense factor on these smooth splines.
    assert torque.factor_at_least(traj) >= 0.95 * dense


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_an_acceleration_limit_the_torque_keeps_below_does_not_change_the_plan(seed):
    """
    With torque limits a joint needs no acceleration limit: the node's stand-in must not matter.

    The inner knots' jerk ramp took its acceleration from the limits, so
    the plan depended on the stand-in although no acceleration reached it:
    with 1e5 rad/s^2 (and jerk 1e5) every segment got one inner knot, with
    1e3 four.  The smoothing windows of vibration_frequency keep the
    knots-only rival out.
    """
    rng = np.random.default_rng(seed)
    points, limit = random_request(rng)
    kwargs = {'max_velocity': [4.0, 4.0], 'max_jerk': [1e5, 1e5], 'max_torque': limit,
              'inverse_dynamics': two_link_torques}
    try:
        plans = [plan(points, '555', 'optimal', max_acceleration=[a, a], inner_knots=4,
                      vibration_frequency=20.0, **kwargs) for a in (1e3, 1e5)]
    except ValueError as exc:
        assert 'gravity alone' in str(exc)
        return
    reached = np.max(np.abs(plans[0].evaluate(np.linspace(0, plans[0].duration, 2000), 2)))
    assert reached < 1e3
    assert plans[0].duration == plans[1].duration
    np.testing.assert_array_equal(plans[0].breakpoints, plans[1].breakpoints)


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_piece_factors_are_the_need_at_each_pieces_samples_both_ends_included(seed):
    """
    piece_factors against the need computed here at TORQUE_PIECE_SAMPLES even times of every piece.

    The times include both ends of every piece: a knot is sampled once and
    counts for both of its pieces.
    """
    from splines445_ros.planning.constraints.torque import TORQUE_PIECE_SAMPLES
    rng = np.random.default_rng(seed)
    points, limit = random_request(rng)
    traj = plan(points, '555', 'fixed', durations=rng.uniform(0.1, 0.5, len(points) - 1))
    factors = TorqueLimit(limit, two_link_torques, 2).piece_factors(traj.coefficients,
                                                                    traj.durations)
    expected = []
    for start, length in zip(traj.breakpoints[:-1], traj.durations):
        t = np.minimum(start + np.linspace(0.0, length, TORQUE_PIECE_SAMPLES), traj.duration)
        q, qd, qdd = (traj.evaluate(t, d) for d in range(3))
        gravity = two_link_torques(q, 0 * q, 0 * q)
        dynamic = two_link_torques(q, qd, qdd) - gravity
        room = np.where(dynamic >= 0.0, limit - gravity, -limit - gravity)
        expected.append(np.sqrt(np.max(dynamic / room)))
    np.testing.assert_allclose(factors[:, 0], expected, rtol=1e-9)


def test_a_spline_straying_into_a_gravity_overload_needs_an_infinite_factor_per_piece():
    """
    The construction's candidates may leave the path; where gravity overloads, none is taken.

    The piece factors of such a candidate are infinite where it crosses the
    overload (the candidate is dropped), finite elsewhere, and raise
    nothing: only the path (its constraints) and the final check refuse a
    request.  The hill of gravity is 1.5 > 1 for ``|q - 0.75| < 0.127``.
    """
    def hill(q, qd, qdd):
        return qdd + 1.5 * np.exp(-((q - 0.75) / 0.2) ** 2)

    torque = TorqueLimit([1.0], hill, 1)
    traj = plan(np.array([[0.0], [0.3], [1.0]]), '555', 'fixed', durations=[1.0, 1.0])
    q = traj.evaluate(np.linspace(0.0, 1.0, 50))
    assert np.max(np.abs(hill(q, 0 * q, 0 * q))) < 0.5      # the first piece: far from it
    factors = torque.piece_factors(traj.coefficients, traj.durations)
    assert factors.shape == (2, 1)
    assert np.isfinite(factors[0, 0]) and factors[1, 0] == np.inf
    with pytest.raises(GravityOverload, match='joint 0: gravity alone needs'):
        torque.time_factor(traj)


def test_the_default_inner_knots_and_windows_with_torque_limits():
    """Torque limits: no smoothing windows and 6 inner knots by default; given ones kept."""
    rng = np.random.default_rng(7)
    points, limit = random_request(rng)
    kwargs = {'max_velocity': [4.0, 4.0], 'max_acceleration': [200.0, 200.0],
              'max_jerk': [4000.0, 4000.0], 'max_torque': limit,
              'inverse_dynamics': two_link_torques}
    # Slow moves with windows, where they are a small share: the knots-only
    # rival (no windows) wins the short fast ones.
    slow = {'max_velocity': [0.3, 0.3], 'max_acceleration': [2.0, 2.0], 'max_jerk': [40.0, 40.0]}
    cases = (({}, 6, []), (dict(slow, smoothing='windows'), 4, [0.3, 0.15]),
             ({'inner_knots': 3}, 3, []), (dict(slow, vibration_frequency=5.0), 4, [0.2, 0.2]))
    for extra, most, windows in cases:
        traj = plan(points, '555', 'optimal', **dict(kwargs, **extra))
        assert traj.optimizer['inner_knots'] == most, extra
        assert max(traj.optimizer['inner_knots_per_segment']) <= most
        assert traj.optimizer['smoothing_windows'] == windows, extra
        assert traj.torque_factor <= 1.0
    # Without torque limits the default stays 4 with the windows.
    plain = plan(points, '555', 'optimal', **slow)
    assert plain.optimizer['inner_knots'] == 4
    assert plain.optimizer['smoothing_windows'] == [0.3, 0.15]


def test_gravity_between_samples_past_the_far_side_of_a_limit_needs_an_infinite_factor():
    """
    A dynamic part that pushes away from the limit gravity passes between two samples.

    Gravity dips to -1 - 1e-5 midway between two 1 ms samples (both within
    the limit of 1) while the dynamic part is +1e-7: the torque passes -1
    there at any speed, so the check's factor must say so, at its own
    timing and slowed down (the ratios already did).
    """
    from splines445_ros.planning.constraints.torque import TorqueCheck
    t = np.arange(0.0, 0.0205, 1e-3)
    gravity = (-1.0 - 1e-5 + 2000.0 * (t - 0.0105) ** 2)[:, None]
    assert np.all(np.abs(gravity) <= 1.0)
    check = TorqueCheck(gravity, gravity + 1e-7, np.array([1.0]))
    for factor in (1.0, 1.5):
        need, ratios = check.needs(factor)
        assert ratios[0] > 1.0 and need > 1.0, (factor, need, ratios)
    assert check.slow_down() == np.inf


@pytest.mark.parametrize('timing', ['uniform', 'optimal'])
def test_gravity_exactly_at_its_limit_at_the_goal_is_planned(timing):
    """The goal holds gravity at exactly the limit: planned (not slowed down without end)."""
    def at_goal(q, qd, qdd):
        return 0.2 * qdd + q

    traj = plan(np.array([[0.0], [0.6], [1.0]]), '555', timing, max_velocity=[1.0],
                max_acceleration=[5.0], max_torque=[1.0], inverse_dynamics=at_goal)
    assert np.isfinite(traj.duration) and traj.torque_factor <= 1.0
    tau = dense_torques(traj, at_goal)
    assert np.max(np.abs(tau)) <= 1.0 + TORQUE_RTOL


def test_a_knots_only_rival_turned_at_its_ends_is_checked_for_the_torque():
    """
    Torque limits, smoothing windows and position limits at the waypoints: a turned rival.

    The knots-only rival, slowed down for the torque, starts a joint past
    its limit; turned at its ends (a knot next to each) it is slowed down
    for the torque again.  Checked at 10 kHz by the test's dynamics: within
    the torque (the 1 kHz check's 0.5 %), the position limits and v/a/j,
    and shorter than the inner-knot plan it beat.  (Helper-32's scan,
    seed 25: steep one-way moves with the torque at 1.05-1.3 times gravity.)
    """
    rng = np.random.default_rng(25)
    n = int(rng.integers(2, 5))
    start = rng.uniform(-1.0, 1.0, 2)
    way = rng.uniform(0.5, 2.0, 2) * np.where(rng.random(2) < 0.5, -1.0, 1.0)
    fractions = np.cumsum(rng.uniform(1.0, 3.0, (n, 2)), axis=0)
    fractions = (fractions - fractions[0]) / (fractions[-1] - fractions[0])
    points = start + fractions * way
    path = plan(points, '555', 'fixed', durations=np.ones(n - 1))
    q = path.evaluate(np.linspace(0.0, path.duration, 400))
    gravity = np.max(np.abs(two_link_torques(q, 0 * q, 0 * q)), axis=0)
    limit = gravity * rng.uniform(1.05, 1.3, 2) + 0.2
    kwargs = {'max_velocity': [4.0, 4.0], 'max_acceleration': [200.0, 200.0],
              'max_jerk': [4000.0, 4000.0], 'max_torque': limit,
              'inverse_dynamics': two_link_torques, 'smoothing': 'windows'}
    low, high = points.min(axis=0), points.max(axis=0)
    traj = plan(points, '555', 'optimal', min_position=low, max_position=high, **kwargs)
    assert 'end_knots' in traj.optimizer
    assert traj.breakpoints.size == traj.waypoint_times.size + 2
    assert traj.duration < traj.optimizer['inner_knots_duration']
    assert np.all(np.abs(dense_torques(traj, two_link_torques)) <= limit * (1.0 + TORQUE_RTOL))
    q = traj.evaluate(np.linspace(0.0, traj.duration, 20001))
    assert np.all(q >= low - 1e-12) and np.all(q <= high + 1e-12)
    assert traj.within_limits(rtol=1e-9)
    # Without the position limits the rival (knots only) leaves them.
    free = plan(points, '555', 'optimal', **kwargs)
    assert free.breakpoints.size == free.waypoint_times.size
    q = free.evaluate(np.linspace(0.0, free.duration, 20001))
    assert np.any(q < low - 1e-9) or np.any(q > high + 1e-9)


def test_a_plan_pulled_within_its_position_limits_holds_its_torque_limits():
    """
    Torque-limited plans that leave a limit cut into their swing: their knots moved, slowed again.

    The moved spline is slowed down for the torque limits afterwards (a
    uniform slow-down keeps the positions): within the limit and the
    torques at 10 kHz.  Where that made it longer than the knots-only
    optimum or the chord-length plan, that plan is returned instead (0.868 s
    against 0.813 s without the limit on one), within both too.
    """
    rng = np.random.default_rng(5)
    pulled = 0
    for _ in range(examples(6)):
        while True:
            points, limit = random_request(rng)
            kwargs = {'max_velocity': [4.0, 4.0], 'max_acceleration': [200.0, 200.0],
                      'max_jerk': [4000.0, 4000.0], 'max_torque': limit,
                      'inverse_dynamics': two_link_torques}
            free = plan(points, '555', 'optimal', **kwargs)
            low, high, _ = cut_limits(free, points, 0.5, rng)
            f_low, f_high = free.position_extrema()[:2]
            if np.any(f_high > high) or np.any(f_low < low):
                break
        traj = plan(points, '555', 'optimal', min_position=low, max_position=high, **kwargs)
        if 'position_limit_knots' in traj.optimizer:
            pulled += 1
        else:
            # A smooth other plan, shorter than the stretched pull.
            assert re.search('planned with (knots at the waypoints only|timing "uniform")',
                             traj.optimizer['speed_profile_reason'])
        t = np.linspace(0.0, traj.duration, 20001)
        q = traj.evaluate(t)
        assert np.all(q >= low - 1e-12) and np.all(q <= high + 1e-12)
        peak = np.max(np.abs(dense_torques(traj, two_link_torques)), axis=0) / limit
        assert np.all(peak <= 1.0 + TORQUE_RTOL), peak
        assert traj.within_limits(rtol=1e-6)
        np.testing.assert_allclose(traj.evaluate(traj.waypoint_times), traj.waypoints,
                                   atol=1e-9)
    assert pulled >= examples(6) // 2


def pendulum_torques(q, qd, qdd):
    """One pendulum joint with viscous-quadratic drag: tau = I qdd + C qd |qd| + G sin q."""
    return 0.396 * qdd + 0.335 * qd * np.abs(qd) + 4.514 * np.sin(q)


@pytest.mark.parametrize('profile', ['time_optimal', 'smoothed'])
@pytest.mark.parametrize('move', [1.3e-5, 1e-6, 1e-4])
def test_a_plan_of_a_few_milliseconds_holds_its_torque(profile, move):
    """Sampled 2-3 times at 1 kHz, such a plan peaked 2 % over its limit between the samples."""
    limit = np.array([4.514 * math.sin(0.8269) + 34.0])
    points = np.array([[-0.8269], [-0.8269 + move]])
    traj = plan(points, '555', 'optimal', speed_profile=profile, max_velocity=[10.0],
                max_acceleration=[1e5], max_jerk=[3e7], max_torque=limit,
                inverse_dynamics=pendulum_torques, waypoint_tolerance=0.0)
    assert traj.duration < 0.01
    samples = dense_torques(traj, pendulum_torques, rate=20000.0 / traj.duration)
    peak = np.max(np.abs(samples), axis=0) / limit
    assert np.all(peak <= 1.0 + 1e-9), peak
    assert np.all(traj.torque_ratios >= peak - 1e-3)     # reported about as high
