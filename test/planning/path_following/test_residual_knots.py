"""
A vibration_frequency's plan, its knots moved to cancel the mode's ringing (residual_knots).

Random walks and one-way moves planned with a ``vibration_frequency``,
with the cancellation and without it (the plan it starts from).  Checked
on the trajectories alone, with the tests' own model of the mode (scipy's
``lsim`` on 0.2 ms samples, damping 0.02): the ringing after the stop does
not grow and falls by half at the median; the ringing during the motion
does not rise above the plan's largest; and the moved plan keeps what the
plan had (the waypoints at their times, the duration, rest at both ends,
C4 at every knot, the v/a/j and position limits, the end jerks' signs).
"""

from example_counts import examples
import numpy as np
import pytest
from scipy.interpolate import PPoly
from scipy.signal import lsim
from splines445_ros.planning import plan, planner
from test_position_limits import one_way_request, walk_request

ZETA = 0.02


def amplitude(traj, frequency, zeta=ZETA):
    """
    Return (T,), (n,): the mode's ringing amplitude over time (largest share over the joints).

    ``x'' + 2 zeta w x' + w**2 x = -q''`` on 0.2 ms samples, and the
    amplitude it would ring with were the motion to stop at each time,
    ``hypot(x, (x' + zeta w x) / wd)``, over each joint's static deflection
    ``a / w**2``: the largest over the joints at each time, and each joint's
    after the stop.
    """
    w = 2.0 * np.pi * frequency
    damped = w * np.sqrt(1.0 - zeta * zeta)
    t = np.linspace(0.0, traj.duration, int(np.ceil(traj.duration / 2e-4)) + 1)
    acc = traj.evaluate(t, 2)
    static = traj.limits.acceleration / (w * w)
    over_time, after = np.zeros(t.size), []
    for j in range(traj.n_joints):
        _, x, state = lsim(([-1.0], [1.0, 2.0 * zeta * w, w * w]), acc[:, j], t)
        rate = np.gradient(x, t)
        share = np.hypot(x, (rate + zeta * w * x) / damped) / static[j]
        over_time = np.maximum(over_time, share)
        after.append(share[-1])
    return over_time, np.array(after)


def plans(points, limits, frequency, **more):
    """Return (the plan, the same without the cancellation) of one request."""
    traj = plan(points, '555', 'optimal', vibration_frequency=frequency, **limits, **more)
    keep = planner._with_ringing_cancelled
    planner._with_ringing_cancelled = lambda refined, options: refined
    try:
        before = plan(points, '555', 'optimal', vibration_frequency=frequency, **limits, **more)
    finally:
        planner._with_ringing_cancelled = keep
    return traj, before


def assert_keeps_the_plan(traj, before, points):
    """``traj`` is ``before`` with knots moved: the same timing, rest, C4, limits, end jerks."""
    assert traj.duration == before.duration
    np.testing.assert_array_equal(traj.waypoint_times, before.waypoint_times)
    # Through the planned waypoints (the request's, near duplicates merged) at their times.
    np.testing.assert_array_equal(traj.waypoints, before.waypoints)
    assert before.waypoints.shape[0] <= points.shape[0]
    np.testing.assert_allclose(traj.evaluate(traj.waypoint_times), traj.waypoints, atol=1e-9)
    ends = np.array([0.0, traj.duration])
    for order in (1, 2):
        np.testing.assert_allclose(traj.evaluate(ends, order), 0.0, atol=1e-9)
    # The end jerks keep their signs (the joints leave and reach their ends along the move).
    jerk, was = traj.evaluate(ends, 3), before.evaluate(ends, 3)
    scale = traj.limits.jerk
    assert np.all(jerk * np.sign(was) >= -1e-9 * scale)
    # C4 at every knot: each piece's derivatives at its end (scipy's PPoly) against the next's
    # at its start.
    ppoly = PPoly(traj.ppoly.c, traj.ppoly.x)
    h = np.diff(ppoly.x)[:-1]
    for order in range(5):
        c = (ppoly.derivative(order) if order else ppoly).c      # (k, S, n), highest first
        powers = h[:, None] ** np.arange(c.shape[0] - 1, -1, -1)[None, :]
        left = np.einsum('pk,kpn->pn', powers, c[:, :-1])
        right = c[-1, 1:]
        np.testing.assert_allclose(left, right, rtol=1e-6,
                                   atol=1e-6 * np.max(np.abs(c[-1])), err_msg=str(order))
    assert traj.within_limits(rtol=1e-9)


@pytest.mark.parametrize('seed', range(3000, 3000 + examples(12)))
@pytest.mark.parametrize('frequency', [1.5, 4.0])
def test_the_ringing_after_the_stop_falls_and_the_motion_rings_no_more(seed, frequency):
    """The moved plan keeps the plan and rings less after the stop, no more during the motion."""
    rng = np.random.default_rng(seed)
    points, limits = walk_request(rng)
    traj, before = plans(points, limits, frequency)
    assert_keeps_the_plan(traj, before, points)
    during, after = amplitude(traj, frequency)
    was_during, was_after = amplitude(before, frequency)
    # lsim and the planner's trapezoid sums differ by sampling: 1 % and 1e-3 of a share.
    assert after.max() <= was_after.max() * 1.01 + 1e-3
    assert during.max() <= was_during.max() * 1.01 + 1e-3
    if 'residual_knots' in traj.optimizer:
        assert 'ringing at' in traj.optimizer['residual_knots']
        residual = traj.optimizer['vibration_residual']
        assert residual == pytest.approx(after.max(), rel=0.05, abs=2e-3)
    else:
        np.testing.assert_array_equal(traj.ppoly.c, before.ppoly.c)


def test_a_low_mode_on_short_pieces_rings_no_more_during_the_motion():
    """A 0.8 Hz mode on 35-134 ms pieces: 2-3 samples a piece misjudged it by 4 % (helper-40)."""
    points = np.array([
        -0.00543342522738591, -0.00961821202430515, -0.0153391299201648, -0.01702919291904968,
        -0.0203745586485776, -0.02683673800715158, -0.02223173604799348, -0.01735628182327069,
        -0.02189782043471992, -0.02504484600828983, -0.01882887891458404, -0.01523556117964176,
        -0.01484082826762111, -0.01698599209055359, -0.01629078287773694, -0.01299170914282408,
        -0.01797733248688675, -0.02292471121050294, -0.02847145629172461,
        -0.03167308893850161])[:, None]
    limits = {'max_velocity': [2.141858351144803], 'max_acceleration': [5.604060811115841],
              'max_jerk': [180.50969706505973]}
    frequency = 0.8036598403252758
    traj, before = plans(points, limits, frequency)
    assert_keeps_the_plan(traj, before, points)
    assert amplitude(traj, frequency)[0].max() <= amplitude(before, frequency)[0].max() + 1e-6


def wrong_side(traj, points):
    """
    Return (2, n): how far each joint passes its start and its goal (sampled).

    In the first segment on the side it moves away from, in the last on
    the side it moves towards; 0 where it does not.
    """
    ends = []
    for at, end, towards in ((slice(0, 2), points[0], np.sign(points[1] - points[0])),
                             (slice(-2, None), points[-1], np.sign(points[-1] - points[-2]))):
        t0, t1 = traj.waypoint_times[at]
        q = traj.evaluate(np.linspace(t0, t1, 4001))
        side = -towards if at.start == 0 else towards
        ends.append(np.max(np.maximum((q - end) * side, 0.0), axis=0))
    return np.array(ends)


@pytest.mark.parametrize('seed', [113, 118, 128, 130, 134, 137])
def test_a_joint_does_not_pass_its_start_or_goal_where_it_did_not(seed):
    """A joint past one bound may not pass another instead (helper-40: 7-8 mrad)."""
    points, limits = walk_request(np.random.default_rng(seed))
    for frequency in (1.5, 4.0):
        traj, before = plans(points, limits, frequency)
        # Round-off: a joint held at its own excess moves it by 1e-9 of it (BLAS threads).
        was = wrong_side(before, points)
        np.testing.assert_array_less(wrong_side(traj, points), was * (1.0 + 1e-6) + 1e-9)


def test_limits_at_the_plans_own_range_are_kept():
    """A joint within the position limits stays within them (helper-40: 8.3e-5 past)."""
    points, limits = walk_request(np.random.default_rng(113))
    before = plans(points, limits, 1.5)[1]
    low, high = before.position_extrema()[:2]
    keep = planner._pulled_within
    planner._pulled_within = lambda traj, options, points: None    # no pull to hide it
    try:
        traj = plan(points, '555', 'optimal', vibration_frequency=1.5,
                    min_position=low - 1e-9, max_position=high + 1e-9, **limits)
    finally:
        planner._pulled_within = keep
    q = traj.evaluate(np.linspace(0.0, traj.duration, 20001))
    assert np.all(q >= low - 1e-9) and np.all(q <= high + 1e-9)


def long_walk(rng):
    """Return a random walk of 6-12 waypoints on 2-6 joints and v/a/j limits (j = 20 a)."""
    return walk_request(rng, waypoints=(6, 13), joints=(2, 7))


def test_the_ringing_after_the_stop_falls_by_half_at_the_median():
    """
    Over random walks of 6-12 waypoints whose plan rings after the stop, at 4 Hz.

    (Shorter requests have fewer free knots than rows to meet, and are often
    left as they are: the first test covers them.)
    """
    ratios = []
    for seed in range(3100, 3100 + examples(20)):
        points, limits = long_walk(np.random.default_rng(seed))
        traj, before = plans(points, limits, 4.0)
        was = amplitude(before, 4.0)[1].max()
        if was > 0.02:
            ratios.append(amplitude(traj, 4.0)[1].max() / was)
    assert len(ratios) >= len(range(examples(20))) // 2
    assert np.median(ratios) <= 0.5


@pytest.mark.parametrize('seed', range(3200, 3200 + examples(6)))
def test_position_limits_and_the_goal_are_not_passed(seed):
    """Limits at the waypoints' range: the moved plan stays within them, as the plan did."""
    points, limits = one_way_request(np.random.default_rng(seed))
    low, high = points.min(axis=0), points.max(axis=0)
    try:
        traj = plan(points, '555', 'optimal', vibration_frequency=4.0, min_position=low,
                    max_position=high, **limits)
    except ValueError:
        return      # the plan itself leaves them (test_position_limits' cases)
    q = traj.evaluate(np.linspace(0.0, traj.duration, 20001))
    assert np.all(q >= low - 1e-12) and np.all(q <= high + 1e-12)


def test_with_torque_limits_nothing_moves():
    """A move changes the torques, and their slow-down would move the cancellation off the mode."""
    points, limits = long_walk(np.random.default_rng(3100))
    n = points.shape[1]
    assert 'residual_knots' in plan(points, '555', 'optimal', vibration_frequency=4.0,
                                    **limits).optimizer

    def inverse_dynamics(q, qd, qdd):
        return 2.0 * qdd + 0.1 * qd

    traj = plan(points, '555', 'optimal', vibration_frequency=4.0,
                max_torque=np.full(n, 1e6), inverse_dynamics=inverse_dynamics, **limits)
    assert 'residual_knots' not in traj.optimizer
