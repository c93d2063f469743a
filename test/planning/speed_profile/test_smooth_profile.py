"""
The smooth third-order profile (issue 38), followed in time and checked by formulas of its own.

Each random case builds the natural cubic path as ``bench_arm_moves.
construction_path`` does, computes :class:`smooth_profile.SmoothProfile` and
then, using only its ``x(s)``: integrates ``t(s) = int ds / sqrt(x)`` by
the trapezoid rule on a fine grid of its own (``s = end -+ sigma**3`` near
the ends, where ``1 / sqrt(x) ~ s**(-2/3)``), interpolates ``s(t)`` by
cubic Hermite (``ds/dt = sqrt(x)``), samples ``q(s(t))`` every 1 ms and
takes velocity, acceleration and jerk by finite differences.
"""

import numpy as np
import pytest
from scipy.interpolate import CubicHermiteSpline
import scipy.sparse as sp
from splines445_ros.planning.constraints import GriddedPath, JointAcceleration, JointVelocity
from splines445_ros.planning.durations.timing import rest_to_rest_durations
from splines445_ros.planning.speed_profile import smooth_profile
from splines445_ros.planning.speed_profile.path_velocity import PathLimits, traversal_times
from splines445_ros.planning.speed_profile.smooth_profile import SmoothProfile
from splines445_ros.planning.spline.limits import JointLimits
from splines445_ros.planning.spline.natural_cubic import natural_cubic_spline

SEEDS = tuple(range(1, 9))
GRID_STEPS = 24
PERIOD = 1e-3
# Finite differences at 1 ms see a mean over 1-3 ms, and the module's rows
# are points (4 a grid step): the profile planned at the limits measured
# 1.0037 at worst (acceleration, 76 paths); 1.5 % leaves room for both.
TOLERANCE = 1.015
# The test's own quadrature: points on each half of the path (in sigma).
QUADRATURE_POINTS = 20000
# The smooth profile lasts at least the fastest v/a profile (the jerk only
# slows it), up to the v/a grid's own discretisation (it may be optimistic
# by a fraction of a percent), and at most this multiple of it (the jerk
# ramps from rest cost 0.1-0.2 s here).
LOWER = 0.995
UPPER = 1.25


def random_case(seed):
    """Return the natural cubic path, its grid and limits v, a, j (j = 10-20 a)."""
    rng = np.random.default_rng(seed)
    n_joints, n_points = int(rng.integers(2, 7)), int(rng.integers(3, 9))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    v, a = rng.uniform(1.0, 3.0, n_joints), rng.uniform(5.0, 15.0, n_joints)
    j = rng.uniform(10.0, 20.0) * a
    knots = np.concatenate([[0.0], np.cumsum(rest_to_rest_durations(
        points, JointLimits.from_user(n_joints, v, a, j)))])
    fractions = np.arange(GRID_STEPS) / GRID_STEPS
    grid = np.concatenate([(knots[:-1, None] + fractions * np.diff(knots)[:, None]).ravel(),
                           knots[-1:]])
    return natural_cubic_spline(knots, points), grid, v, a, j


def time_law(profile, start, end):
    """Return s(t) (a callable) and the duration, by the test's own quadrature of x(s)."""
    half = 0.5 * (end - start)
    sigma = np.linspace(0.0, half ** (1.0 / 3.0), QUADRATURE_POINTS)
    # s = start + sigma**3, ds = 3 sigma**2 dsigma; the integrand 3 sigma**2 / sqrt(x)
    # has a finite limit at sigma = 0 (x ~ alpha s**(4/3)): take it from the next point.
    s = start + sigma ** 3
    rate = np.empty_like(sigma)
    rate[1:] = 3.0 * sigma[1:] ** 2 / np.sqrt(profile.x(s[1:]))
    rate[0] = rate[1]
    first = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(sigma))])
    s_back = end - sigma ** 3
    rate[1:] = 3.0 * sigma[1:] ** 2 / np.sqrt(profile.x(s_back[1:]))
    rate[0] = rate[1]
    second = np.concatenate([[0.0], np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(sigma))])
    duration = first[-1] + second[-1]
    t = np.concatenate([first, duration - second[-2::-1]])
    s_all = np.concatenate([s, s_back[-2::-1]])
    speed = np.sqrt(np.maximum(profile.x(s_all), 0.0))
    law = CubicHermiteSpline(t, s_all, speed)
    return (lambda times: np.clip(law(np.clip(times, 0.0, duration)), start, end)), duration


@pytest.fixture(scope='module', params=SEEDS)
def solved(request):
    """Return a random case and its smooth profile."""
    path, grid, v, a, j = random_case(request.param)
    return path, grid, v, a, j, SmoothProfile(path, grid, v, a, j)


def test_followed_every_millisecond_within_the_limits(solved):
    """q(s(t)) sampled every 1 ms holds v, a, j by finite differences, within TOLERANCE."""
    path, grid, v, a, j, profile = solved
    s_of_t, duration = time_law(profile, grid[0], grid[-1])
    assert duration == pytest.approx(profile.duration, rel=1e-6)
    # At rest before 0 and after the duration: a few samples on each side.
    times = np.arange(-3, int(np.ceil(duration / PERIOD)) + 4) * PERIOD
    q = path(s_of_t(times))
    velocity = np.abs(np.diff(q, axis=0)) / PERIOD
    acceleration = np.abs(np.diff(q, 2, axis=0)) / PERIOD ** 2
    jerk = np.abs(np.diff(q, 3, axis=0)) / PERIOD ** 3
    assert np.max(velocity / v) <= TOLERANCE
    assert np.max(acceleration / a) <= TOLERANCE
    assert np.max(jerk / j) <= TOLERANCE
    # The limits are reached: the profile is not merely slow.
    assert max(np.max(velocity / v), np.max(acceleration / a)) >= 0.9


def test_time_at_inverts_the_time_law(solved):
    """time_at(s) matches the test's own quadrature, and s_of_t(time_at(s)) gives s back."""
    path, grid, v, a, j, profile = solved
    s_of_t, duration = time_law(profile, grid[0], grid[-1])
    s = np.concatenate([grid, np.random.default_rng(0).uniform(grid[0], grid[-1], 200)])
    t = profile.time_at(s)
    assert t[0] == pytest.approx(0.0, abs=1e-12)
    assert t[grid.size - 1] == pytest.approx(duration, rel=1e-6)
    assert np.all(np.diff(t[:grid.size]) > 0.0)
    # The test's law in reverse at the same times: s within a micro-step of the path.
    assert np.allclose(s_of_t(t), s, rtol=0.0, atol=1e-6 * (grid[-1] - grid[0]))
    assert np.allclose(profile.s_of_t(t), s, rtol=0.0, atol=1e-9 * (grid[-1] - grid[0]))


def test_s_of_t_is_finite_and_increasing_on_a_fine_clock(solved):
    """Every time of a 1 ms clock, the first and last steps included, has its s, in order."""
    path, grid, v, a, j, profile = solved
    t = np.concatenate([np.linspace(0.0, 0.02 * profile.duration, 400),
                        np.arange(0.0, profile.duration, 1e-3),
                        np.linspace(0.98 * profile.duration, profile.duration, 400)])
    s = profile.s_of_t(np.sort(t))
    assert np.all(np.isfinite(s))
    assert np.all(np.diff(s) >= -1e-12 * (grid[-1] - grid[0]))
    assert s[0] == grid[0] and s[-1] == pytest.approx(grid[-1], abs=1e-9 * (grid[-1] - grid[0]))


def test_at_rest_at_both_ends(solved):
    """At rest at both ends (x = 0, x > 0 inside), left and reached with no acceleration step."""
    path, grid, v, a, j, profile = solved
    scale = np.max(profile.x(np.linspace(grid[0], grid[-1], 1001)))
    assert np.all(np.abs(profile.x(grid[[0, -1]])) <= 1e-9 * scale)
    inside = np.linspace(grid[0], grid[-1], 2001)[1:-1]
    assert np.all(profile.x(inside) > 0.0)
    # Within 3 ms of rest, a jerk-limited motion has |acceleration| <= j 3 ms and
    # |velocity| <= j (3 ms)**2 / 2: far below a and v (an acceleration step breaks it).
    s_of_t, duration = time_law(profile, grid[0], grid[-1])
    offsets = np.arange(-3, 4) * PERIOD
    for times in (offsets, duration + offsets):
        q = path(s_of_t(times))
        acceleration = np.abs(np.diff(q, 2, axis=0)) / PERIOD ** 2
        velocity = np.abs(np.diff(q, axis=0)) / PERIOD
        assert np.all(acceleration <= TOLERANCE * j * 3.0 * PERIOD)
        assert np.all(velocity <= TOLERANCE * j * (3.0 * PERIOD) ** 2 / 2.0)


def test_duration_between_the_va_profile_and_a_multiple(solved):
    """Not faster than the fastest v/a profile on the same path, not much slower."""
    path, grid, v, a, j, profile = solved
    fine = np.linspace(grid[0], grid[-1], 8 * (grid.size - 1) + 1)
    x = PathLimits(GriddedPath.of_ppoly(path, fine), (JointVelocity(v), JointAcceleration(a))
                   ).profile(np.ones(fine.size))
    fastest = traversal_times(x, np.diff(fine))[-1]
    assert LOWER * fastest <= profile.duration <= UPPER * fastest


def test_bad_input_is_refused():
    """A path that does not move, non-positive limits, a wrong grid: ValueError."""
    path, grid, v, a, j = random_case(SEEDS[0])
    still = natural_cubic_spline(np.array([0.0, 1.0, 2.0]), np.ones((3, v.size)))
    with pytest.raises(ValueError, match='does not move'):
        SmoothProfile(still, np.linspace(0.0, 2.0, 49), v, a, j)
    with pytest.raises(ValueError, match='positive'):
        SmoothProfile(path, grid, v, -a, j)
    with pytest.raises(ValueError, match='positive'):
        SmoothProfile(path, grid, v, a, 0.0)
    with pytest.raises(ValueError, match='one value per joint'):
        SmoothProfile(path, grid, v[:-1], a, j)
    with pytest.raises(ValueError, match='span'):
        SmoothProfile(path, grid[:-5], v, a, j)
    with pytest.raises(ValueError, match='increasing'):
        SmoothProfile(path, grid[::-1], v, a, j)
    with pytest.raises(ValueError, match='PPoly'):
        SmoothProfile(lambda s: s, grid, v, a, j)
    with pytest.raises(ValueError, match='positive'):
        SmoothProfile(path, grid, v, a, np.nan)
    for frequency in (-4.0, np.inf, np.nan):
        with pytest.raises(ValueError, match='vibration_frequency must be finite'):
            SmoothProfile(path, grid, v, a, j, vibration_frequency=frequency)


@pytest.mark.parametrize('seed', SEEDS[:4])
def test_warm_highspy_and_cold_linprog_give_the_same_profile(seed, monkeypatch):
    """The warm-started highspy path and linprog's fallback (no highspy) agree."""
    pytest.importorskip('highspy')
    path, grid, v, a, j = random_case(seed)
    monkeypatch.setattr(smooth_profile, 'HIGHSPY', True)
    warm = SmoothProfile(path, grid, v, a, j)
    monkeypatch.setattr(smooth_profile, 'HIGHSPY', False)
    cold = SmoothProfile(path, grid, v, a, j)
    assert warm.duration == pytest.approx(cold.duration, rel=5e-4)
    s = np.linspace(grid[0], grid[-1], 501)
    assert np.allclose(warm.x(s), cold.x(s), rtol=0.0, atol=5e-3 * np.max(cold.x(s)))


def test_fallback_without_highspy_is_followed(monkeypatch):
    """With highspy missing (the module's flag off), linprog's profile holds the limits too."""
    monkeypatch.setattr(smooth_profile, 'HIGHSPY', False)
    path, grid, v, a, j = random_case(SEEDS[1])
    profile = SmoothProfile(path, grid, v, a, j)
    s_of_t, duration = time_law(profile, grid[0], grid[-1])
    times = np.arange(-3, int(np.ceil(duration / PERIOD)) + 4) * PERIOD
    q = path(s_of_t(times))
    for k, limit in ((1, v), (2, a), (3, j)):
        assert np.max(np.abs(np.diff(q, k, axis=0)) / PERIOD ** k / limit) <= TOLERANCE


def test_a_later_lp_that_highs_refuses_keeps_the_last_profile(monkeypatch):
    """A RuntimeError after the first LP (HiGHS refusing a model) keeps the first profile."""
    path, grid, v, a, j = random_case(SEEDS[2])
    first = {}
    solve = SmoothProfile._generate

    def refused_after_one(self, *args, **kwargs):
        if first:
            raise RuntimeError("HiGHS refused the profile's LP (passModel)")
        first['result'] = solve(self, *args, **kwargs)
        return first['result']

    monkeypatch.setattr(SmoothProfile, '_generate', refused_after_one)
    profile = SmoothProfile(path, grid, v, a, j)
    assert np.array_equal(np.concatenate([profile.coefficients,
                                          np.ravel(profile.end_coefficients)]),
                          first['result'].x)
    # That first profile is followed within the limits, like any other.
    s_of_t, duration = time_law(profile, grid[0], grid[-1])
    times = np.arange(-3, int(np.ceil(duration / PERIOD)) + 4) * PERIOD
    q = path(s_of_t(times))
    for k, limit in ((1, v), (2, a), (3, j)):
        assert np.max(np.abs(np.diff(q, k, axis=0)) / PERIOD ** k / limit) <= TOLERANCE
    # Refused at once: no profile, the RuntimeError that plan() answers with its default.

    def refused(self, *args, **kwargs):
        raise RuntimeError('refused')

    monkeypatch.setattr(SmoothProfile, '_generate', refused)
    with pytest.raises(RuntimeError, match='refused'):
        SmoothProfile(path, grid, v, a, j)


def test_a_mode_grid_with_steps_of_1e305_seconds_is_left_alone(monkeypatch):
    """
    Two steps where x is 0 at their ends (each ~1e305 s) give a mode too fast, not an error.

    Their parts a period were cast to int before the sum: it wrapped, and
    np.repeat raised a ValueError that no caller expects from a profile.
    """
    path, grid, v, a, j = random_case(SEEDS[0])
    steps = SmoothProfile._time_steps

    def stopped_twice(self, points, x_p):
        dt = steps(self, points, x_p)
        dt[[1, 2]] = 1e305
        return dt

    monkeypatch.setattr(SmoothProfile, '_time_steps', stopped_twice)
    profile = SmoothProfile(path, grid, v, a, j, vibration_frequency=4.0)
    assert np.isnan(profile.residual)
    plain = SmoothProfile(path, grid, v, a, j)
    assert np.array_equal(profile.coefficients, plain.coefficients)


@pytest.mark.parametrize('warm', [True, False])
@pytest.mark.parametrize('limit', ['ITERATIONS_PER_ROW', 'SOLVE_SECONDS'])
def test_a_solve_stops_at_its_limits(warm, limit, monkeypatch):
    """
    No simplex iteration or no time allowed: the first LP fails (RuntimeError), either solver.

    The limits (ITERATIONS_PER_ROW per row and column, SOLVE_SECONDS) are
    what bound a badly scaled LP that ran for minutes in one solve
    (helper-20's fuzz: a = 0.02 and segments of 300 s); with the defaults
    the same case solves.
    """
    if warm:
        pytest.importorskip('highspy')
    monkeypatch.setattr(smooth_profile, 'HIGHSPY', warm)
    path, grid, v, a, j = random_case(SEEDS[3])
    assert SmoothProfile(path, grid, v, a, j).lps > 0
    monkeypatch.setattr(smooth_profile, limit, 0)
    with pytest.raises(RuntimeError, match='first LP'):
        SmoothProfile(path, grid, v, a, j)


def test_each_highspy_solve_gets_its_own_time_limit(monkeypatch):
    """
    Each highspy solve gets a time limit of its own: HiGHS counts a model's run time over runs.

    helper-22's review: set once, the 5 s were the budget of all of a
    profile's LPs, and a 200 x 7 plan with a mode failed its later LPs.
    """
    highspy = pytest.importorskip('highspy')
    limits = []

    class Recording(highspy.Highs):
        def setOptionValue(self, name, value):
            if name == 'time_limit':
                limits.append((value, self.getRunTime()))
            return super().setOptionValue(name, value)

    monkeypatch.setattr(smooth_profile, 'HIGHSPY', True)
    monkeypatch.setattr(smooth_profile.highspy, 'Highs', Recording)
    path, grid, v, a, j = random_case(SEEDS[1])
    profile = SmoothProfile(path, grid, v, a, j)
    assert len(limits) == profile.lps >= 3
    assert limits[-1][1] > 0.0      # the later solves come after run time has been spent
    for value, spent in limits:
        assert value >= spent + smooth_profile.SOLVE_SECONDS * (1.0 - 1e-12)


@pytest.mark.parametrize('seed', SEEDS[:4])
def test_speed_rows_set_in_place_are_the_tangent_rows_stacked(seed):
    """
    ``_SpeedRows.stacked`` against the tangent rows written out: ``base + diag(c / 2 r) x``.

    ``r = sqrt(min(x_q, (bound / c)**2))`` where the bound is positive, else
    ``sqrt(x_q)``, and the bound ``limit - c r / 2``.  Random sparse rows
    whose patterns differ from ``x``'s, zero ``c`` at some rows, non-positive
    bounds, three LPs in a row (the data is rewritten in place each time).
    """
    rng = np.random.default_rng(seed)
    n_points, n_columns = 30, 12
    x = sp.random(n_points, n_columns, density=0.3, random_state=rng, format='csr')
    others = sp.random(7, n_columns, density=0.4, random_state=rng, format='csr')
    blocks = []
    for _ in range(3):
        at = np.sort(rng.choice(n_points, size=int(rng.integers(1, n_points)), replace=False))
        base = sp.random(at.size, n_columns, density=0.3, random_state=rng, format='csr')
        c = rng.normal(size=at.size) * (rng.uniform(size=at.size) < 0.8)
        limit = rng.normal(size=at.size)
        blocks.append((base, at, c, limit))
    rows = smooth_profile._SpeedRows(blocks, x, others)
    for _ in range(3):
        x_q = rng.uniform(0.01, 4.0, n_points)
        other_data = rng.normal(size=others.nnz)
        others.data[:] = other_data
        bound = rng.normal(size=others.shape[0])
        matrix, stacked = rows.stacked(x_q, others, bound)
        expected_rows, expected_bound = [others], [bound]
        for base, at, c, limit in blocks:
            cap = np.array([(lim / ci) ** 2 if lim > 0.0 and ci != 0.0 else np.inf
                            for lim, ci in zip(limit, c)])
            r = np.sqrt(np.minimum(x_q[at], cap))
            expected_rows.append(base + sp.diags(0.5 * c / r) @ x[at])
            expected_bound.append(limit - 0.5 * c * r)
        expected = sp.vstack(expected_rows).toarray()
        np.testing.assert_array_equal(matrix.toarray(), expected)
        np.testing.assert_array_equal(stacked, np.concatenate(expected_bound))
        z = rng.normal(size=n_columns)
        np.testing.assert_allclose(matrix @ z, expected @ z, rtol=1e-12, atol=1e-12)
