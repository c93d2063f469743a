"""
Free inner knots (issue 17): 555 optimal timing against TOPP-RA, one run.

20 random rest-to-rest requests (fixed seed; 5 to 50 waypoints, 3 to 7
joints, v in [1, 3] rad/s and a in [5, 15] rad/s^2 per joint).  For each:
TOPP-RA's duration and planning time (toppra, v/a limits only, its own
spline path through the waypoints, default grid), the lower bound LB of the
issue, and 555 optimal with knots at the waypoints only (``inner_knots=0``,
before the issue) and with inner knots (the default), for no jerk limit,
j = 20 a and j = 5 a, as ratios to TOPP-RA with planning times; then the
median and worst ratios, planning time against TOPP-RA's, and whether every
limit held (exact peaks).  Then the paper's example (its boundary values)
and the planning time at 100 x 7 and 1000 x 7 against TOPP-RA's on the same
request, each timed in turn in this run; last, the planning time of small
requests (3 x 3 to 30 x 7) against TOPP-RA's, each the best of several
calls made in turn.

Smoothness next to speed (issue 23): for j = 20 a, every plan's shaking of
a lightly damped mode at 4 and 8 Hz on every joint (``shaking.py``: peak
while moving and residual after the end, each divided by TOPP-RA's on the
same case), for the table's two plans and ``vibration_frequency=4``;
medians over the cases, and the same figures on the 100 x 7 and 1000 x 7
requests.

Usage: ``python benchmarks/bench_inner_knots.py [inner_knots]`` (default: plan()'s).
"""

import logging
import os
import sys
import time

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_planning import toppra_trajectory  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
from shaking import (FREQUENCIES, of_toppra, shaking_figures, shaking_header,  # noqa: E402
                     shaking_ratios)
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.robot import paper_example as pe  # noqa: E402

SEED = 17
N_CASES = 20
JERK_RATIOS = (None, 20.0, 5.0)
# Shaking is measured at this jerk ratio: on the two plans of the table,
# and on one more with this vibration_frequency [Hz].
SHAKING_JERK = 20.0
VIBRATION_FREQUENCY = 4.0


def shaking_row(traj, elapsed, reference, d_top, t_top, amax):
    """Duration, :func:`shaking_ratios` and planning time of ``traj``, each / TOPP-RA's."""
    return ([traj.duration / d_top] + shaking_ratios(traj, reference, amax)
            + [elapsed / t_top])


def timed(func):
    """Wall time [s] of one call and its result."""
    started = time.perf_counter()
    result = func()
    return time.perf_counter() - started, result


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


def main():
    """Run the comparison and print the tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    inner = int(sys.argv[1]) if len(sys.argv) > 1 else None
    name = 'default' if inner is None else str(inner)
    rng = np.random.default_rng(SEED)
    print(f'555 optimal / TOPP-RA, inner_knots=0 -> inner_knots={name} '
          '(planning time / TOPP-RA planning time)')
    print('| case | N x n | TOPP-RA [s] (planning [s]) | LB / TOPP-RA | '
          + ' | '.join(label(r) for r in JERK_RATIOS) + ' |')
    print('|' + '---|' * (4 + len(JERK_RATIOS)))
    before = {r: [] for r in JERK_RATIOS}
    after = {r: [] for r in JERK_RATIOS}
    speed = {r: [] for r in JERK_RATIOS}
    held = dict.fromkeys(JERK_RATIOS, True)
    shaped_name = f'vibration_frequency={VIBRATION_FREQUENCY:g}'
    shaken = {'inner_knots=0': [], f'inner_knots={name}': [], shaped_name: []}
    bounds = []
    for case in range(N_CASES):
        waypoints, vmax, amax = random_case(rng)
        t_top, top = timed(lambda: toppra_trajectory(waypoints, vmax, amax))
        d_top = top.duration
        reference = shaking_figures(of_toppra(top), d_top, amax)
        bounds.append(lower_bound(waypoints, vmax, amax) / d_top)
        cells = []
        for ratio in JERK_RATIOS:
            kwargs = {'max_velocity': vmax, 'max_acceleration': amax,
                      'max_jerk': None if ratio is None else ratio * amax}
            t0, knots_only = timed(lambda: plan(waypoints, '555', 'optimal', inner_knots=0,
                                                **kwargs))
            t1, traj = timed(lambda: plan(waypoints, '555', 'optimal', inner_knots=inner,
                                          **kwargs))
            before[ratio].append(knots_only.duration / d_top)
            after[ratio].append(traj.duration / d_top)
            speed[ratio].append(t1 / t_top)
            held[ratio] &= traj.within_limits(rtol=1e-9)
            if ratio == SHAKING_JERK:
                t2, shaped = timed(lambda: plan(waypoints, '555', 'optimal',
                                                vibration_frequency=VIBRATION_FREQUENCY,
                                                **kwargs))
                for row, planned, elapsed in (('inner_knots=0', knots_only, t0),
                                              (f'inner_knots={name}', traj, t1),
                                              (shaped_name, shaped, t2)):
                    shaken[row].append(shaking_row(planned, elapsed, reference, d_top, t_top,
                                                   amax))
            cells.append(f'{before[ratio][-1]:.3f} ({t0 / t_top:.2f}) -> '
                         f'{after[ratio][-1]:.3f} ({t1 / t_top:.2f})')
        print(f'| {case} | {len(waypoints)} x {waypoints.shape[1]} | {d_top:.2f} ({t_top:.3f}) '
              f'| {bounds[-1]:.3f} | ' + ' | '.join(cells) + ' |')
        sys.stdout.flush()
    print()
    print(f'| jerk limit | inner_knots=0: median / worst | inner_knots={name}: median / worst '
          '| planning time / TOPP-RA planning time: median / worst | all limits held '
          '| LB / TOPP-RA median |')
    print('|---|---|---|---|---|---|')
    for ratio in JERK_RATIOS:
        print(f'| {label(ratio)} | {np.median(before[ratio]):.3f} / {np.max(before[ratio]):.3f} '
              f'| {np.median(after[ratio]):.3f} / {np.max(after[ratio]):.3f} '
              f'| {np.median(speed[ratio]):.2f} / {np.max(speed[ratio]):.2f} '
              f'| {held[ratio]} | {np.median(bounds):.3f} |')
    print()
    print(f'Speed and shaking, j = {SHAKING_JERK:g} a: medians over the cases of each plan / '
          'TOPP-RA on the same case (shaking: peak while moving, residual after the end; '
          'benchmarks/shaking.py)')
    print('| plan | duration: median / worst | ' + shaking_header()
          + ' | planning time: median / worst |')
    print('|' + '---|' * (3 + 2 * len(FREQUENCIES)))
    for shaken_name, rows in shaken.items():
        rows = np.array(rows)
        median = np.median(rows, axis=0)
        print(f'| {shaken_name} | {median[0]:.3f} / {np.max(rows[:, 0]):.3f} | '
              + ' | '.join(f'{value:.2f}' for value in median[1:-1])
              + f' | {median[-1]:.2f} / {np.max(rows[:, -1]):.2f} |')
    print()
    kwargs = pe.plan_kwargs()
    for knots in (0, inner):
        times = []
        for _ in range(5):
            elapsed, traj = timed(lambda: plan(pe.joint_waypoints(), '555', 'optimal',
                                               inner_knots=knots, **kwargs))
            times.append(elapsed)
        print(f"Paper's example (its boundary values), 555 optimal, inner_knots="
              f"{'default' if knots is None else knots}: {traj.duration:.4f} s, planned in "
              f'{1e3 * np.median(times):.0f} ms (median of 5), inner knots per segment at '
              f"most: {traj.optimizer['inner_knots']}")
    print()
    print('Random walks x 7 joints, v = 2, a = 10, j = 200 (TOPP-RA: v/a), one run each in turn:')
    print('| N x n | TOPP-RA [s] | inner_knots=0 [s] | inner knots [s] | TOPP-RA planning [s] '
          '| inner knots planning [s] | planning / TOPP-RA planning | '
          + shaking_header() + ' (/ TOPP-RA) |')
    print('|' + '---|' * (7 + 2 * len(FREQUENCIES)))
    for n_points in (100, 1000):
        waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, 7)), axis=0)
        vmax, amax = np.full(7, 2.0), np.full(7, 10.0)
        kwargs = {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': 20.0 * amax}
        t_top, top = timed(lambda: toppra_trajectory(waypoints, vmax, amax))
        d_top = top.duration
        elapsed, traj = timed(lambda: plan(waypoints, '555', 'optimal', inner_knots=inner,
                                           **kwargs))
        knots_only = plan(waypoints, '555', 'optimal', inner_knots=0, **kwargs)
        shaking = shaking_ratios(traj, shaking_figures(of_toppra(top), d_top, amax), amax)
        print(f'| {n_points} x 7 | {d_top:.2f} | {knots_only.duration:.2f} '
              f'| {traj.duration:.2f} | {t_top:.2f} | {elapsed:.2f} | {elapsed / t_top:.2f} | '
              + ' | '.join(f'{value:.2f}' for value in shaking) + ' |')
        sys.stdout.flush()
    small_requests(inner)
    return 0


# Planning time by size (issue 23: at most TOPP-RA's from 3 x 3 on): sizes,
# requests per size and calls per timing (the best counts).
SMALL_SIZES = ((3, 3), (5, 6), (8, 7), (12, 7), (30, 7))
SMALL_CASES = 4
SMALL_REPEATS = 5


def small_requests(inner):
    """Print 555 optimal's planning time / TOPP-RA's per size: each best of its calls, in turn."""
    print()
    print(f'Planning time by size (random walks, random v/a, j = 20 a; per request the best of '
          f'{SMALL_REPEATS} calls of each planner, alternating; {SMALL_CASES} requests per size):')
    print('| N x n | TOPP-RA [ms] | 555 optimal [ms] | ratio: median / worst | plans with inner '
          'knots |')
    print('|---|---|---|---|---|')
    rng = np.random.default_rng(SEED + 1)
    for n_points, n_joints in SMALL_SIZES:
        rows = []
        with_knots = 0
        for _ in range(SMALL_CASES):
            waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
            vmax, amax = rng.uniform(1.0, 3.0, n_joints), rng.uniform(5.0, 15.0, n_joints)
            kwargs = {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': 20.0 * amax}
            best_top = best_ours = np.inf
            for _ in range(SMALL_REPEATS):
                elapsed, _ = timed(lambda: toppra_trajectory(waypoints, vmax, amax))
                best_top = min(best_top, elapsed)
                elapsed, traj = timed(lambda: plan(waypoints, '555', 'optimal',
                                                   inner_knots=inner, **kwargs))
                best_ours = min(best_ours, elapsed)
            with_knots += traj.optimizer.get('inner_knots', 0) > 0
            rows.append((best_top, best_ours))
        rows = np.array(rows)
        ratio = rows[:, 1] / rows[:, 0]
        print(f'| {n_points} x {n_joints} | {1e3 * np.median(rows[:, 0]):.1f} '
              f'| {1e3 * np.median(rows[:, 1]):.1f} | {np.median(ratio):.2f} / {ratio.max():.2f} '
              f'| {with_knots}/{SMALL_CASES} |')
        sys.stdout.flush()


if __name__ == '__main__':
    sys.exit(main())
