"""
Joint damping and dry friction in the torque limits: the motor's whole torque within its limit.

The arm is the two-link arm of ``test_path_constraints`` (closed-form
dynamics) with a viscous damping ``D qd`` and a dry friction ``F`` per
joint, written here: the motor gives ``M qdd + C qd + g + D qd`` and, while
the joint moves, up to ``F`` more.  The planner is told of the damping and
friction through the inverse dynamics' ``viscous`` and ``dry_friction``
(as :class:`~splines445_ros.robot.dynamics.ArmDynamics` gives them with
``include_damping``); the torques are checked here at 10 kHz.
"""

import os

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.planning.constraints.torque import NoRoomToMove, TorqueCheck, TorqueLimit
from splines445_ros.service.request_planning import no_room_report
from test_path_constraints import two_link_torques
from test_torque_limits import random_request

EXAMPLES = int(os.environ.get('SPLINES445_PROPERTY_EXAMPLES', str(examples(12))))
# The 1 kHz check holds the torque within 0.5 % between its samples (issue 25).
TORQUE_RTOL = 5e-3
ROUTES = [('555', 'optimal', 'smoothed'), ('555', 'optimal', 'time_optimal'),
          ('555', 'uniform', 'smoothed'), ('445', 'uniform', 'smoothed'),
          ('434', 'optimal', 'smoothed')]
LIMITS = {'max_velocity': [4.0, 4.0], 'max_acceleration': [200.0, 200.0],
          'max_jerk': [4000.0, 4000.0]}


class DampedArm:
    """The two-link arm with viscous damping ``D qd`` and dry friction ``F`` at each joint."""

    def __init__(self, damping, friction):
        """Keep the damping [N m s/rad] (2,) and the friction [N m] (2,)."""
        self.damping = np.asarray(damping, float)
        self.friction = np.asarray(friction, float)

    def __call__(self, q, qd, qdd):
        """Return the rigid-body torques plus the damping's (not the friction: its sign)."""
        return two_link_torques(q, qd, qdd) + self.damping * qd

    def viscous(self, q, qd):
        """Return the damping part of the torques."""
        return self.damping * qd

    def dry_friction(self, q):
        """Return the friction a moving joint overcomes, (N, 2)."""
        return np.broadcast_to(self.friction, q.shape).copy()


def motor_peaks(traj, arm, limit, rate=10000.0):
    """
    Return per joint the peak of the motor's torque over its limit.

    ``tau + D qd`` and a friction of up to ``F`` against the motion:
    ``max(tau + F, -tau)`` moving forward, ``max(tau, F - tau)`` backward
    (the friction is not counted on to help); at rest ``|tau|``.
    """
    t = np.linspace(0.0, traj.duration, int(traj.duration * rate) + 2)
    q, qd, qdd = (traj.evaluate(t, d) for d in range(3))
    # The ends of a rest-to-rest plan are at rest exactly (round-off there is not motion).
    qd[[0, -1]] = 0.0
    qdd[[0, -1]] = 0.0
    tau = two_link_torques(q, qd, qdd) + arm.damping * qd
    motor = np.maximum(tau + np.where(qd > 0.0, arm.friction, 0.0),
                       np.where(qd < 0.0, arm.friction, 0.0) - tau)
    return np.max(motor, axis=0) / limit


def damped_request(rng):
    """Return a two-link request whose damping at full speed is a large share of its limits."""
    points, limit = random_request(rng)
    damping = rng.uniform(0.3, 1.0, 2) * limit / LIMITS['max_velocity'][0]
    friction = rng.uniform(0.0, 0.1, 2) * limit
    return points, limit, DampedArm(damping, friction)


def planned_or_refused(points, limit, dynamics, route):
    """Return the plan of one of ROUTES, or None where gravity (and friction) refused it."""
    method, timing, profile = route
    try:
        return plan(points, method, timing, max_torque=limit, inverse_dynamics=dynamics,
                    speed_profile=profile, **LIMITS)
    except ValueError as exc:
        # Gravity (with a moving joint's friction) beyond a limit: refused by name.
        assert 'gravity' in str(exc)
        return None


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), route=st.sampled_from(ROUTES))
def test_damping_and_friction_held_at_dense_samples_and_something_binds(seed, route):
    rng = np.random.default_rng(seed)
    points, limit, arm = damped_request(rng)
    traj = planned_or_refused(points, limit, arm, route)
    if traj is None:
        return
    peak = motor_peaks(traj, arm, limit)
    assert np.all(peak <= 1.0 + TORQUE_RTOL), peak
    assert traj.within_limits(rtol=1e-6)
    np.testing.assert_allclose(traj.evaluate(traj.waypoint_times), traj.waypoints, atol=1e-9)
    # The reported ratios are the motor's peaks, friction and damping included.
    np.testing.assert_allclose(traj.torque_ratios, peak, rtol=2e-2, atol=1e-3)
    # Not slower than it must be: a torque, or a v/a/j limit, is reached.
    assert max(peak.max(), np.max(traj.limit_ratios())) >= 0.98


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), factor=st.floats(1.0, 4.0))
def test_a_slow_down_divides_the_damping_by_f_and_the_rest_by_f_squared(seed, factor):
    """
    TorqueCheck.needs(f) and slow_down() against 10 kHz torques of the slowed-down spline.

    The slowed-down spline is built here from the waypoints with every
    duration times ``f``; a check that took the damping for a part of the
    ``1 / f**2`` torque would find a slowed-down plan within its limits
    that is not.
    """
    rng = np.random.default_rng(seed)
    points, limit, arm = damped_request(rng)
    durations = rng.uniform(0.1, 0.6, len(points) - 1)
    fast = plan(points, '555', 'fixed', durations=durations)
    try:
        check = TorqueLimit(limit, arm, 2).check(fast)
    except ValueError as exc:
        assert 'gravity alone' in str(exc)
        return
    slow = plan(points, '555', 'fixed', durations=durations * factor)
    peak = motor_peaks(slow, arm, limit)
    need, ratios = check.needs(factor)
    # An upper bound of the peaks (the excess between samples), and a close one.
    assert np.all(ratios >= peak * (1.0 - 1e-9)), (ratios, peak)
    assert np.all(ratios <= peak + 2e-3 * np.max(peak)), (ratios, peak)
    least = check.slow_down()
    if not np.isfinite(least):
        # Gravity and a moving joint's friction use the whole limit somewhere.
        return
    assert (need <= 1.0 + 1e-9) == (factor >= least * (1.0 - 1e-9))
    # slow_down() is where the limits are just held.
    held = plan(points, '555', 'fixed', durations=durations * least * (1.0 + 1e-9))
    peak = motor_peaks(held, arm, limit)
    assert np.all(peak <= 1.0 + 1e-9), peak
    if least > 1.0:
        assert np.max(peak) >= 0.99


def test_a_single_joints_slow_down_is_the_root_of_its_quadratic():
    """
    One joint, one sample: ``g + v / f + d / f**2 = L`` solved here for ``f``.

    With ``v`` and ``d`` of either sign, gravity anywhere within the limit
    and exactly at it (no room: the damping may pull away first), against
    the smallest ``f`` from which every slower one holds, found by
    scanning; and at ``f = 1`` a sample within its limit needs no slow-down
    even where a slower plan would not hold it.
    """
    rng = np.random.default_rng(4)
    y = np.linspace(1e-6, 1.0, 200001)      # 1 / f
    for case in range(600):
        limit = rng.uniform(1.0, 10.0)
        gravity = rng.uniform(-0.9, 0.9) * limit if case % 4 else rng.choice([-1.0, 1.0]) * limit
        v, d = rng.uniform(-3.0, 3.0, 2) * limit
        check = TorqueCheck(np.full((1, 1), gravity), np.full((1, 1), gravity + v + d),
                            np.array([limit]), viscous=np.full((1, 1), v))
        torque = gravity + v * y + d * y * y
        bad = np.flatnonzero(np.abs(torque) > limit * (1.0 + 1e-12))
        found = check.slow_down()
        case_text = (gravity, v, d, limit, found)
        if not bad.size or 1.0 / y[bad[0]] <= 1.0:
            assert found <= 1.0 + 1e-6, case_text
        elif bad[0] == 0:       # pushed past the limit at once
            assert found >= 1e5, case_text
        else:
            assert found == pytest.approx(1.0 / y[bad[0]], rel=2e-4), case_text
        assert (check.needs()[0] <= 1.0) == (abs(gravity + v + d) <= limit), case_text


def test_a_joint_without_a_limit_leaves_the_others_checked():
    """An infinite limit (no limit on that joint) with damping: the others are still held."""
    rng = np.random.default_rng(8)
    for _ in range(6):
        points, limit, arm = damped_request(rng)
        limit = np.array([limit[0], np.inf])
        try:
            traj = plan(points, '555', 'uniform', max_torque=limit, inverse_dynamics=arm,
                        **LIMITS)
        except ValueError as exc:
            assert 'gravity' in str(exc)
            continue
        peak = motor_peaks(traj, arm, limit)
        assert peak[0] <= 1.0 + TORQUE_RTOL and peak[1] == 0.0, peak
        assert np.all(np.isfinite(traj.torque_ratios)) and traj.torque_ratios[1] == 0.0
        np.testing.assert_allclose(traj.torque_ratios, peak, rtol=2e-2, atol=1e-3)


def test_gravity_a_moving_joints_friction_leaves_no_room_for_is_refused_with_the_joint():
    """Gravity within the limit but not within it less the friction, where the joint moves."""
    points = np.array([[0.0, 0.0], [0.4, 0.3], [0.8, -0.2]])
    rigid = two_link_torques(points, 0 * points, 0 * points)
    limit = np.max(np.abs(rigid), axis=0) * np.array([1.02, 3.0])
    arm = DampedArm([0.0, 0.0], [0.05 * limit[0], 0.0])
    with pytest.raises(NoRoomToMove, match='joint 0: gravity with its dry friction') as info:
        plan(points, '555', 'uniform', max_torque=limit, inverse_dynamics=arm, **LIMITS)
    # The nodes name the joint, and say what to change.
    message, values = no_room_report(info.value, ['shoulder', 'elbow'], 0.1)
    assert message.startswith("joint 'shoulder': gravity with its dry friction uses")
    assert 'torque_headroom (0.1)' in message and 'torque_counts_friction false' in message
    assert values == {'overloaded_joint': 'shoulder'}
    # Without the friction the same request is planned.
    plan(points, '555', 'uniform', max_torque=limit, inverse_dynamics=DampedArm([0, 0], [0, 0]),
         **LIMITS)


def test_a_joint_at_rest_keeps_its_whole_limit_against_gravity():
    """Friction lowers the limit of a moving joint only: a still joint holds gravity to it."""
    points = np.array([[0.3, 0.0], [0.3, 0.6], [0.3, -0.4]])
    rigid = two_link_torques(points, 0 * points, 0 * points)
    # Joint 0 never moves; its gravity is within 1 % of its limit.
    limit = np.array([np.max(np.abs(rigid[:, 0])) * 1.01, 30.0])
    arm = DampedArm([0.0, 0.5], [0.2 * limit[0], 0.5])
    traj = plan(points, '555', 'optimal', max_torque=limit, inverse_dynamics=arm, **LIMITS)
    assert np.all(motor_peaks(traj, arm, limit) <= 1.0 + TORQUE_RTOL)


def test_friction_costs_a_joint_moving_against_gravity_not_one_moving_with_it():
    """
    Friction opposes the motion: it adds to the motor's torque only on the side it moves to.

    Gravity on joint 0 is within half its friction of the limit: moved the
    way gravity pulls it, the joint needs ``|g|`` at most (planned, and
    held); the other way it needs ``|g| + F`` (refused).  Counting the
    friction on both sides refused both.
    """
    line = np.array([[0.3, 0.0], [0.55, 0.0], [0.8, 0.0]])
    gravity = two_link_torques(line, 0 * line, 0 * line)[:, 0]
    assert np.all(np.sign(gravity) == np.sign(gravity[0]))
    heaviest = np.max(np.abs(gravity))
    friction = 0.2 * heaviest
    limit = np.array([heaviest + 0.5 * friction, 1e3])
    arm = DampedArm([0.0, 0.0], [friction, 0.0])
    # Gravity pulls joint 0 towards -sign(g) (the motor holds +g): that way is "with" it.
    with_gravity = line if np.sign(gravity[0]) < 0 else line[::-1]
    traj = plan(with_gravity, '555', 'optimal', max_torque=limit, inverse_dynamics=arm, **LIMITS)
    assert np.all(motor_peaks(traj, arm, limit) <= 1.0 + TORQUE_RTOL)
    with pytest.raises(NoRoomToMove, match='joint 0: gravity with its dry friction'):
        plan(with_gravity[::-1], '555', 'optimal', max_torque=limit, inverse_dynamics=arm,
             **LIMITS)


@pytest.mark.parametrize('timing', ['uniform', 'optimal'])
def test_almost_no_room_is_refused_not_planned_for_a_million_seconds(timing):
    """
    Joint 0 swept through its gravity peak against gravity, its limit a hair above ``|g| + F``.

    The damping there needs a slow-down of about ``D qd / room``: the plan
    would last days.  It is refused (a 6e6 s plan was returned): naming the
    joint where the plan is slowed down uniformly, by its duration where
    the inner-knot construction slows its pieces.
    """
    sweep = np.array([[-0.4, 0.0], [0.0, 0.0], [0.4, 0.0]])
    gravity = two_link_torques(sweep, 0 * sweep, 0 * sweep)[:, 0]
    peak = float(np.max(np.abs(gravity)))
    assert np.argmax(np.abs(gravity)) == 1
    friction = 0.1 * peak
    limit = np.array([peak + friction + 1e-5 * peak, 1e3])
    arm = DampedArm([0.5 * peak, 0.0], [friction, 0.0])
    # Against gravity (the motor holds +g: gravity pulls towards -sign(g)).
    against = sweep if gravity[1] > 0 else sweep[::-1]
    refusal = (r'joint 0: gravity with its dry friction leaves it almost no torque to move '
               r'with: the plan would last' if timing == 'uniform'
               else r'the trajectory lasts [0-9.e+]+ s: the torque is checked')
    with pytest.raises(ValueError, match=refusal):
        plan(against, '555', timing, max_torque=limit, inverse_dynamics=arm, **LIMITS)


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_the_coarse_factor_is_a_lower_bound_where_joints_reverse(seed):
    """
    TorqueLimit.factor_at_least (10 ms samples) never above what the 1 kHz check needs.

    Joint 0 reverses at every waypoint, so the friction turns over: counted
    at a coarse sample's neighbours 10 ms away it asked up to 18 % more
    than the check (helper-87).
    """
    rng = np.random.default_rng(seed)
    n = int(rng.integers(4, 8))
    points = np.cumsum(rng.uniform(-0.8, 0.8, (n, 2)), axis=0)
    points[:, 0] = points[0, 0] + 0.5 * (np.arange(n) % 2)
    traj = plan(points, '555', 'fixed', durations=rng.uniform(0.1, 0.6, n - 1))
    q = traj.evaluate(np.linspace(0.0, traj.duration, 400))
    gravity = np.max(np.abs(two_link_torques(q, 0 * q, 0 * q)), axis=0)
    limit = gravity * rng.uniform(1.0, 1.3, 2) + rng.uniform(0.1, 2.0, 2)
    friction = rng.uniform(0.0, 1.0, 2) * (limit - gravity)
    arm = DampedArm(rng.uniform(0.0, 0.25, 2) * limit * rng.integers(0, 2), friction)
    torque = TorqueLimit(limit, arm, 2)
    check = torque.check(traj)
    need = max(check.needs()[0], check.slow_down())
    assert torque.factor_at_least(traj) <= need * (1.0 + 1e-9)


class HiddenDamping:
    """The two-link arm with damping ``D qd`` inside its torques, not given as ``viscous``."""

    def __init__(self, damping):
        """Keep the damping [N m s/rad] (2,)."""
        self.damping = np.asarray(damping, float)

    def __call__(self, q, qd, qdd):
        """Return the rigid-body torques plus the damping's."""
        return two_link_torques(q, qd, qdd) + self.damping * qd


@settings(max_examples=EXAMPLES, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), route=st.sampled_from(ROUTES))
def test_damping_the_function_does_not_expose_is_still_held(seed, route):
    """
    A plain ``tau(q, qd, qdd)`` with damping inside: its slowed-down plans checked again.

    The slow-down assumed ``g + d / f**2``, and the damping falls as ``1 / f``
    only: plans reached 1.88 times the limit with ``torque_ratios`` saying
    1.0 (helper-89).  The torques are the function's own, at 10 kHz.
    """
    rng = np.random.default_rng(seed)
    points, limit, arm = damped_request(rng)
    hidden = HiddenDamping(arm.damping)
    traj = planned_or_refused(points, limit, hidden, route)
    if traj is None:
        return
    t = np.linspace(0.0, traj.duration, int(traj.duration * 1e4) + 2)
    q, qd, qdd = (traj.evaluate(t, d) for d in range(3))
    qd[[0, -1]] = qdd[[0, -1]] = 0.0
    peak = np.max(np.abs(hidden(q, qd, qdd)), axis=0) / limit
    assert np.all(peak <= 1.0 + TORQUE_RTOL), peak
    np.testing.assert_allclose(traj.torque_ratios, peak, rtol=2e-2, atol=1e-3)


def test_the_scaling_probe_tells_hidden_damping_from_rigid_body_torques():
    """TorqueCheck.scales: True for M qdd + C qd + g (with damping exposed too), else False."""
    rng = np.random.default_rng(5)
    points, limit, arm = damped_request(rng)
    fast = plan(points, '555', 'fixed', durations=np.full(len(points) - 1, 0.2))
    big = np.full(2, 1e6)
    assert TorqueLimit(big, two_link_torques, 2).check(fast).scales
    assert TorqueLimit(big, arm, 2).check(fast).scales
    assert not TorqueLimit(big, HiddenDamping(arm.damping), 2).check(fast).scales
    # A function with complex torques is refused (as floats its imaginary part was dropped).
    with pytest.raises(ValueError, match='complex torques'):
        TorqueLimit(big, lambda q, qd, qdd: two_link_torques(q, qd, qdd) + 0j, 2).check(fast)


def test_a_light_joints_hidden_damping_is_seen_beside_a_heavy_joints_torque():
    """
    The probe looks at every limited joint's own peaks, relative to its own limit.

    Probed only where the torque is largest in N m (a heavy joint with 2000 N m of
    gravity, no limit), a light joint's hidden damping went unseen and its plan
    peaked at 1.15 times its limit (helper-91).
    """
    def hidden(q, qd, qdd):
        return np.stack([50.0 * qdd[:, 0] + 2000.0, 0.05 * qdd[:, 1] + 0.6 * qd[:, 1]], axis=1)
    limit = np.array([np.inf, 1.0])
    points = np.array([[0, 0], [2.0, 0.0], [4.0, 0.0], [4.0, 0.02], [4.0, 3.0], [4.0, 6.0]])
    limits = {'max_velocity': [3.0, 6.0], 'max_acceleration': [20.0, 60.0],
              'max_jerk': [400.0, 2000.0]}
    fast = plan(points, '555', 'optimal', **limits)
    assert not TorqueLimit(limit, hidden, 2).check(fast).scales
    for method, timing in (('445', 'uniform'), ('555', 'optimal')):
        traj = plan(points, method, timing, max_torque=limit, inverse_dynamics=hidden,
                    **limits)
        t = np.linspace(0.0, traj.duration, int(traj.duration * 2e4) + 2)
        q, qd, qdd = (traj.evaluate(t, d) for d in range(3))
        qd[[0, -1]] = qdd[[0, -1]] = 0.0
        peak = np.max(np.abs(hidden(q, qd, qdd)), axis=0) / limit
        assert peak[1] <= 1.0 + TORQUE_RTOL, (method, timing, peak)
        assert traj.torque_ratios[1] == pytest.approx(peak[1], rel=1e-2)
