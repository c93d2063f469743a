"""
plan(speed_profile="time_optimal"): the third-order profile followed by a C4 spline (issue 38).

Checked against what the implementation does not compute itself: peaks
from ``numpy.roots`` (``reference_spline.exact_peaks``), the unique C4
quintic spline through the same knots (``scipy.interpolate.
make_interp_spline(k=5)``), 1 kHz samples differenced by numpy, and the
default plan of the same request.
"""

from example_counts import examples
from hypothesis import example, given, settings, strategies as st
import numpy as np
import pytest
from reference_spline import exact_peaks
from scipy.interpolate import CubicSpline, make_interp_spline
from scipy.optimize import linprog
from scipy.signal import lsim
from splines445_ros.planning import plan
from splines445_ros.planning import planner
from splines445_ros.planning.durations.timing import rest_to_rest_durations
from splines445_ros.planning.path_following import time_optimal
from splines445_ros.planning.path_following.path_timing import rescaled
from splines445_ros.planning.path_following.time_optimal import MAX_KNOTS
from splines445_ros.planning.plan_options import MAX_TIME_OPTIMAL_WAYPOINTS
from splines445_ros.planning.speed_profile import smooth_profile
from splines445_ros.planning.spline.limits import JointLimits

PERIOD = 1e-3
# 1 ms finite differences see a mean over 1-3 ms of a plan exactly at its
# limits: within 1 % of them (they are checked exactly by the peaks).
SAMPLED_TOLERANCE = 1.01


def random_request(seed, max_points=9, joints=(3, 7), min_points=2):
    """2-9 waypoints (or as given), 3-7 joints, v in [1, 3], a in [5, 15], j = 10-20 a."""
    rng = np.random.default_rng(seed)
    n_points = int(rng.integers(min_points, max_points + 1))
    n_joints = int(rng.integers(*joints))
    points = np.cumsum(rng.uniform(-0.6, 0.6, (n_points, n_joints)), axis=0)
    v, a = rng.uniform(1.0, 3.0, n_joints), rng.uniform(5.0, 15.0, n_joints)
    return points, {'max_velocity': v, 'max_acceleration': a,
                    'max_jerk': rng.uniform(10.0, 20.0) * a}


def time_optimal_plan(points, limits):
    return plan(points, '555', 'optimal', speed_profile='time_optimal', **limits)


def followed(traj, points):
    """
    Whether ``traj`` is time_optimal's; where it gave way, that it did so as documented.

    The profile stops inside the path where every joint is at rest at once,
    or nearly: a joint reversing alone, or a path that nearly turns back at
    a waypoint (a long hypothesis run's seed 222274349: chords at a cosine
    of -0.99, and the profile's ``x(s)`` dips to 0 between its row points).
    There the default's plan is returned, flagged, within every limit.
    """
    if traj.optimizer.get('speed_profile') == 'time_optimal':
        return True
    assert 'stops inside the path' in traj.optimizer['speed_profile_skipped']
    chords = np.diff(points, axis=0)
    lengths = np.linalg.norm(chords, axis=1)
    cosines = np.sum(chords[:-1] * chords[1:], axis=1) / (lengths[:-1] * lengths[1:])
    assert cosines.size and np.min(cosines) < -0.95
    assert traj.within_limits(rtol=1e-9)
    return False


@settings(max_examples=examples(12), deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_through_every_waypoint_c4_and_within_every_limit(seed):
    """Waypoints at their knots, the C4 quintic through its knots, exact peaks at the limits."""
    points, limits = random_request(seed)
    traj = time_optimal_plan(points, limits)
    if not followed(traj, points):
        return
    # Every waypoint is a knot, passed exactly, at rest at both ends.
    assert np.all(np.isin(traj.waypoint_times, traj.breakpoints))
    scale = max(1.0, float(np.max(np.abs(points))))
    assert np.max(np.abs(traj.ppoly(traj.waypoint_times) - points)) <= 1e-9 * scale
    for t in (0.0, traj.duration):
        for order, name in ((1, 'max_velocity'), (2, 'max_acceleration')):
            assert np.max(np.abs(traj.ppoly(t, nu=order)) / limits[name]) <= 1e-9
    # C4: the PPoly is scipy's C4 quintic spline through the same knot values.
    knots = traj.breakpoints
    zero = np.zeros(points.shape[1])
    reference = make_interp_spline(knots, traj.ppoly(knots), k=5,
                                   bc_type=([(1, zero), (2, zero)], [(1, zero), (2, zero)]))
    fine = np.linspace(0.0, traj.duration, 4001)
    for order in range(5):
        ours, theirs = traj.ppoly(fine, nu=order), reference(fine, nu=order)
        assert np.max(np.abs(ours - theirs)) <= 1e-6 * max(1.0, float(np.max(np.abs(theirs))))
    # Exact peaks within the limits, one of them binding.
    ratios = [exact_peaks(traj.ppoly, k).max(axis=0) / limits[name] for k, name in
              ((1, 'max_velocity'), (2, 'max_acceleration'), (3, 'max_jerk'))]
    assert max(np.max(r) for r in ratios) <= 1.0 + 1e-9
    assert max(np.max(r) for r in ratios) >= 1.0 - 1e-6


@settings(max_examples=examples(8), deadline=None)
@given(st.integers(0, 2**32 - 1))
@example(222274349)     # a path that nearly turns back: the default's plan (followed)
def test_joints_without_a_jerk_limit_hold_velocity_and_acceleration(seed):
    """No jerk limit on some joints (on all, at times): the others' jerk and every v/a held."""
    points, limits = random_request(seed)
    rng = np.random.default_rng(seed)
    free = rng.random(points.shape[1]) < 0.5
    limits['max_jerk'] = np.where(free, np.inf, limits['max_jerk'])
    traj = time_optimal_plan(points, limits)
    if not followed(traj, points):
        return
    scale = max(1.0, float(np.max(np.abs(points))))
    assert np.max(np.abs(traj.ppoly(traj.waypoint_times) - points)) <= 1e-9 * scale
    ratios = [exact_peaks(traj.ppoly, k).max(axis=0) / limits[name] for k, name in
              ((1, 'max_velocity'), (2, 'max_acceleration'), (3, 'max_jerk'))]
    assert max(np.max(r) for r in ratios) <= 1.0 + 1e-9
    # One limit binds (step 4's exact factor): the jerk of a limited joint, or v or a.
    assert max(np.max(r) for r in ratios) >= 1.0 - 1e-6
    assert np.all(np.isfinite(exact_peaks(traj.ppoly, 3)))


def reference_topp_duration(path, vmax, amax, steps=2000):
    """
    Return the v/a time-optimal duration along ``path`` (a PPoly q(s)), by the test's own LP.

    ``x_k = sdot**2`` on a uniform grid, ``u_k = (x_(k+1) - x_k) / (2 ds)``
    (TOPP-RA's discretisation): ``|q'_k u_k + q''_k x_k| <= a`` and
    ``|q'_k| sqrt(x_k) <= v`` for every joint, at rest at both ends.  The
    largest ``x`` is the time-optimal one (``sum x`` maximised); the time
    is the trapezoid sum of ``ds / sqrt(x)``.  First order in the step.
    """
    s = np.linspace(path.x[0], path.x[-1], steps + 1)
    ds = s[1] - s[0]
    d1, d2 = path(s[:-1], 1), path(s[:-1], 2)
    rows, bounds = [], []
    forward = (np.eye(steps, steps + 1, 1) - np.eye(steps, steps + 1)) / (2.0 * ds)
    for j in range(d1.shape[1]):
        acceleration = d1[:, j, None] * forward + d2[:, j, None] * np.eye(steps, steps + 1)
        rows += [acceleration, -acceleration]
        bounds += [np.full(steps, amax[j])] * 2
    with np.errstate(divide='ignore'):
        cap = np.min((vmax / np.abs(path(s, 1))) ** 2, axis=1)
    cap[[0, -1]] = 0.0
    result = linprog(-np.ones(steps + 1), A_ub=np.vstack(rows), b_ub=np.concatenate(bounds),
                     bounds=list(zip(np.zeros(steps + 1), np.minimum(cap, 1e12))),
                     method='highs')
    assert result.status == 0, result.message
    x = np.maximum(result.x, 0.0)
    return float(np.sum(2.0 * ds / (np.sqrt(x[:-1]) + np.sqrt(x[1:]))))


@pytest.mark.parametrize('seed, min_points, most', [
    (0, 8, 1.03), (1, 8, 1.03), (2, 8, 1.03), (3, 2, 1.08), (4, 2, 1.08)])
def test_with_no_jerk_limit_it_is_the_velocity_acceleration_optimum_of_its_path(
        seed, min_points, most):
    """
    Within 3 % of the test's own v/a optimum along its path on 8-12 waypoints (issue 38).

    The path is step 1's: the natural cubic through the waypoints at their
    rest-to-rest times (scipy's CubicSpline here).  The spline follows it
    between knots only closely, so the duration may fall a little below.
    The profile's ``x`` is C2 (a B-spline knot every 2 of 24 grid steps a
    segment): it cannot switch from accelerating to braking at a point,
    which costs up to 7 % on a single segment (``most`` 1.08 from 2 waypoints).
    """
    points, limits = random_request(300 + seed, max_points=12, min_points=min_points)
    limits['max_jerk'] = None
    traj = time_optimal_plan(points, limits)
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    vmax, amax = limits['max_velocity'], limits['max_acceleration']
    durations = rest_to_rest_durations(points, JointLimits(vmax, amax,
                                                           np.full(vmax.size, np.inf)))
    knots = np.concatenate([[0.0], np.cumsum(durations)])
    path = CubicSpline(knots, points, bc_type='natural')
    reference = reference_topp_duration(path, vmax, amax)
    assert 0.98 * reference <= traj.duration <= most * reference, traj.duration / reference


@pytest.mark.parametrize('seed', range(4))
def test_sampled_every_millisecond_within_the_limits(seed):
    """1 kHz samples, differenced by numpy, hold v/a/j within SAMPLED_TOLERANCE."""
    points, limits = random_request(100 + seed)
    traj = time_optimal_plan(points, limits)
    t = np.arange(-3, int(np.ceil(traj.duration / PERIOD)) + 4) * PERIOD
    q = traj.ppoly(np.clip(t, 0.0, traj.duration))
    for k, name in ((1, 'max_velocity'), (2, 'max_acceleration'), (3, 'max_jerk')):
        sampled = np.max(np.abs(np.diff(q, k, axis=0)), axis=0) / PERIOD ** k
        assert np.all(sampled <= SAMPLED_TOLERANCE * limits[name]), (k, sampled / limits[name])


def test_shorter_than_the_default_on_typical_requests():
    """The default averages its profile over 0.45 s of windows: the followed profile is shorter."""
    ratios = []
    for seed in range(8):
        points, limits = random_request(200 + seed)
        ours = time_optimal_plan(points, limits)
        default = plan(points, '555', 'optimal', **limits)
        assert ours.duration >= ours.duration_lower_bound() * (1.0 - 1e-9)
        ratios.append(ours.duration / default.duration)
    assert np.median(ratios) < 0.95, ratios
    assert max(ratios) < 1.0, ratios


def test_merged_waypoints_are_reported():
    """A near-duplicate waypoint is merged and reported, as with the default."""
    points = np.array([[0.0, 0.0], [0.5, 1.0], [0.5 + 1e-9, 1.0], [1.0, 0.2]])
    limits = {'max_velocity': [1.0, 2.0], 'max_acceleration': [5.0, 5.0],
              'max_jerk': [100.0, 100.0]}
    traj = time_optimal_plan(points, limits)
    assert traj.dropped_waypoints == (2,)
    assert traj.waypoint_times.size == 3
    # A uniform slow-down (torque's and tool lines' 1 kHz checks) still reports it:
    # helper-20's fuzz found torque-limited plans that had lost it.
    slow = rescaled(traj, 1.2)
    assert slow.dropped_waypoints == (2,)
    assert slow.duration == pytest.approx(1.2 * traj.duration, rel=1e-9)


@pytest.mark.parametrize('kwargs, message', [
    ({'speed_profile': 'fastest'}, 'speed_profile must be one of'),
    ({'inner_knots': 4}, 'leave inner_knots unset'),
    ({'smoothing': 'none'}, "smoothing 'none' would be ignored"),
    ({'timing': 'uniform'}, 'needs method "555" with timing "optimal"'),
    ({'method': '445'}, 'needs method "555" with timing "optimal"'),
])
def test_what_it_would_ignore_or_cannot_hold_is_refused(kwargs, message):
    """Each option it cannot honour is a ValueError with the reason."""
    args = {'max_velocity': [1.0, 2.0], 'max_acceleration': [5.0, 5.0],
            'max_jerk': [100.0, 100.0], 'speed_profile': 'time_optimal',
            'method': '555', 'timing': 'optimal'}
    args.update(kwargs)
    method, timing = args.pop('method'), args.pop('timing')
    with pytest.raises(ValueError) as error:
        plan(np.array([[0.0, 0.0], [1.0, 0.5]]), method, timing, **args)
    assert message in str(error.value)


def test_too_many_waypoints_are_refused():
    """Its linear programs grow with the path: a bound on the waypoints, with the reason."""
    limits = {'max_velocity': [1.0], 'max_acceleration': [5.0], 'max_jerk': [100.0]}
    many = np.arange(MAX_TIME_OPTIMAL_WAYPOINTS + 1, dtype=float)[:, None] * 0.1
    with pytest.raises(ValueError, match=f'at most {MAX_TIME_OPTIMAL_WAYPOINTS} waypoints'):
        plan(many, '555', 'optimal', speed_profile='time_optimal', **limits)


class TwoLinkDynamics:
    """
    The test's own inverse dynamics: a planar two-link arm with point masses (vectorised).

    tau = M(q) qdd + C(q, qd) qd + g(q), written out from the Lagrangian of
    masses m1, m2 at the ends of links l1, l2, gravity along -y.
    """

    m1, m2, l1, l2, g = 2.0, 1.0, 0.5, 0.4, 9.81

    def __call__(self, q, qd, qdd):
        q, qd, qdd = (np.atleast_2d(v) for v in (q, qd, qdd))
        m1, m2, l1, l2, g = self.m1, self.m2, self.l1, self.l2, self.g
        c2, s2 = np.cos(q[:, 1]), np.sin(q[:, 1])
        m11 = (m1 + m2) * l1 ** 2 + m2 * l2 ** 2 + 2 * m2 * l1 * l2 * c2
        m12 = m2 * l2 ** 2 + m2 * l1 * l2 * c2
        m22 = np.full_like(c2, m2 * l2 ** 2)
        h = m2 * l1 * l2 * s2
        gravity1 = (m1 + m2) * g * l1 * np.cos(q[:, 0]) + m2 * g * l2 * np.cos(q[:, 0] + q[:, 1])
        gravity2 = m2 * g * l2 * np.cos(q[:, 0] + q[:, 1])
        tau1 = (m11 * qdd[:, 0] + m12 * qdd[:, 1] - h * (2 * qd[:, 0] * qd[:, 1] + qd[:, 1] ** 2)
                + gravity1)
        tau2 = m12 * qdd[:, 0] + m22 * qdd[:, 1] + h * qd[:, 0] ** 2 + gravity2
        return np.column_stack([tau1, tau2])


@pytest.mark.parametrize('seed', range(3))
def test_torque_limits_are_rows_of_the_profile_and_held_every_millisecond(seed):
    """The two-link arm's torque, by the test's dynamics at 1 kHz, within the limits, binding."""
    rng = np.random.default_rng(300 + seed)
    points = np.cumsum(rng.uniform(-0.8, 0.8, (int(rng.integers(3, 7)), 2)), axis=0)
    dynamics = TwoLinkDynamics()
    # Gravity alone needs at most 15.7 N m at joint 1 and 3.9 N m at joint 2.
    max_torque = np.array([20.0, 6.0])
    limits = {'max_velocity': [3.0, 3.0], 'max_acceleration': [40.0, 40.0],
              'max_jerk': [5000.0, 5000.0]}
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                max_torque=max_torque, inverse_dynamics=dynamics, **limits)
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    t = np.linspace(0.0, traj.duration, int(traj.duration / PERIOD) + 1)
    tau = dynamics(traj.ppoly(t), traj.ppoly(t, nu=1), traj.ppoly(t, nu=2))
    ratio = np.max(np.abs(tau) / max_torque)
    assert ratio <= 1.0 + 1e-6
    # The torque binds: its peak reaches the limit (the profile is time-optimal
    # under it; v or a may bind elsewhere on the path too).
    assert ratio >= 0.95
    assert traj.limit_ratios().max() <= 1.0 + 1e-9
    # And the default plan with the same torque limits is not much shorter.
    default = plan(points, '555', 'optimal', max_torque=max_torque,
                   inverse_dynamics=dynamics, **limits)
    assert traj.duration <= 1.05 * default.duration


def test_gravity_above_the_torque_limit_is_refused_naming_the_joint():
    """A pose where gravity alone exceeds a limit cannot be traversed at any speed."""
    with pytest.raises(ValueError, match='joint 0'):
        plan([[0.0, 0.0], [0.3, 0.2]], '555', 'optimal', speed_profile='time_optimal',
             max_torque=[5.0, 20.0], inverse_dynamics=TwoLinkDynamics(),
             max_velocity=[3.0, 3.0], max_acceleration=[40.0, 40.0],
             max_jerk=[800.0, 800.0])


class FailingProfile:
    """A stand-in for SmoothProfile whose first LP fails."""

    def __init__(self, *args):
        raise RuntimeError('the first LP of the smooth profile failed: infeasible')


@pytest.mark.parametrize('failure', ['no spline', 'first LP'])
def test_no_spline_falls_back_to_the_default_and_says_so(monkeypatch, failure):
    """No spline found, or the profile's first LP failing: the default plan, flagged."""
    if failure == 'no spline':
        def no_spline(*args):
            raise time_optimal.NoSpline("no spline through the profile's knots")

        monkeypatch.setattr(planner, 'plan_time_optimal', no_spline)
        why = "no spline through the profile's knots"
    else:
        monkeypatch.setattr(time_optimal, 'SmoothProfile', FailingProfile)
        why = 'the first LP of the smooth profile failed: infeasible'
    points, limits = random_request(7)
    traj = time_optimal_plan(points, limits)
    default = plan(points, '555', 'optimal', **limits)
    assert traj.optimizer['speed_profile_skipped'] == f'{planner.NO_TIME_OPTIMAL_SPLINE}: {why}'
    assert traj.duration == pytest.approx(default.duration, rel=1e-12)


@pytest.mark.parametrize('seed', [2, 3, 11])
def test_a_joint_reversing_alone_is_followed_or_falls_back_within_the_limits(seed):
    """
    One or two joints: followed, or the default's plan, flagged, and still exact.

    A joint reversing alone can make the profile stop between its row
    points, which its C2 x(s) cannot do in finite time.
    """
    points, limits = random_request(seed, joints=(1, 3))
    traj = time_optimal_plan(points, limits)
    assert (traj.optimizer.get('speed_profile') == 'time_optimal'
            or traj.optimizer['speed_profile_skipped'].startswith(planner.NO_TIME_OPTIMAL_SPLINE))
    scale = max(1.0, float(np.max(np.abs(points))))
    assert np.max(np.abs(traj.ppoly(traj.waypoint_times) - points)) <= 1e-9 * scale
    for k, name in ((1, 'max_velocity'), (2, 'max_acceleration'), (3, 'max_jerk')):
        assert np.all(exact_peaks(traj.ppoly, k).max(axis=0) <= limits[name] * (1.0 + 1e-9))


@settings(max_examples=examples(10), deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_moving_ends_are_kept_exactly_within_every_limit(seed):
    """
    A moving start (and end): the boundary values exactly, every limit, every waypoint.

    Followed, or (when the profile finds no spline that keeps them) the
    default's plan, flagged; never an infeasible one.
    """
    points, limits = random_request(seed)
    rng = np.random.default_rng(seed)
    n = points.shape[1]
    values = {'start_velocity': 0.4 * limits['max_velocity'] * rng.uniform(-1, 1, n),
              'start_acceleration': 0.3 * limits['max_acceleration'] * rng.uniform(-1, 1, n)}
    if seed % 2:
        values['end_velocity'] = 0.3 * limits['max_velocity'] * rng.uniform(-1, 1, n)
    traj = time_optimal_plan(points, dict(limits, **values))
    assert (traj.optimizer.get('speed_profile') == 'time_optimal'
            or traj.optimizer['speed_profile_skipped'].startswith(planner.NO_TIME_OPTIMAL_SPLINE))
    for t, velocity, acceleration in (
            (0.0, values['start_velocity'], values['start_acceleration']),
            (traj.duration, values.get('end_velocity', np.zeros(n)), np.zeros(n))):
        assert np.allclose(traj.ppoly(t, nu=1), velocity, atol=1e-9)
        assert np.allclose(traj.ppoly(t, nu=2), acceleration, atol=1e-9)
    scale = max(1.0, float(np.max(np.abs(points))))
    assert np.max(np.abs(traj.ppoly(traj.waypoint_times) - points)) <= 1e-9 * scale
    for k, name in ((1, 'max_velocity'), (2, 'max_acceleration'), (3, 'max_jerk')):
        assert np.all(exact_peaks(traj.ppoly, k).max(axis=0) <= limits[name] * (1.0 + 1e-9))


def test_moving_starts_are_mostly_followed_and_shorter():
    """On requests of 3-7 waypoints moving at the start, the profile is followed and gains."""
    followed, ratios = 0, []
    for seed in range(12):
        points, limits = random_request(400 + seed)
        if len(points) < 3:
            continue
        n = points.shape[1]
        rng = np.random.default_rng(seed)
        limits['start_velocity'] = 0.4 * limits['max_velocity'] * rng.uniform(-1, 1, n)
        traj = time_optimal_plan(points, limits)
        followed += traj.optimizer.get('speed_profile') == 'time_optimal'
        ratios.append(traj.duration / plan(points, '555', 'optimal', **limits).duration)
    assert followed >= 0.9 * len(ratios), (followed, len(ratios))
    assert np.median(ratios) < 1.0, ratios


def test_the_fallback_is_the_default_plan_of_the_request_as_it_came(monkeypatch):
    """Near-duplicates merged once: the fallback is exactly the default's plan, flagged."""
    def no_spline(*args):
        raise time_optimal.NoSpline('none')

    monkeypatch.setattr(planner, 'plan_time_optimal', no_spline)
    points = [[0.0], [1.0], [1.0015], [1.0008]]
    limits = {'max_velocity': [1.0], 'max_acceleration': [5.0], 'max_jerk': [100.0]}
    traj = time_optimal_plan(np.array(points), limits)
    default = plan(points, '555', 'optimal', **limits)
    assert traj.optimizer['speed_profile_skipped'] == f'{planner.NO_TIME_OPTIMAL_SPLINE}: none'
    assert traj.dropped_waypoints == default.dropped_waypoints
    assert traj.waypoint_times.size == traj.waypoints.shape[0] == default.waypoints.shape[0]
    assert traj.duration == pytest.approx(default.duration, rel=1e-12)


def test_a_long_plan_has_a_bounded_number_of_knots():
    """Knots about every 15 ms, but not more than about MAX_KNOTS in all (a 200 s plan)."""
    traj = plan([[0.0], [1.0], [0.0]], '555', 'optimal', speed_profile='time_optimal',
                max_velocity=[0.01], max_acceleration=[0.01], max_jerk=[0.01])
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    assert traj.duration > 1.2 * MAX_KNOTS * time_optimal.KNOT_PERIOD
    assert MAX_KNOTS / 2 <= traj.breakpoints.size <= MAX_KNOTS + 10
    assert traj.within_limits(rtol=1e-9)


def test_a_profile_the_solver_refuses_falls_back_within_the_limits():
    """A plan of milliseconds (entries beyond HiGHS's bounds): the default's plan, flagged."""
    limits = {'max_velocity': [1e6] * 2, 'max_acceleration': [1e8] * 2, 'max_jerk': [1e12] * 2}
    traj = time_optimal_plan(np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]]), limits)
    assert (traj.optimizer.get('speed_profile') == 'time_optimal'
            or traj.optimizer['speed_profile_skipped'].startswith(planner.NO_TIME_OPTIMAL_SPLINE))
    assert traj.within_limits(rtol=1e-9)


def test_the_knots_are_about_one_knot_period_apart(monkeypatch):
    """Knot spacing follows time_optimal.KNOT_PERIOD, read when the plan is made."""
    points, limits = random_request(7, max_points=12, min_points=8)
    spacing = {}
    for period in (0.015, 0.045):
        monkeypatch.setattr(time_optimal, 'KNOT_PERIOD', period)
        traj = time_optimal_plan(points, limits)
        spacing[period] = np.median(np.diff(traj.breakpoints))
        # At most the period apart (the segments' counts are rounded up, pieces halved).
        assert period / 2.5 <= spacing[period] <= period * (1 + 1e-9), (period, spacing)
    assert spacing[0.045] > 2.0 * spacing[0.015]


def residual_vibration(traj, frequency, limit, zeta=0.02, rate=1000.0, periods=2.0):
    """
    Return the largest ringing after ``traj`` ends, of a mode at ``frequency`` on each joint.

    ``x'' + 2 zeta w x' + w**2 x = -qdd(t)``, driven by the plan's own
    acceleration (its polynomials, sampled at ``rate``) and then by
    nothing for ``periods`` periods; in units of ``a / w**2`` per joint
    (the static deflection at its acceleration ``limit``).
    """
    w = 2.0 * np.pi * frequency
    t = np.arange(0.0, traj.duration + periods / frequency, 1.0 / rate)
    qdd = np.where(t[:, None] <= traj.duration, traj.ppoly(np.minimum(t, traj.duration), 2),
                   0.0)
    after = t > traj.duration
    worst = 0.0
    for j in range(qdd.shape[1]):
        _, x, _ = lsim(([-1.0], [1.0, 2.0 * zeta * w, w * w]), qdd[:, j], t)
        worst = max(worst, np.max(np.abs(x[after])) * w * w / limit[j])
    return worst


@pytest.mark.parametrize('seed, jerk_limited, frequency', [
    (0, True, 4.0), (1, True, 4.0), (2, True, 8.0), (3, True, 4.0), (4, False, 4.0),
    (5, False, 8.0)])
def test_vibration_frequency_cancels_the_ringing_after_the_stop(seed, jerk_limited, frequency):
    """The test's own damped oscillator at f rings at most 0.2 a / w**2 after the stop."""
    points, limits = random_request(500 + seed, max_points=12, min_points=5)
    if not jerk_limited:
        limits['max_jerk'] = None
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                vibration_frequency=frequency, **limits)
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    assert traj.within_limits(rtol=1e-9)
    assert np.max(np.abs(traj.ppoly(traj.waypoint_times) - points)) <= 1e-9 * max(
        1.0, float(np.max(np.abs(points))))
    a = limits['max_acceleration']
    ringing = residual_vibration(traj, frequency, a)
    plain = time_optimal_plan(points, limits)
    assert plain.optimizer['vibration_residual'] is None
    # The plain profile stops with jerk ramps far shorter than a period: 0.2-2.1 here.
    assert ringing <= min(0.2, 0.3 * residual_vibration(plain, frequency, a))
    # What the plan reports is this ringing (its amplitude: the oscillator's
    # largest swing over the next two periods is within a few % of it).
    assert traj.optimizer['vibration_residual'] == pytest.approx(ringing, rel=0.1, abs=0.01)
    # A stop shaped for the mode costs a share of its period, not periods.
    assert traj.duration <= plain.duration + 1.0 / frequency


def test_vibration_frequency_leaves_less_ringing_after_the_end():
    """The test's own damped oscillator at f rings far less after the stop (2-6 s moves)."""
    ratios = []
    for seed in range(6):
        points, limits = random_request(600 + seed, max_points=12, min_points=5)
        plain = time_optimal_plan(points, limits)
        cancelled = plan(points, '555', 'optimal', speed_profile='time_optimal',
                         vibration_frequency=4.0, **limits)
        a = limits['max_acceleration']
        ratios.append(residual_vibration(cancelled, 4.0, a) / residual_vibration(plain, 4.0, a))
    assert np.median(ratios) < 0.1, ratios


@pytest.mark.parametrize('frequency, most', [(1000.0, None), (4.0, -1)])
def test_a_mode_the_grid_cannot_hold_is_left_and_reported(frequency, most, monkeypatch):
    """1 kHz on a plan of seconds (64 000 points), or 4 Hz with no points allowed: left alone."""
    if most is not None:
        monkeypatch.setattr(smooth_profile, 'MAX_MODE_POINTS', most)
    points, limits = random_request(502, max_points=12, min_points=5)
    plain = time_optimal_plan(points, limits)
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                vibration_frequency=frequency, **limits)
    assert traj.optimizer['profile_lps'] == plain.optimizer['profile_lps']
    assert np.array_equal(traj.ppoly.c, plain.ppoly.c)
    ringing = residual_vibration(traj, frequency, limits['max_acceleration'],
                                 rate=max(1000.0, 40.0 * frequency))
    assert traj.optimizer['vibration_residual'] == pytest.approx(ringing, rel=0.1, abs=0.01)
    if frequency == 4.0:
        assert ringing > 0.2    # the rows would have run


def test_a_spline_far_from_its_profile_s_time_has_it_cancel_the_stretched_mode(monkeypatch):
    """With j = 3 a the spline's exact factor is 0.97: it rings at f as its profile at 0.97 f."""
    points, limits = random_request(715, max_points=8, min_points=3)
    limits['max_jerk'] = 3.0 * np.asarray(limits['max_acceleration'])
    a = limits['max_acceleration']
    monkeypatch.setattr(time_optimal, 'RESIDUAL_SCALE', np.inf)
    once = plan(points, '555', 'optimal', speed_profile='time_optimal',
                vibration_frequency=4.0, **limits)
    monkeypatch.undo()
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                vibration_frequency=4.0, **limits)
    assert abs(once.optimizer['time_scale'] - 1.0) > time_optimal.RESIDUAL_SCALE
    assert traj.within_limits(rtol=1e-9)
    ringing = residual_vibration(traj, 4.0, a)
    # The figure is the plan's at the user's f, not the profile's f k.
    assert traj.optimizer['vibration_residual'] == pytest.approx(ringing, rel=0.1, abs=0.01)
    assert traj.optimizer['vibration_frequency'] == 4.0
    assert ringing < 0.7 * residual_vibration(once, 4.0, a)


def test_a_uniform_slow_down_measures_the_ringing_again():
    """path_timing.rescaled (the torque's and the tool lines' 1 kHz checks): the figure follows."""
    points, limits = random_request(503, max_points=12, min_points=5)
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                vibration_frequency=4.0, **limits)
    slow = rescaled(traj, 1.05)
    ringing = residual_vibration(slow, 4.0, limits['max_acceleration'])
    assert slow.optimizer['vibration_residual'] == pytest.approx(ringing, rel=0.1, abs=0.01)
    assert abs(ringing - traj.optimizer['vibration_residual']) > 0.02


def test_a_slow_down_of_a_plan_with_knots_at_its_waypoints_measures_it_again():
    """planner.slowed_down rebuilds such a plan (no inner knots): its figure follows too."""
    points, limits = random_request(503, max_points=12, min_points=5)
    traj = plan(points, '555', 'optimal', inner_knots=0, **limits)
    assert traj.breakpoints.size == traj.waypoint_times.size
    # A time_optimal plan whose segments all last under a knot period looks like this.
    traj.optimizer = dict(traj.optimizer or {}, vibration_frequency=4.0,
                          vibration_residual=residual_vibration(traj, 4.0,
                                                                limits['max_acceleration']))
    slow = planner.slowed_down(traj, 1.05)
    ringing = residual_vibration(slow, 4.0, limits['max_acceleration'])
    assert slow.optimizer['vibration_residual'] == pytest.approx(ringing, rel=0.1, abs=0.01)
    assert abs(ringing - traj.optimizer['vibration_residual']) > 0.02
    assert slow.optimizer['time_scale'] == 1.05


def test_a_long_segment_is_cancelled_too():
    """Two waypoints 5 s apart: the row points are 17-50 ms apart, the mode's grid is not."""
    points = np.array([[0.0, 0.0, 0.0], [-2.1, 1.2, 2.4]])
    limits = {'max_velocity': [0.5] * 3, 'max_acceleration': [2.0] * 3, 'max_jerk': [30.0] * 3}
    plain = time_optimal_plan(points, limits)
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                vibration_frequency=4.0, **limits)
    assert plain.duration > 4.0
    ringing = residual_vibration(traj, 4.0, limits['max_acceleration'])
    assert ringing <= min(0.15, 0.3 * residual_vibration(plain, 4.0, limits['max_acceleration']))
    assert traj.optimizer['vibration_residual'] == pytest.approx(ringing, rel=0.1, abs=0.01)
    assert traj.duration <= 1.15 * plain.duration


def test_a_moving_end_is_not_cancelled():
    """The cancellation is for a stop: with an end velocity there is none, and none reported."""
    points, limits = random_request(501, max_points=12, min_points=5)
    direction = np.sign(points[-1] - points[-2])
    moving = plan(points, '555', 'optimal', speed_profile='time_optimal',
                  vibration_frequency=4.0, end_velocity=0.1 * direction, **limits)
    assert moving.optimizer['speed_profile'] == 'time_optimal'
    assert moving.optimizer['vibration_residual'] is None
    assert np.allclose(moving.evaluate([moving.duration], 1)[0], 0.1 * direction, atol=1e-9)
    started = plan(points, '555', 'optimal', speed_profile='time_optimal',
                   vibration_frequency=4.0, start_velocity=0.1 * np.sign(points[1] - points[0]),
                   **limits)
    assert started.optimizer['speed_profile'] == 'time_optimal'
    ringing = residual_vibration(started, 4.0, limits['max_acceleration'])
    assert ringing <= 0.2
    assert started.optimizer['vibration_residual'] == pytest.approx(ringing, rel=0.1, abs=0.01)


def test_a_slow_start_is_followed_not_skipped():
    """
    A request whose profile leaves rest slowly (a joint with j = 7 a): its time law inverts there.

    Found by a fuzz run: Newton's steps in s(t) met 0 / 0 next to the rest
    end, every knot there had no position, and plan() fell back to the
    default (5.08 s instead of 4.69 s).
    """
    rng = np.random.default_rng(1074)
    n_points, n_joints = int(rng.integers(2, 12)), int(rng.integers(1, 8))
    scale = 10 ** rng.uniform(-3, 2)
    points = np.cumsum(rng.uniform(-1, 1, (n_points, n_joints)) * scale
                       * (rng.random((n_points, n_joints)) < 0.8), axis=0)
    rng.random()
    v = 10 ** rng.uniform(-2, 1.5, n_joints)
    a = v * 10 ** rng.uniform(-0.5, 1.5, n_joints)
    rng.random()
    j = a * 10 ** rng.uniform(0.3, 2.5, n_joints)
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal', vibration_frequency=2.0,
                max_velocity=v, max_acceleration=a, max_jerk=j)
    assert 'speed_profile_skipped' not in traj.optimizer
    assert traj.optimizer['speed_profile'] == 'time_optimal'
    assert traj.within_limits(rtol=1e-9)


def test_retime_path_times_a_plan_of_tens_of_milliseconds():
    """
    A plan of 45 ms (fewer grid steps than the profile's end regions) is retimed, not refused.

    retime_path's grid had a step every 10 ms, 4 on this plan, and the
    profile refused it (ValueError, swallowed as if a constraint had).
    """
    points = np.array([[0.0, 0.0], [1e-4, 2e-4]])
    v, a = np.array([1.0, 1.0]), np.array([10.0, 10.0])
    traj = plan(points, '555', 'optimal', max_velocity=v, max_acceleration=a,
                max_jerk=20.0 * a)
    assert traj.duration < 0.1
    retimed = time_optimal.retime_path(traj, traj.limits)
    assert retimed is not None
    assert retimed.optimizer['speed_profile'] == time_optimal.NAME
    assert np.allclose(retimed.ppoly(retimed.waypoint_times), points, rtol=0.0, atol=1e-12)
    assert retimed.within_limits(rtol=1e-9)
    # Rest to rest: no velocity or acceleration at either end.
    for k in (1, 2):
        assert np.allclose(retimed.ppoly.derivative(k)(retimed.waypoint_times[[0, -1]]), 0.0,
                           atol=1e-9)


def test_a_joint_reversing_alone_with_a_mode_plans_without_an_internal_error():
    """
    One joint reversing 20 times (a stop each: x = 0 at neighbouring row points), 1.5 Hz.

    Found by helper-20's fuzz (its seed 1169, rounded): the mode grid's
    parts of ~1e305 s steps overflowed their integer cast, and np.repeat's
    "repeats may not contain negative values" left plan() as a ValueError
    about nothing the user gave.
    """
    walk = [0.206, 0.15, -0.05, -0.043, -0.333, -0.282, -0.466, -0.437, -0.701, -0.718,
            -0.508, -0.712, -0.596, -0.696, -0.458, -0.721, -0.763, -0.843, -0.866, -1.069,
            -0.971, -0.762, -0.781, -0.827, -0.654, -0.652, -0.489, -0.615, -0.534, -0.798,
            -0.986, -0.707, -0.798, -0.517, -0.309, -0.469, -0.652, -0.372, -0.328, -0.278]
    points = np.array(walk)[:, None]
    limits = {'max_velocity': [3.73], 'max_acceleration': [10.1], 'max_jerk': [1.24]}
    traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                vibration_frequency=1.5, **limits)
    assert traj.within_limits(rtol=1e-9)
    assert np.allclose(traj.ppoly(traj.waypoint_times), points, rtol=0.0, atol=1e-9)


def test_replanning_from_a_running_plans_states_at_a_limit_is_followed():
    """
    From the states of a running time_optimal plan at a v or a limit: mostly followed, exactly.

    Such a state is at its limit more often than not, and the profile's
    lowered limits (0.98, ...) were below its own velocity or acceleration:
    its first LP was infeasible in 115 of 117 such states
    (bench_replanning.py, seed 1362917117).
    The profile's limits now stay at or above the state's own, on paths
    whose first segment lasts 1, 1.25 or 1.5 times its rest-to-rest time:
    13 of these 15 states (1 before; 10 at 1 alone).
    """
    rng = np.random.default_rng(1)
    limits = {'max_velocity': [2.0] * 3, 'max_acceleration': [10.0] * 3,
              'max_jerk': [200.0] * 3}
    v, a = np.asarray(limits['max_velocity']), np.asarray(limits['max_acceleration'])
    running = time_optimal_plan(np.cumsum(rng.uniform(-0.8, 0.8, (6, 3)), axis=0), limits)
    goal = running.waypoints[-1] + np.cumsum(rng.uniform(-0.8, 0.8, (3, 3)), axis=0)
    at_limit = followed = 0
    for t in np.arange(0.05, running.duration, 0.1):
        q, qd, qdd = (running.evaluate(np.array([t]), k)[0] for k in range(3))
        if max(np.max(np.abs(qd) / v), np.max(np.abs(qdd) / a)) < 0.96:
            continue
        at_limit += 1
        points = np.vstack([q, goal])
        try:
            traj = plan(points, '555', 'optimal', speed_profile='time_optimal',
                        start_velocity=qd, start_acceleration=qdd, **limits)
        except ValueError:
            continue        # no plan of any kind from this state
        if traj.optimizer.get('speed_profile') != time_optimal.NAME:
            continue
        followed += 1
        assert traj.within_limits(rtol=1e-9)
        assert np.allclose(traj.ppoly(traj.waypoint_times), points, rtol=0.0, atol=1e-9)
        for k, value in ((1, qd), (2, qdd)):
            assert np.allclose(traj.ppoly.derivative(k)(0.0), value, rtol=1e-9, atol=1e-9)
    assert at_limit >= 8
    assert followed >= 0.7 * at_limit, (followed, at_limit)
