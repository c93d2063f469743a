"""
Straight tool paths: Taylor's bounded-deviation refinement (splines445_ros.cartesian.tool_paths).

The deviation is checked independently of the implementation: forward
kinematics written here, a grid 400 points per segment offset from the
implementation's, and the distance to the requested edge each time belongs
to (from the times the tool waypoints are passed).
"""

from example_counts import examples
from hypothesis import assume, event, given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.cartesian.path_deviation import path_deviation
from splines445_ros.cartesian.refinement_time import RefinementTimeout
from splines445_ros.cartesian.tool_paths import plan_tool_path
from splines445_ros.planning import METHODS
from splines445_ros.robot import paper_example as pe
from splines445_ros.robot.kinematics import PlanarArm

D1, D2 = 1.1, 0.9
ARM = PlanarArm(D1, D2)
LIMITS = {'max_velocity': pe.MAX_VELOCITY, 'max_acceleration': pe.MAX_ACCELERATION}
CHECK_POINTS = 400  # per trajectory segment


def forward(q):
    """Tool (x, y, yaw) of the paper's arm, written independently of PlanarArm."""
    q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2]
    return np.column_stack([D1 * np.cos(q1) + D2 * np.cos(q1 + q2),
                            D1 * np.sin(q1) + D2 * np.sin(q1 + q2), q1 + q2 + q3])


def measured_deviation(result, poses):
    """Largest (position, orientation) deviation on a fine grid offset from the library's."""
    traj = result.trajectory
    u = (np.arange(CHECK_POINTS) + 0.5) / CHECK_POINTS
    t = (traj.waypoint_times[:-1, None] + np.diff(traj.waypoint_times)[:, None] * u).ravel()
    tool = forward(traj.evaluate(t))
    passed = traj.waypoint_times[result.waypoint_knots]  # when each tool waypoint is reached
    edge = np.clip(np.searchsorted(passed, t, side='right') - 1, 0, len(poses) - 2)
    yaw = np.unwrap(poses[:, 2])
    a, b = poses[edge, :2], poses[edge + 1, :2]
    ab = b - a
    length2 = np.sum(ab**2, axis=1)
    s = np.clip(np.sum((tool[:, :2] - a) * ab, axis=1) / np.maximum(length2, 1e-300), 0, 1)
    s = np.where(length2 > 1e-18, s,
                 np.clip((t - passed[edge]) / (passed[edge + 1] - passed[edge]), 0, 1))
    position = np.linalg.norm(tool[:, :2] - a - s[:, None] * ab, axis=1)
    target = yaw[edge] + s * (yaw[edge + 1] - yaw[edge])
    orientation = np.abs((tool[:, 2] - target + np.pi) % (2 * np.pi) - np.pi)
    return position.max(), orientation.max()


def check_result(result, poses, tol_position, tol_orientation, rest_to_rest=True):
    traj = result.trajectory
    position, orientation = measured_deviation(result, poses)
    assert position <= tol_position * (1 + 1e-6) + 1e-12, (position, tol_position)
    assert orientation <= tol_orientation * (1 + 1e-6) + 1e-12, (orientation, tol_orientation)
    # The library's own maxima are at least what the fine grid sees, up to
    # the golden-section search's own accuracy: GOLDEN_STEPS = 10 leave a
    # bracket of 0.618**10 = 8e-3 of two grid cells, where a smooth bump is
    # below its peak by about (8e-3)**2 / 8 = 8e-6 of its height.
    assert result.max_deviation >= position * (1 - 1e-5) - 1e-12
    # Passes through every tool waypoint (yaw modulo 2 pi).
    at_knots = forward(traj.evaluate(traj.waypoint_times[result.waypoint_knots]))
    np.testing.assert_allclose(at_knots[:, :2], poses[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.cos(at_knots[:, 2] - poses[:, 2]), 1.0, atol=1e-12)
    # Limits hold exactly (peaks from the polynomials) and on a dense sampling.
    assert traj.within_limits()
    t = np.linspace(0.0, traj.duration, 20001)
    assert np.all(np.abs(traj.evaluate(t, 1)) <= pe.MAX_VELOCITY * (1 + 1e-9))
    assert np.all(np.abs(traj.evaluate(t, 2)) <= pe.MAX_ACCELERATION * (1 + 1e-9))
    if rest_to_rest:
        for d in (1, 2):
            np.testing.assert_allclose(traj.evaluate([0.0, traj.duration], d), 0.0, atol=1e-9)
    assert result.inserted == len(result.joints) - len(np.unique(result.waypoint_knots))


@st.composite
def reachable_polygons(draw):
    """Tool polygons (N, 3) whose edges stay well inside the arm's annulus 0.2 < r < 2."""
    n = draw(st.integers(2, 6))
    angle = draw(st.floats(-np.pi, np.pi))
    rows = []
    for _ in range(n):
        radius = draw(st.floats(0.6, 1.7))
        yaw = draw(st.floats(-1.5, 1.5))
        rows.append((radius * np.cos(angle), radius * np.sin(angle), yaw))
        angle += draw(st.floats(-1.2, 1.2))
    poses = np.array(rows)
    for a, b in zip(poses[:-1, :2], poses[1:, :2]):
        ab = b - a
        assume(np.linalg.norm(ab) > 0.05)
        s = np.clip(-a @ ab / (ab @ ab), 0.0, 1.0)
        assume(np.linalg.norm(a + s * ab) > 0.45)  # the line stays away from the hole
    return poses


@given(poses=reachable_polygons(), method=st.sampled_from(METHODS),
       tol=st.sampled_from([1e-3, 3e-3, 1e-2]), tol_yaw=st.sampled_from([3e-3, 3e-2]))
def test_uniform_timing_stays_within_the_tolerance_everywhere(poses, method, tol, tol_yaw):
    try:
        result = plan_tool_path(poses, ARM, tol, tol_yaw, method=method, **LIMITS)
    except ValueError as exc:
        # 445's disturbances do not decay: it may need more than the cap (never 434 or 555).
        assert method == '445' and 'max_inserted' in str(exc), str(exc)
        assert 'between tool waypoints' in str(exc)
        event('445 reached the cap')
        return
    event(f'refined: {result.inserted > 0}')
    check_result(result, poses, tol, tol_yaw)


@settings(max_examples=examples(6))
@given(poses=reachable_polygons(), method=st.sampled_from(METHODS))
def test_optimal_timing_stays_within_the_tolerance_everywhere(poses, method):
    assume(len(poses) <= 4)
    try:
        result = plan_tool_path(poses, ARM, 5e-3, 5e-2, max_inserted=40, method=method,
                                timing='optimal', **LIMITS)
    except ValueError as exc:
        assert 'max_inserted' in str(exc), str(exc)
        event(f'{method} reached the cap')
        return
    event(f'refined: {result.inserted > 0}')
    check_result(result, poses, 5e-3, 5e-2)


def test_optimal_refinement_restarts_from_the_split_optimum(monkeypatch):
    from splines445_ros.cartesian import tool_paths
    calls = []

    planned = tool_paths.plan_with_options

    def recording(waypoints, options, durations=None):
        traj = planned(waypoints, options, durations)
        calls.append((durations, traj.durations))
        return traj
    monkeypatch.setattr(tool_paths, 'plan_with_options', recording)
    poses = np.column_stack([pe.triangle_points()[:4], np.zeros(4)])
    result = plan_tool_path(poses, ARM, 5e-3, max_inserted=200, method='555',
                            timing='optimal', inner_knots=0, **LIMITS)
    assert result.inserted > 0 and len(calls) > 1
    assert calls[0][0] is None  # the first plan starts from the uniform solution
    for (_, before), (start, _) in zip(calls[:-1], calls[1:]):
        # Every later one from the previous optimum, each split segment's
        # duration shared between its halves.
        assert start.size > before.size
        assert start.sum() == pytest.approx(before.sum(), rel=1e-12)


@pytest.mark.parametrize('tolerance', [5e-3, None])
def test_555_optimal_tool_paths_are_never_longer_than_with_knots_only(tolerance):
    """Inner knots are tried on the refined path, kept only when shorter and within tolerance."""
    poses = np.column_stack([pe.triangle_points()[:4], np.zeros(4)])
    kwargs = dict(method='555', timing='optimal', max_inserted=200, **LIMITS)
    default = plan_tool_path(poses, ARM, tolerance, **kwargs)
    knots_only = plan_tool_path(poses, ARM, tolerance, inner_knots=0, **kwargs)
    assert default.trajectory.duration <= knots_only.trajectory.duration
    assert knots_only.trajectory.breakpoints.size == len(knots_only.joints)
    if tolerance is None:
        # Nothing to refine: the unrefined request gets its inner knots when
        # they pay.  On this 1 s move they do only with short smoothing
        # windows (a very stiff arm, 2 x 10 ms); the default 0.25 s window
        # costs more than they gain, and then knots only is kept.
        stiff = plan_tool_path(poses, ARM, tolerance, vibration_frequency=100.0, **kwargs)
        assert stiff.trajectory.breakpoints.size > len(stiff.joints)
        assert stiff.trajectory.duration < knots_only.trajectory.duration
        # smoothing is taken and checked as plan() checks it (the tool lines
        # are never averaged).
        bare = plan_tool_path(poses, ARM, tolerance, smoothing='none', **kwargs)
        assert bare.trajectory.optimizer['smoothing_windows'] == []
        assert bare.trajectory.duration < knots_only.trajectory.duration
        with pytest.raises(ValueError, match='sets the windows itself'):
            plan_tool_path(poses, ARM, tolerance, smoothing='none', vibration_frequency=4.0,
                           **kwargs)
    else:
        check_result(default, poses, tolerance, np.inf)


@pytest.mark.parametrize('method', ['434', '555'])
def test_paper_triangle_within_one_millimetre(method):
    xy = pe.triangle_points()
    poses = np.column_stack([xy, np.zeros(len(xy))])
    result = plan_tool_path(poses, ARM, 1e-3, method=method, **LIMITS)
    check_result(result, poses, 1e-3, 1e-9)
    assert result.initial_deviation.max_position > 0.03  # the paper's observation
    assert 0 < result.inserted < 100
    # A 1000-point grid per segment finds the same maxima as the default one.
    fine = path_deviation(result, ARM, grid=1000)
    assert fine.max_position == pytest.approx(result.max_deviation, abs=1e-9)


def test_fixed_timing_keeps_the_times_of_the_tool_waypoints():
    xy = pe.triangle_points(6)
    poses = np.column_stack([xy, np.linspace(0.0, 0.5, len(xy))])
    durations = np.array([1.0, 1.5, 1.0, 2.0, 1.0])
    result = plan_tool_path(poses, ARM, 2e-3, 1e-2, method='434', timing='fixed',
                            durations=durations)
    assert result.inserted > 0
    passed = result.trajectory.waypoint_times[result.waypoint_knots]
    np.testing.assert_allclose(passed, np.concatenate([[0.0], np.cumsum(durations)]))
    position, orientation = measured_deviation(result, poses)
    assert position <= 2e-3 * (1 + 1e-6) and orientation <= 1e-2 * (1 + 1e-6)


def test_duplicate_tool_waypoints_are_merged_and_still_passed():
    xy = pe.triangle_points(5)
    poses = np.column_stack([xy, np.zeros(len(xy))])
    doubled = np.insert(poses, 2, poses[2], axis=0)
    result = plan_tool_path(doubled, ARM, 2e-3, method='555', **LIMITS)
    assert result.waypoint_knots[2] == result.waypoint_knots[3]
    check_result(result, doubled, 2e-3, 1e-9)


def test_unreachable_poses_are_named():
    with pytest.raises(ValueError, match=r'tool waypoint 2 at .* is unreachable'):
        plan_tool_path([[1, 0, 0], [0, 1, 0], [0, 0.1, 0], [-1, 0, 0]], ARM, 1e-3, **LIMITS)
    # Both ends reachable, but the straight line between them crosses the hole at the base.
    with pytest.raises(ValueError, match='line from tool waypoint 0 to 1 leaves the reach'):
        plan_tool_path([[1, 0, 0], [-1, 0, 0]], ARM, 1e-3, method='434', **LIMITS)


def test_the_cap_stops_with_the_segment_and_the_deviation_reached():
    xy = pe.triangle_points()
    poses = np.column_stack([xy, np.zeros(len(xy))])
    with pytest.raises(ValueError, match=r'after inserting 5 waypoints \(max_inserted\): the '
                                         r'tool still deviates 0\.0\d+ m from the straight '
                                         r'line \(tolerance 0\.001 m\) between tool '
                                         r'waypoints \d+ and \d+'):
        plan_tool_path(poses, ARM, 1e-3, max_inserted=5, method='434', **LIMITS)


@pytest.mark.parametrize('method, timing', [('434', 'uniform'), ('555', 'uniform'),
                                            ('555', 'optimal')])
def test_the_refinement_stops_at_max_refinement_time_saying_how_far_it_got(method, timing):
    # 555 optimal refines its tool lines, the others insert waypoints: each
    # stops at its next round once the time is up, whatever max_inserted allows.
    xy = pe.triangle_points()
    poses = np.column_stack([xy, np.zeros(len(xy))])
    kwargs = dict(method=method, timing=timing, max_inserted=10_000, **LIMITS)
    with pytest.raises(RefinementTimeout, match=r'stopped after \d.* s, past max_refinement_time '
                                                r'\(1e-09 s\): \d+ (waypoints|knots) inserted'
                                                r'.* still'):
        plan_tool_path(poses, ARM, 1e-4, max_refinement_time=1e-9, **kwargs)
    # Without the limit it refines; a path within its tolerances at once
    # needs no round, so the limit never stops it.
    for tolerance, seconds in ((1e-4, 0), (1.0, 1e-9)):
        result = plan_tool_path(poses, ARM, tolerance, max_refinement_time=seconds, **kwargs)
        assert (result.inserted > 0) == (tolerance < 1.0)
        assert measured_deviation(result, poses)[0] <= tolerance * (1 + 1e-6)


def test_past_max_refinement_time_the_steps_that_only_shorten_are_skipped():
    # Within its tolerance at once: no round to stop, but time_optimal's
    # re-timing only shortens the lines' own plan, so it is skipped and said so.
    xy = pe.triangle_points()
    poses = np.column_stack([xy, np.zeros(len(xy))])
    kwargs = dict(method='555', timing='optimal', **LIMITS)
    own = plan_tool_path(poses, ARM, 1e-3, **kwargs).trajectory
    late = plan_tool_path(poses, ARM, 1e-3, speed_profile='time_optimal',
                          max_refinement_time=1e-9, **kwargs).trajectory
    timed = plan_tool_path(poses, ARM, 1e-3, speed_profile='time_optimal', **kwargs).trajectory
    assert late.optimizer['refinement_time'].startswith('max_refinement_time reached')
    assert 'refinement_time' not in timed.optimizer
    assert late.duration == own.duration and timed.duration < own.duration


@pytest.mark.parametrize('method, timing', [('434', 'uniform'), ('445', 'uniform'),
                                            ('555', 'uniform'), ('445', 'optimal'),
                                            ('555', 'optimal')])
@pytest.mark.parametrize('tolerance', [None, 1e-3])
def test_a_waypoint_next_to_the_one_before_is_passed_there_not_timed_alone(
        method, timing, tolerance):
    # 1.5 nm and 50 um after the second pose: within a tenth of the tolerance
    # (within 1 mm with none), so passed at the second's time; their segments
    # of nanometres would otherwise set the whole uniform plan's time (555
    # uniform without a tolerance took 5.9 s against 0.81 s).
    poses = np.array([[1.2, 0.0, 0.0], [1.2, 0.5, 0.0], [1.2, 0.5 + 1.5e-9, 0.0],
                      [1.2, 0.5 + 5e-5, 0.0], [0.8, 0.8, 0.0]])
    kwargs = dict(method=method, timing=timing, **LIMITS)
    result = plan_tool_path(poses, ARM, tolerance, **kwargs)
    alone = plan_tool_path(poses[[0, 1, 4]], ARM, tolerance, **kwargs)
    assert result.trajectory.duration == alone.trajectory.duration
    passed = result.trajectory.waypoint_times[result.waypoint_knots]
    assert passed[1] == passed[2] == passed[3]
    tool = forward(result.trajectory.evaluate(passed))
    np.testing.assert_allclose(tool[:, :2], poses[:, :2], atol=1e-4 * (1 + 1e-9))
    # A pose 2 mm on is its own waypoint, whatever is checked.
    apart = poses.copy()
    apart[3, 1] = 0.502
    knots = plan_tool_path(apart, ARM, tolerance, **kwargs).waypoint_knots
    assert knots[2] == knots[1] and knots[3] > knots[1]


@pytest.mark.parametrize('seconds', [-1.0, float('nan')])
def test_a_negative_refinement_time_is_refused(seconds):
    with pytest.raises(ValueError, match='max_refinement_time = .*non-negative'):
        plan_tool_path([[1, 0, 0], [1, 1, 0]], ARM, max_refinement_time=seconds, **LIMITS)


def test_orientation_alone_can_drive_the_refinement():
    poses = np.array([[1.2, 0.0, 0.0], [1.2, 0.6, 2.5], [0.8, 0.9, -0.5]])
    unrefined = plan_tool_path(poses, ARM, method='434', **LIMITS)
    assert unrefined.inserted == 0 and unrefined.max_orientation_deviation > 0.01
    result = plan_tool_path(poses, ARM, None, 0.01, method='434', **LIMITS)
    assert result.inserted > 0
    assert measured_deviation(result, poses)[1] <= 0.01 * (1 + 1e-6)


@pytest.mark.parametrize('poses, kwargs, message', [
    ([[1, 0, 0]], {}, 'at least 2 tool waypoints'),
    ([[1, 0, 0], [1, np.nan, 0]], {}, 'tool waypoint 1 has y = nan'),
    ([[1, 0], [1, 1]], {}, r'shape \(N, 3\)'),
    ([[1, 0, 0], [1, 1, 0]], {'max_deviation': -1.0}, 'max_deviation = -1.0'),
    ([[1, 0, 0], [1, 1, 0]], {'timing': 'fixed'}, 'needs durations'),
    # Issue 18: these raised OverflowError and TypeError.
    ([[1, 0, 0], [1, 1, 0]], {'max_inserted': float('inf')}, 'max_inserted = inf'),
    ([[1, 0, 0], [1, 1, 0]], {'max_inserted': None}, 'max_inserted = None'),
    ([[1, 0, 0], [1, 1, 0]], {'max_deviation': [1e-3]}, r'max_deviation must be a number'),
])
def test_bad_input_is_a_clear_error(poses, kwargs, message):
    with pytest.raises(ValueError, match=message):
        plan_tool_path(poses, ARM, **{**LIMITS, **kwargs})


def test_demo_table_and_figure(tmp_path):
    from splines445_ros.tools.tool_path_demo import markdown_table, plot_refined_paths, \
        refine_triangle
    runs = refine_triangle(methods=('434',), timings=('uniform',))
    table = markdown_table(runs)
    row = table.splitlines()[2].split('|')
    assert row[1].strip() == '434' and float(row[4]) <= 1.0 and float(row[5]) <= 1.0
    path = str(tmp_path / 'refined.png')
    plot_refined_paths(runs, path)
    with open(path, 'rb') as handle:
        assert handle.read(8) == b'\x89PNG\r\n\x1a\n'


@pytest.mark.parametrize('method, timing', [('445', 'uniform'), ('555', 'optimal')])
@pytest.mark.parametrize('side', ['max', 'min'])
def test_a_tool_waypoint_beyond_the_position_limits_is_named_at_once(side, method, timing):
    """
    A tool waypoint whose joints lie beyond a limit: refused naming it, before any refinement.

    The refinement checks only the plan it ends with; inserting waypoints
    around one that the plan must pass outside the limits cannot help (found
    in review: 200 insertions, then a deviation error); the tool lines (555
    optimal) named the joint and a time only.  The limit goes
    just inside the waypoint that sets its joint's range (by the joints the
    inverse kinematics gives).
    """
    poses = np.array([[1.2, 0.6, 0.3], [0.6, 1.3, 1.0], [-0.4, 1.2, 1.8]])
    joints = ARM.inverse(poses)
    low, high = joints.min(axis=0) - 1.0, joints.max(axis=0) + 1.0
    # The joint whose extreme waypoint stands out most from the others.
    ordered = np.sort(joints, axis=0)
    gaps = ordered[-1] - ordered[-2] if side == 'max' else ordered[1] - ordered[0]
    j = int(np.argmax(gaps))
    k = int(np.argmax(joints[:, j]) if side == 'max' else np.argmin(joints[:, j]))
    assert gaps[j] > 0.1
    if side == 'max':
        high[j] = joints[k, j] - 0.05
    else:
        low[j] = joints[k, j] + 0.05
    words = 'above max' if side == 'max' else 'below min'
    with pytest.raises(ValueError, match=rf'tool waypoint {k} needs joint {j} at .* {words}'):
        plan_tool_path(poses, ARM, 1e-4, method=method, timing=timing,
                       max_velocity=[1.0] * 3, max_acceleration=[3.0] * 3,
                       min_position=low, max_position=high)


def test_max_inserted_as_a_whole_float_is_the_integer_and_bad_values_are_refused():
    """2.0 passed the check, then range() refused it with a TypeError (helper-69)."""
    poses = np.column_stack([pe.triangle_points()[:3], np.zeros(3)])   # (x, y, yaw)
    kwargs = {'max_velocity': [2.0] * 3, 'max_acceleration': [10.0] * 3}
    as_float = plan_tool_path(poses, ARM, 1e-3, max_inserted=2000.0, **kwargs)
    as_int = plan_tool_path(poses, ARM, 1e-3, max_inserted=2000, **kwargs)
    assert as_float.trajectory.duration == as_int.trajectory.duration
    for bad in (2.5, -1, True, float('nan')):
        with pytest.raises(ValueError, match='max_inserted'):
            plan_tool_path(poses, ARM, 1e-3, max_inserted=bad, **kwargs)


def test_tool_waypoints_that_all_coincide_are_refused():
    """As joint waypoints are: round-off made a plan of microseconds (helper-66)."""
    pose = [1.0, 0.5, 0.3]     # (x, y, yaw)
    with pytest.raises(ValueError, match='all 3 tool waypoints coincide'):
        plan_tool_path([pose] * 3, ARM, 1e-3, max_velocity=[2.0] * 3,
                       max_acceleration=[10.0] * 3)
