"""
Free inner knots (issue 17): 555 optimal timing against TOPP-RA, one run.

20 random rest-to-rest requests (fresh every run, the seed printed first:
``bench_seeds.py``; 5 to 50 waypoints, 3 to 7 joints, v in [1, 3] rad/s and
a in [5, 15] rad/s^2 per joint).  For each: TOPP-RA's duration and planning
time (toppra, v/a limits only, its chord spline through the waypoints,
``own_path.chord_spline``, default grid), the lower bound LB of the issue,
and 555 optimal with knots at the waypoints only (``inner_knots=0``,
before the issue) and with inner knots (the default), for no jerk limit,
j = 20 a and j = 5 a, plus the default with ``vibration_frequency=4`` and
``speed_profile='time_optimal'`` (``planning/path_following/time_optimal.py``)
with no jerk limit and at j = 20 a, and time_optimal with
``vibration_frequency=4`` (the mode's ringing after the stop cancelled by
its profile, ``planning/speed_profile/residual_vibration.py``).

Every plan's figures (issue 38, ``bench_figures.py``), each over TOPP-RA's
on the same case: the duration; the duration over TOPP-RA's along our own
path (``own_path.py``: TOPP-RA with the same v/a limits on the geometric
path of our plan, re-parameterised by arc length: what the speed profile
alone gives away) and that TOPP-RA over TOPP-RA (what our path gains); the
shaking of a lightly damped mode at 4 and 8 Hz on every joint
(``shaking.py``: peak while moving and residual after the end); the
planning time (each plan and TOPP-RA on its request in turn, best of
:data:`REPEATS` each: ``wall_time.timed_against``; a case's TOPP-RA
planning time printed is the best of all its calls).  The summary gives
medians and worst cases over the cases and whether every limit held (exact
peaks).  Then the paper's example (its boundary values); the same figures
at 100 x 7 and 1000 x 7, each timed in turn with TOPP-RA, best of
:data:`REPEATS`; the planning time of small requests (3 x 3 to 30 x 7)
against TOPP-RA's, each the best of several calls made in turn, with the
durations over TOPP-RA's; last, the figures of long moves (few segments
of up to :data:`LONG_STEP` rad: step 8 of ``inner_knots.py``).

Usage: ``python benchmarks/bench_inner_knots.py [inner_knots]`` (default:
plan()'s); ``SPLINES445_BENCH_SEED=<seed>`` repeats a run,
``SPLINES445_BENCH_CASES=<count>`` draws another number of requests.
"""

import logging
import os
import sys
from types import SimpleNamespace

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_figures  # noqa: E402, I100
from bench_planning import toppra_trajectory  # noqa: E402
import bench_seeds  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
import own_path  # noqa: E402, I100
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.robot import paper_example as pe  # noqa: E402
from wall_time import best_of, timed_against  # noqa: E402

N_CASES = 20
JERK_RATIOS = (None, 20.0, 5.0)
# One more plan at this jerk ratio, with this vibration_frequency [Hz].
SHAKING_JERK = 20.0
VIBRATION_FREQUENCY = 4.0
# speed_profile='time_optimal' plans at these jerk ratios (None: no jerk limit).
OPTIMAL_JERK_RATIOS = (None, 20.0)
# Random streams of the run's seed (bench_seeds.generator).
CASES_STREAM, LARGE_STREAM, SMALL_STREAM, LONG_STREAM = 0, 1, 2, 3
# Rounds of a plan and TOPP-RA in turn, best of each (wall_time.timed_against).
REPEATS = 3


def shaking_row(traj, elapsed, reference, d_top, t_top, amax):
    """Duration, :func:`shaking_ratios` and planning time of ``traj``, each / TOPP-RA's."""
    return ([traj.duration / d_top] + shaking_ratios(traj, reference, amax)
            + [elapsed / t_top])


def rest_to_rest_time(distance, vmax, amax):
    """Shortest rest-to-rest time over ``distance`` with |v| <= vmax, |a| <= amax."""
    if distance >= vmax * vmax / amax:
        return distance / vmax + vmax / amax
    return 2.0 * np.sqrt(distance / amax)


def lower_bound(waypoints, vmax, amax):
    """
    LB of the issue: no trajectory through the waypoints is shorter.

    The larger of: every segment at the full speed of its slowest joint
    (sum over segments of max_j |dq_j| / v_j); and, per joint, the sum of
    rest-to-rest v/a times between its direction reversals (a joint is at
    rest where it turns).
    """
    dq = np.diff(waypoints, axis=0)
    cruise = float(np.sum(np.max(np.abs(dq) / vmax, axis=1)))
    best = cruise
    for j in range(waypoints.shape[1]):
        moves = dq[:, j][dq[:, j] != 0.0]
        if moves.size == 0:
            continue
        turns = np.flatnonzero(np.diff(np.sign(moves)) != 0) + 1
        stretches = [abs(s.sum()) for s in np.split(moves, turns)]
        best = max(best, sum(rest_to_rest_time(d, vmax[j], amax[j]) for d in stretches))
    return best


def random_case(rng):
    """One request: waypoints (N, n), v and a limits (n,)."""
    n_joints = int(rng.integers(3, 8))
    n_points = int(rng.integers(5, 51))
    waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    return waypoints, rng.uniform(1.0, 3.0, n_joints), rng.uniform(5.0, 15.0, n_joints)


def label(ratio):
    """Column name of a jerk setting."""
    return 'no jerk limit' if ratio is None else f'j = {ratio:g} a'


def summary_head(title, last):
    """Print a blank line, ``title`` and the head of a table of summaries (a plan a row)."""
    print()
    print(title)
    print('| plan | ' + bench_figures.header() + f' | {last} |')
    print(bench_figures.rule(2 + len(bench_figures.NAMES)))


def plan_figures(traj, elapsed, t_top, case):
    """
    Return the :data:`bench_figures.NAMES` figures of one of our plans on ``case``.

    ``elapsed`` and ``t_top``: its planning time and TOPP-RA's, timed in
    the same rounds (:func:`against_toppra`).
    """
    own = own_path.toppra_along(traj, own_path.velocity_acceleration(case.vmax, case.amax))
    return bench_figures.figures(traj.duration, own.duration, case.d_top,
                                 shaking_ratios(traj, case.reference, case.amax), elapsed,
                                 t_top)


def toppra_case(waypoints, vmax, amax):
    """Return TOPP-RA's figures on a request (``t_tops``: its planning times, filled later)."""
    top = toppra_trajectory(waypoints, vmax, amax)
    return SimpleNamespace(waypoints=waypoints, vmax=vmax, amax=amax, d_top=top.duration,
                           t_tops=[],
                           reference=shaking_figures(of_toppra(top), top.duration, amax))


def against_toppra(case, func):
    """
    Return (our planning time, TOPP-RA's, our plan): ``func`` and TOPP-RA in turn.

    Best of :data:`REPEATS` each (``wall_time.timed_against``); TOPP-RA's
    time is also kept in ``case.t_tops``.
    """
    (t_top, _), (elapsed, traj) = timed_against(
        lambda: toppra_trajectory(case.waypoints, case.vmax, case.amax), func, REPEATS)
    case.t_tops.append(t_top)
    return elapsed, t_top, traj


def main():
    """Run the comparison and print the tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    seed = bench_seeds.run_seed()
    inner = int(sys.argv[1]) if len(sys.argv) > 1 else None
    name = 'default' if inner is None else str(inner)
    n_cases = bench_seeds.case_count(N_CASES)
    rng = bench_seeds.generator(CASES_STREAM)
    print(f'{n_cases} random requests (seed {seed}, stream {CASES_STREAM}): 555 optimal / '
          f'TOPP-RA, inner_knots=0 -> inner_knots={name} (planning time / TOPP-RA planning '
          f"time; 4 Hz shaking peak / TOPP-RA's), and inner_knots={name} / TOPP-RA along our "
          'own path')
    print('| case | N x n | TOPP-RA [s] (planning [s]) | LB / TOPP-RA | '
          + ' | '.join(label(r) for r in JERK_RATIOS) + ' |')
    print(bench_figures.rule(4 + len(JERK_RATIOS)))
    rows = {}
    for ratio in JERK_RATIOS:
        rows[f'inner_knots=0, {label(ratio)}'] = []
        rows[f'inner_knots={name}, {label(ratio)}'] = []
    shaped_name = f'vibration_frequency={VIBRATION_FREQUENCY:g}, {label(SHAKING_JERK)}'
    rows[shaped_name] = []
    optimal_names = {ratio: f'speed_profile=time_optimal, {label(ratio)}'
                     for ratio in OPTIMAL_JERK_RATIOS}
    for optimal_name in optimal_names.values():
        rows[optimal_name] = []
    cancelled_name = (f'speed_profile=time_optimal, '
                      f'vibration_frequency={VIBRATION_FREQUENCY:g}, {label(SHAKING_JERK)}')
    rows[cancelled_name] = []
    held = dict.fromkeys(rows, True)
    bounds = []
    for index in range(n_cases):
        waypoints, vmax, amax = random_case(rng)
        case = toppra_case(waypoints, vmax, amax)
        bounds.append(lower_bound(waypoints, vmax, amax) / case.d_top)
        cells = []
        for ratio in JERK_RATIOS:
            kwargs = {'max_velocity': vmax, 'max_acceleration': amax,
                      'max_jerk': None if ratio is None else ratio * amax}
            plans = [(f'inner_knots=0, {label(ratio)}',) + against_toppra(
                case, lambda: plan(waypoints, '555', 'optimal', inner_knots=0, **kwargs))]
            plans.append((f'inner_knots={name}, {label(ratio)}',) + against_toppra(
                case, lambda: plan(waypoints, '555', 'optimal', inner_knots=inner, **kwargs)))
            if ratio == SHAKING_JERK:
                plans.append((shaped_name,) + against_toppra(
                    case, lambda: plan(waypoints, '555', 'optimal', inner_knots=inner,
                                       vibration_frequency=VIBRATION_FREQUENCY, **kwargs)))
                plans.append((cancelled_name,) + against_toppra(
                    case, lambda: plan(waypoints, '555', 'optimal', speed_profile='time_optimal',
                                       vibration_frequency=VIBRATION_FREQUENCY, **kwargs)))
            if ratio in optimal_names:
                plans.append((optimal_names[ratio],) + against_toppra(
                    case, lambda: plan(waypoints, '555', 'optimal', speed_profile='time_optimal',
                                       **kwargs)))
            for row, elapsed, t_top, traj in plans:
                rows[row].append(plan_figures(traj, elapsed, t_top, case))
                held[row] &= traj.within_limits(rtol=1e-9)
            before, after = rows[plans[0][0]][-1], rows[plans[1][0]][-1]
            peak = bench_figures.PEAK_4HZ
            cells.append(f'{before[0]:.3f} ({before[-1]:.2f}; {before[peak]:.2f}) -> '
                         f'{after[0]:.3f} ({after[-1]:.2f}; {after[peak]:.2f}), own path '
                         f'{after[1]:.3f}')
        print(f'| {index} | {len(waypoints)} x {waypoints.shape[1]} | {case.d_top:.2f} '
              f'({min(case.t_tops):.3f}) | {bounds[-1]:.3f} | ' + ' | '.join(cells) + ' |')
        sys.stdout.flush()
    summary_head(f'Every plan / TOPP-RA on the same case, medians and worst (largest) over '
                 f'the {n_cases} cases (TOPP-RA: its chord spline through the waypoints; along '
                 'our path: benchmarks/own_path.py; shaking: peak while moving, residual after '
                 f'the end, benchmarks/shaking.py); LB / TOPP-RA median {np.median(bounds):.3f}',
                 'all limits held (exact peaks)')
    for row, figures in rows.items():
        print(f'| {row} | {bench_figures.summary(figures)} | {held[row]} |')
    print()
    kwargs = pe.plan_kwargs()
    for knots in (0, inner):
        times = []
        for _ in range(5):
            elapsed, traj = best_of(lambda: plan(pe.joint_waypoints(), '555', 'optimal',
                                                 inner_knots=knots, **kwargs), 1)
            times.append(elapsed)
        print(f"Paper's example (its boundary values), 555 optimal, inner_knots="
              f"{'default' if knots is None else knots}: {traj.duration:.4f} s, planned in "
              f'{1e3 * np.median(times):.0f} ms (median of 5), inner knots per segment at '
              f"most: {traj.optimizer['inner_knots']}")
    large_requests(inner)
    small_requests(inner)
    long_moves(inner)
    return 0


def large_requests(inner):
    """Print 100 x 7 and 1000 x 7: the figures of every row, best of REPEATS each in turn."""
    print()
    print(f'Random walks x 7 joints (stream {LARGE_STREAM}), v = 2, a = 10, j = 200 (TOPP-RA: '
          f'v/a), planning times best of {REPEATS}, ours and TOPP-RA in turn; figures of '
          'inner_knots=default / TOPP-RA:')
    print('| N x n | TOPP-RA [s] | inner_knots=0 [s] | inner knots [s] | TOPP-RA planning [s] '
          '| inner knots planning [s] | ' + bench_figures.header(cases=False)
          + ' | limits held |')
    print(bench_figures.rule(7 + len(bench_figures.NAMES)))
    rng = bench_seeds.generator(LARGE_STREAM)
    for n_points in (100, 1000):
        waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, 7)), axis=0)
        vmax, amax = np.full(7, 2.0), np.full(7, 10.0)
        kwargs = {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': 20.0 * amax}
        case = toppra_case(waypoints, vmax, amax)
        elapsed, t_top, traj = against_toppra(
            case, lambda: plan(waypoints, '555', 'optimal', inner_knots=inner, **kwargs))
        knots_only = plan(waypoints, '555', 'optimal', inner_knots=0, **kwargs)
        print(f'| {n_points} x 7 | {case.d_top:.2f} | {knots_only.duration:.2f} '
              f'| {traj.duration:.2f} | {t_top:.2f} | {elapsed:.2f} | '
              + bench_figures.single(plan_figures(traj, elapsed, t_top, case))
              + f' | {traj.within_limits(rtol=1e-9)} |')
        sys.stdout.flush()


# Planning time by size (issue 23: at most TOPP-RA's from 3 x 3 on): sizes,
# requests per size and calls per timing (the best counts).
SMALL_SIZES = ((3, 3), (5, 6), (8, 7), (12, 7), (30, 7))
SMALL_CASES = 4
SMALL_REPEATS = 5


def small_requests(inner):
    """Print 555 optimal's planning time / TOPP-RA's per size: each best of its calls, in turn."""
    print()
    print(f'Planning time by size (random walks, stream {SMALL_STREAM}, random v/a, j = 20 a; '
          f'per request the best of '
          f'{SMALL_REPEATS} calls of each planner, alternating; {SMALL_CASES} requests per size):')
    print('| N x n | TOPP-RA [ms] | 555 optimal [ms] | planning / TOPP-RA: median / worst '
          '| duration / TOPP-RA: median / worst | 4 Hz shaking peak / TOPP-RA: median / worst '
          '| plans with inner knots |')
    print('|---|---|---|---|---|---|---|')
    rng = bench_seeds.generator(SMALL_STREAM)
    for n_points, n_joints in SMALL_SIZES:
        rows = []
        with_knots = 0
        for _ in range(SMALL_CASES):
            waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
            vmax, amax = rng.uniform(1.0, 3.0, n_joints), rng.uniform(5.0, 15.0, n_joints)
            kwargs = {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': 20.0 * amax}
            (best_top, top), (best_ours, traj) = timed_against(
                lambda: toppra_trajectory(waypoints, vmax, amax),
                lambda: plan(waypoints, '555', 'optimal', inner_knots=inner, **kwargs),
                SMALL_REPEATS)
            with_knots += traj.optimizer.get('inner_knots', 0) > 0
            reference = shaking_figures(of_toppra(top), top.duration, amax)
            rows.append((best_top, best_ours, traj.duration / top.duration,
                         shaking_ratios(traj, reference, amax)[0]))
        rows = np.array(rows)
        ratio = rows[:, 1] / rows[:, 0]
        print(f'| {n_points} x {n_joints} | {1e3 * np.median(rows[:, 0]):.1f} '
              f'| {1e3 * np.median(rows[:, 1]):.1f} | {np.median(ratio):.2f} / {ratio.max():.2f} '
              f'| {np.median(rows[:, 2]):.3f} / {np.max(rows[:, 2]):.3f} '
              f'| {np.median(rows[:, 3]):.2f} / {np.max(rows[:, 3]):.2f} '
              f'| {with_knots}/{SMALL_CASES} |')
        sys.stdout.flush()


# Long moves (step 8 of inner_knots.py): requests, waypoints, largest step [rad].
LONG_CASES = 20
LONG_WAYPOINTS = (2, 5)
LONG_STEP = 6.0


def long_moves(inner):
    """Print the figures of moves of few long segments (a cruise each): ours / TOPP-RA."""
    summary_head(f'Long moves (stream {LONG_STREAM}): {LONG_CASES} requests of '
                 f'{LONG_WAYPOINTS[0]}-{LONG_WAYPOINTS[1]} waypoints, 1-6 joints, steps uniform '
                 f'in +-{LONG_STEP:g} rad, v in [0.5, 3], a in [2, 15], j = 20 a; planning best '
                 f'of {REPEATS}, ours and TOPP-RA in turn; median / worst:', 'limits held')
    rng = bench_seeds.generator(LONG_STREAM)
    rows, held = [], True
    for _ in range(LONG_CASES):
        n_points, n_joints = int(rng.integers(*LONG_WAYPOINTS, endpoint=True)), int(
            rng.integers(1, 7))
        waypoints = np.cumsum(rng.uniform(-LONG_STEP, LONG_STEP, (n_points, n_joints)), axis=0)
        vmax, amax = rng.uniform(0.5, 3.0, n_joints), rng.uniform(2.0, 15.0, n_joints)
        kwargs = {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': 20.0 * amax}
        case = toppra_case(waypoints, vmax, amax)
        elapsed, t_top, traj = against_toppra(
            case, lambda: plan(waypoints, '555', 'optimal', inner_knots=inner, **kwargs))
        rows.append(plan_figures(traj, elapsed, t_top, case))
        held &= traj.within_limits(rtol=1e-9)
    name = 'default' if inner is None else f'inner_knots={inner}'
    print(f'| {name} | {bench_figures.summary(rows)} | {held} |')
    sys.stdout.flush()


if __name__ == '__main__':
    sys.exit(main())
