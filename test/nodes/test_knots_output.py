"""
``output: knots``: joint_trajectory_controller's interpolation of the knots is the plan.

Between two points that both carry positions, velocities and accelerations,
ros2_control's joint_trajectory_controller runs the quintic polynomial through
those six values (its ``interpolation_method: splines``).  :func:`hermite` below
is that interpolation, written here from its definition (a linear solve of the
six end conditions, in the controller's time: integer nanoseconds of
``time_from_start``), not from the package's code.  Every segment the planner
makes has degree <= 5, so the quintic through its end states is the segment
itself: the knots published by the planner must reproduce the library
trajectory to 1e-9 of each derivative's peak, derivatives 0 to 3, at dense
times between them.

One effect is not round-off: ``time_from_start`` has a resolution of 1 ns, and
the knots are published at their rounded times with the spline's state there.
Where the jerk is continuous (445, 555) the states of the two segments at a
rounded knot agree to (snap jump) * (0.5 ns)^2 / 2, nothing.  Where the jerk
jumps (434) they differ by up to (jerk jump) * (rounding) in acceleration, and
the interpolation carries that difference into the neighbouring intervals; the
test allows exactly that much for 434 (computed with the same Hermite basis),
and requires 1e-9 alone for 434 when the knots lie on the nanosecond grid.
"""

from hypothesis import assume, given, settings, strategies as st
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from splines445_ros.nodes.ros_conversions import sampled_trajectory_from_msg, trajectory_to_msg
from splines445_ros.planning import plan
from splines445_ros.robot import paper_example as pe
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.service.request_planning import output_samples
from splines445_ros.tools.plot_trajectory import controller_view
from trajectory_msgs.msg import JointTrajectory

NANOS = 1_000_000_000
METHODS = ['434', '445', '555']
RTOL = 1e-9
# Round-off: a few units of eps on each of the six end values (see interpolation_errors).
FLOAT_SLACK = 4.0
INSIDE = np.linspace(0.0, 1.0, 13)[1:-1]  # dense times inside every interval, as fractions
# Planning with boundary values dominates the time: a third of the profile's examples
# for each of the nine method and timing combinations below (more with the long profile).
EXAMPLES = settings(max_examples=max(20, settings.default.max_examples // 3))


def hermite(h, start, end, tau, derivative):
    """
    Evaluate the quintic through ``start`` and ``end`` ((p, v, a), each (n,)) at 0 and h.

    Returns its ``derivative`` at local times ``tau`` (K,): shape (K, n).
    """
    powers = np.arange(6)

    def rows(t):
        # Rows of p(t), p'(t), p''(t) for the monomial coefficients c_0..c_5 of tau.
        out = []
        for d in range(3):
            factor = np.array([np.prod(np.arange(i - d + 1, i + 1)) if i >= d else 0.0
                               for i in powers])
            out.append(factor * (float(t) ** np.maximum(powers - d, 0)))
        return out
    matrix = np.array(rows(0.0) + rows(h))
    coefficients = np.linalg.solve(matrix, np.vstack([*start, *end]))  # (6, n)
    factor = np.array([np.prod(np.arange(i - derivative + 1, i + 1)) if i >= derivative
                       else 0.0 for i in powers])
    basis = factor * np.asarray(tau, dtype=float)[:, None] ** np.maximum(powers - derivative, 0)
    return basis @ coefficients


def message_arrays(msg):
    """time_from_start in integer ns (K,) and positions, velocities, accelerations (K, n)."""
    ns = np.array([p.time_from_start.sec * NANOS + p.time_from_start.nanosec
                   for p in msg.points], dtype=np.int64)
    return ns, [np.array([getattr(p, f) for p in msg.points])
                for f in ('positions', 'velocities', 'accelerations')]


def controller_hermite(msg):
    """Return the controller's interpolation of ``msg``: (k, h, tau, derivative) -> (K, n)."""
    _, states = message_arrays(msg)

    def interpolate(k, h, tau, derivative):
        return hermite(h, [s[k] for s in states], [s[k + 1] for s in states], tau, derivative)
    return interpolate


def interpolation_errors(msg, traj, interpolate=None, derivatives=4):
    """
    Largest |interpolation - library| per derivative, as a ratio to its bound (> 1 fails).

    ``interpolate(k, h, tau, derivative)`` gives the interpolation between
    points k and k + 1 of ``msg`` (h apart) at local times ``tau``; default the
    controller's (:func:`hermite`).  The bound is RTOL times the derivative's
    peak over the compared times (all joints), plus, where the jerk jumps at
    a knot whose time was rounded, the effect of that rounding (see the module
    docstring).
    """
    interpolate = interpolate or controller_hermite(msg)
    ns, states = message_arrays(msg)
    pieces, times = [], []
    for k in range(len(ns) - 1):
        h_ns = int(ns[k + 1] - ns[k])
        offsets = np.round(INSIDE * h_ns).astype(np.int64)
        times.append((ns[k] + offsets) * 1e-9)
        pieces.append((k, h_ns * 1e-9, offsets * 1e-9))
    t = np.concatenate(times)
    reference = [traj.evaluate(t, d) for d in range(derivatives)]
    peaks = [max(float(np.max(np.abs(r))), 1e-300) for r in reference]
    mismatch = acceleration_mismatch(traj, ns)
    magnitudes = np.max(np.abs(np.array(states)), axis=2)  # (3, K): |p|, |v|, |a| per point
    unit = np.eye(6)[:, None, :]  # six data sets, each one of p0, v0, a0, p1, v1, a1 = 1
    ratios = np.zeros(derivatives)
    row = 0
    for k, h, tau in pieces:
        fine = np.linspace(0.0, h, 201)
        for d in range(derivatives):
            error = np.max(np.abs(interpolate(k, h, tau, d)
                                  - reference[d][row:row + len(tau)]))
            # The Hermite basis: what a unit change of each of the six values does.
            basis = np.max(np.abs(hermite(h, unit[:3], unit[3:], fine, d)), axis=0)
            # 434: an acceleration off by m at an end moves it by m times that basis.
            rounding = mismatch[k] * basis[2] + mismatch[k + 1] * basis[5]
            # Double precision: the six values carry relative errors of order eps.
            floor = FLOAT_SLACK * np.finfo(float).eps * float(
                basis @ np.concatenate([magnitudes[:, k], magnitudes[:, k + 1]]))
            ratios[d] = max(ratios[d], error / (RTOL * peaks[d] + rounding + floor))
        row += len(tau)
    return ratios


def acceleration_mismatch(traj, ns):
    """
    (K,) |acceleration of the segment before - after| at the published knot times.

    Zero where the jerk is continuous or the knot was not rounded; computed
    from the library's pieces, the left one at its own end.
    """
    x = traj.ppoly.x
    jerk = traj.ppoly.derivative(3)
    out = np.zeros(len(x))
    for k in range(1, len(x) - 1):
        left = np.array([np.polyval(jerk.c[:, k - 1, j], x[k] - x[k - 1])
                         for j in range(jerk.c.shape[2])])
        right = jerk.c[-1, k]
        out[k] = float(np.max(np.abs(right - left))) * abs(ns[k] * 1e-9 - x[k])
    return out


def knots_message(traj, joint_names):
    """Return the planner node's knots output for ``traj``, as it publishes it."""
    config = PlannerConfig(joint_names=tuple(joint_names), output='knots')
    return trajectory_to_msg(output_samples(config, traj), joint_names)


@st.composite
def requests(draw):
    """Random walks (N, n) with boundary values within half the limits."""
    n_points = draw(st.integers(2, 14))
    n_joints = draw(st.integers(1, 7))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    vmax = rng.uniform(0.5, 3.0, n_joints)
    amax = rng.uniform(2.0, 20.0, n_joints)
    boundary = [rng.uniform(-0.5, 0.5, n_joints) * limit
                for limit in (vmax, amax, vmax, amax)]
    # Durations on the nanosecond grid (a whole number of ms) for "fixed" timing.
    durations = rng.integers(200, 3000, n_points - 1) * 1e-3
    return points, vmax, amax, boundary, durations


def plan_drawn(method, timing, request):
    points, vmax, amax, (v0, a0, ve, ae), durations = request
    try:
        if timing == 'fixed':
            return plan(points, method, 'fixed', durations=durations, start_velocity=v0,
                        start_acceleration=a0, end_velocity=ve, end_acceleration=ae)
        return plan(points, method, timing, max_velocity=vmax, max_acceleration=amax,
                    start_velocity=v0, start_acceleration=a0, end_velocity=ve,
                    end_acceleration=ae)
    except ValueError:
        assume(False)


def names(n):
    return [f'j{i}' for i in range(n)]


@pytest.mark.parametrize('method', METHODS)
@pytest.mark.parametrize('timing', ['uniform', 'fixed'])
@EXAMPLES
@given(request=requests())
def test_the_controllers_interpolation_of_the_knots_is_the_planned_trajectory(
        method, timing, request):
    traj = plan_drawn(method, timing, request)
    msg = knots_message(traj, names(traj.n_joints))
    ns, _ = message_arrays(msg)
    # One point per breakpoint of the spline, at its time rounded to the nanosecond.
    assert len(msg.points) == traj.ppoly.x.size
    assert np.all(np.abs(ns - traj.ppoly.x * NANOS) <= 0.5 + 1e-3)
    if timing == 'fixed':
        assert np.all(np.abs(ns * 1e-9 - traj.ppoly.x) <= 1e-12)  # knots on the ns grid
    ratios = interpolation_errors(msg, traj)
    assert np.all(ratios <= 1.0), ratios


@pytest.mark.parametrize('method', METHODS)
@EXAMPLES
@given(request=requests())
def test_arm_sim_playback_of_the_knots_is_the_planned_trajectory(method, request):
    traj = plan_drawn(method, 'uniform', request)
    msg = knots_message(traj, names(traj.n_joints))
    played = sampled_trajectory_from_msg(msg, names(traj.n_joints))
    ns, _ = message_arrays(msg)

    def vectorised(k, h, tau, derivative):
        return played.states_at(ns[k] * 1e-9 + tau)[derivative]

    def one_by_one(k, h, tau, derivative):
        return np.array([played.state_at(ns[k] * 1e-9 + s)[derivative] for s in tau])
    # arm_sim_node's playback gives position, velocity and acceleration.
    assert np.all(interpolation_errors(msg, traj, vectorised, derivatives=3) <= 1.0)
    assert np.all(interpolation_errors(msg, traj, one_by_one, derivatives=3) <= 1.0)


@pytest.mark.parametrize('method', METHODS)
@pytest.mark.parametrize('timing', ['uniform', 'optimal'])
def test_the_paper_example_as_knots(method, timing):
    traj = plan(pe.joint_waypoints(), method, timing, **pe.plan_kwargs())
    msg = knots_message(traj, pe.JOINT_NAMES)
    # One point per knot: the 12 waypoints, and 555 optimal's inner knots when
    # it keeps them (with these moving ends only if they gain 5 %: not here).
    assert len(msg.points) == traj.breakpoints.size
    inner = (traj.optimizer or {}).get('inner_knots', 0)
    assert (len(msg.points) > 12) == bool(inner)
    assert not inner or (method, timing) == ('555', 'optimal')
    assert np.all(interpolation_errors(msg, traj) <= 1.0)
    # The end: within the nanosecond rounding of the last knot's time of the end state.
    end = msg.points[-1]
    slack = 1e-9 * float(np.max(np.abs(pe.BOUNDARY_ACCELERATION))) + 1e-12
    np.testing.assert_allclose(end.velocities, pe.BOUNDARY_VELOCITY, atol=slack)
    np.testing.assert_allclose(end.positions, pe.joint_waypoints()[-1],
                               atol=0.5e-9 * float(np.max(np.abs(pe.BOUNDARY_VELOCITY)))
                               + 1e-12)


def test_inner_knots_as_knots_rest_to_rest():
    """The paper's waypoints rest to rest with a vibration_frequency: inner knots, a point each."""
    kwargs = {k: v for k, v in pe.plan_kwargs().items()
              if not k.startswith(('start_', 'end_'))}
    traj = plan(pe.joint_waypoints(), '555', 'optimal', vibration_frequency=4.0, **kwargs)
    assert traj.optimizer['inner_knots'] > 0
    msg = knots_message(traj, pe.JOINT_NAMES)
    assert len(msg.points) == traj.breakpoints.size > 12
    assert np.all(interpolation_errors(msg, traj) <= 1.0)
    np.testing.assert_allclose(msg.points[-1].velocities, 0.0, atol=1e-12)


@pytest.mark.parametrize('profile', ['smoothed', 'time_optimal'])
@pytest.mark.parametrize('period', [0.5, 0.05, 0.01, 2e-4])
def test_sampled_output_is_played_as_the_planned_trajectory(profile, period):
    """Every knot is a sample: the controller's quintics between samples are the spline."""
    kwargs = {k: v for k, v in pe.plan_kwargs().items()
              if not k.startswith(('start_', 'end_'))}
    more = {'vibration_frequency': 4.0} if profile == 'smoothed' else {}  # (inner knots)
    traj = plan(pe.joint_waypoints(), '555', 'optimal', speed_profile=profile, **more,
                **kwargs)
    assert traj.breakpoints.size > 12      # inner knots, between the waypoints
    config = PlannerConfig(sample_period=period, joint_names=tuple(pe.JOINT_NAMES))
    msg = trajectory_to_msg(output_samples(config, traj), pe.JOINT_NAMES)
    ns, (positions, _, _) = message_arrays(msg)
    # The knots, the waypoints among them at their positions, are points.
    assert np.all(np.abs(ns[:, None] - traj.ppoly.x[None, :] * NANOS).min(axis=0) <= 0.5)
    at = np.abs(ns[:, None] - traj.waypoint_times[None, :] * NANOS).argmin(axis=0)
    # At its time rounded to the nanosecond a waypoint's point is the spline there:
    # the waypoint to |v| / 2 ns (the waypoint itself there was a step a controller's
    # quintic to a neighbour 0.2 ms away played at up to 159 times the jerk limit).
    speed = np.abs(traj.evaluate(traj.waypoint_times, 1))
    assert np.all(np.abs(positions[at] - pe.joint_waypoints()) <= speed * 0.5e-9 + 1e-12)
    # Between points, the controller's quintic is the spline (up to a knot time's
    # rounding to the nanosecond: 1e-7 of the peak velocity at most), its jerk too.
    _, states = message_arrays(msg)
    # (A fine period: every step-th interval, and those on either side of a waypoint.)
    step = max(1, (len(ns) - 1) // 2000)
    intervals = np.union1d(np.arange(0, len(ns) - 1, step),
                           np.clip(np.concatenate([at - 1, at]), 0, len(ns) - 2))
    for d, rtol in ((0, 1e-9), (1, 1e-6), (2, 1e-4), (3, 1e-2)):
        peak = float(np.max(np.abs(traj.evaluate(np.linspace(0, traj.duration, 999), d))))
        for k in intervals:
            h = (ns[k + 1] - ns[k]) * 1e-9
            tau = INSIDE * h
            played = hermite(h, [x[k] for x in states], [x[k + 1] for x in states], tau, d)
            np.testing.assert_allclose(played, traj.evaluate(ns[k] * 1e-9 + tau, d),
                                       rtol=0, atol=rtol * peak)


def test_the_check_fails_on_a_wrong_knot():
    """controller_errors is not blind: a velocity off by 1e-6 rad/s at one knot fails it."""
    traj = plan(pe.joint_waypoints(), '445', 'uniform', **pe.plan_kwargs())
    msg = knots_message(traj, pe.JOINT_NAMES)
    assert np.all(interpolation_errors(msg, traj) <= 1.0)
    msg.points[5].velocities[1] += 1e-6
    ratios = interpolation_errors(msg, traj)
    assert ratios[0] > 1.0 and ratios[1] > 1.0 and ratios[3] > 1.0, ratios


@given(seed=st.integers(0, 2**32 - 1), h=st.floats(1e-3, 10.0))
def test_the_tests_hermite_reproduces_any_quintic(seed, h):
    rng = np.random.default_rng(seed)
    c = rng.uniform(-1.0, 1.0, (6, 2)) / (h ** np.arange(6))[:, None]
    poly = [np.polynomial.Polynomial(c[:, j]) for j in range(2)]

    def state(tau):
        return [np.array([p.deriv(d)(tau) if d else p(tau) for p in poly]) for d in range(3)]
    tau = np.linspace(0.0, h, 17)
    for d in range(4):
        expected = np.column_stack([p.deriv(d)(tau) if d else p(tau) for p in poly])
        scale = max(1.0, float(np.max(np.abs(expected))))
        np.testing.assert_allclose(hermite(h, state(0.0), state(h), tau, d), expected,
                                   atol=1e-9 * scale * max(1.0, h ** -d))


def test_knots_of_the_library_trajectory():
    traj = plan(pe.joint_waypoints(), '434', 'uniform', **pe.plan_kwargs())
    exact = traj.knots()
    np.testing.assert_array_equal(exact.times, traj.ppoly.x)
    np.testing.assert_array_equal(exact.positions[-1], traj.waypoints[-1])
    np.testing.assert_array_equal(exact.velocities[-1], pe.BOUNDARY_VELOCITY)
    np.testing.assert_array_equal(exact.accelerations[-1], pe.BOUNDARY_ACCELERATION)
    for d, values in enumerate(exact[1:]):
        np.testing.assert_allclose(values, traj.evaluate(traj.ppoly.x, d), rtol=0, atol=1e-9)
    rounded = traj.knots(1e-3)
    assert np.all(np.abs(rounded.times - traj.ppoly.x) <= 0.5e-3 + 1e-12)
    np.testing.assert_allclose(np.round(rounded.times * 1e3), rounded.times * 1e3, atol=1e-6)
    for bad in (-1.0, float('nan'), float('inf')):
        with pytest.raises(ValueError, match='resolution'):
            traj.knots(bad)
    with pytest.raises(ValueError, match='closer than the time resolution'):
        traj.knots(1.0)


def test_output_is_validated_and_knots_count_against_max_trajectory_points():
    for bad in ('Knots', 'samples', ''):
        with pytest.raises(ValueError, match='output must be one of'):
            PlannerConfig.from_values({'output': bad})
    with pytest.raises(ValueError, match='output must be a string'):
        PlannerConfig.from_values({'output': 3})
    traj = plan(pe.joint_waypoints(), '555', 'uniform', **pe.plan_kwargs())
    few = PlannerConfig(output='knots', max_trajectory_points=11)
    with pytest.raises(ValueError, match='12 knots, more than max_trajectory_points'):
        output_samples(few, traj)
    assert output_samples(PlannerConfig(output='knots', max_trajectory_points=12),
                          traj).times.size == 12
    # The same limit with samples: 0.01 s over about 3.3 s is about 336 points.
    with pytest.raises(ValueError, match='sample_period'):
        output_samples(PlannerConfig(max_trajectory_points=12), traj)
    # Exactly as many samples as produced count, the waypoints' among them: 100
    # waypoints every 10 ms sampled every 10 ms are 100 points, not 199.
    points = np.cumsum(np.r_[[[0.0]], np.full((99, 1), 1e-3)], axis=0)
    dense = plan(points, '445', 'fixed', durations=np.full(99, 0.01))
    produced = dense.sample(0.01, 1e-9).times.size
    assert produced == 100
    for limit in (produced - 1, produced):
        config = PlannerConfig(max_trajectory_points=limit, joint_names=('j',))
        if limit < produced:
            with pytest.raises(ValueError, match=f'{produced} points or more at sample_period'):
                output_samples(config, dense)
        else:
            assert output_samples(config, dense).times.size == produced
    # With inner knots too (helper-56: 78 points published at a limit of 20).
    kwargs = {k: v for k, v in pe.plan_kwargs().items()
              if not k.startswith(('start_', 'end_'))}
    knotted = plan(pe.joint_waypoints(), '555', 'optimal', vibration_frequency=4.0, **kwargs)
    for period in (1.0, 0.5, 0.1):
        produced = knotted.sample(period, 1e-9).times.size
        assert produced > int(knotted.duration / period) + 1 + 12   # the inner knots
        with pytest.raises(ValueError, match='max_trajectory_points'):
            output_samples(PlannerConfig(sample_period=period,
                                         max_trajectory_points=produced - 1), knotted)
        enough = PlannerConfig(sample_period=period, max_trajectory_points=produced)
        assert output_samples(enough, knotted).times.size == produced


@pytest.mark.parametrize('vmax', [3e-9, 1e-12])
def test_a_plan_longer_than_a_time_from_start_holds_is_refused(vmax):
    """int32 seconds (68 years): a longer time_from_start wrapped round in transit."""
    traj = plan(np.array([[0.0], [10.0]]), '445', 'uniform', max_velocity=[vmax],
                max_acceleration=[vmax])
    assert traj.duration > 2**31
    with pytest.raises(ValueError, match='more than a time_from_start holds'):
        output_samples(PlannerConfig(output='knots'), traj)
    # Within int32 seconds the last point's time is the duration, as serialised.
    short = plan(np.array([[0.0], [10.0]]), '445', 'uniform', max_velocity=[1e-8],
                 max_acceleration=[1e-8])
    assert short.duration < 2**31
    last = serialize_message(trajectory_to_msg(output_samples(PlannerConfig(output='knots'),
                                                              short), ['j']))
    point = deserialize_message(last, JointTrajectory).points[-1].time_from_start
    assert point.sec + 1e-9 * point.nanosec == pytest.approx(short.duration, abs=1e-6)


def test_plot_trajectory_shows_the_controllers_motion_between_knots():
    traj = plan(pe.joint_waypoints(), '555', 'uniform', **pe.plan_kwargs())
    ns, (p, v, a) = message_arrays(knots_message(traj, pe.JOINT_NAMES))
    t, pos, vel, acc, interpolated = controller_view(ns * 1e-9, p, v, a, count=500)
    assert interpolated and len(t) >= 500 and np.all(np.diff(t) > 0.0)
    for d, values in enumerate((pos, vel, acc)):
        scale = float(np.max(np.abs(values)))
        np.testing.assert_allclose(values, traj.ppoly(t, d), rtol=0, atol=RTOL * scale)
    # Dense samples (output: sampled) are plotted as they are.
    many = np.linspace(0.0, 1.0, 600)
    assert not controller_view(many, np.zeros((600, 1)), np.zeros((600, 1)), None, 500)[4]
