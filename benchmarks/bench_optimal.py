"""
Optimal timing against TOPP-RA: durations and planning times, one run.

20 random rest-to-rest requests (a fresh seed every run, SPLINES445_BENCH_CASES
sets the count; 3 and 7 joints; 5 to 50 waypoints; v <= 2, a <= 10 per
joint, no jerk limit).  For each: the time-optimal duration TOPP-RA
(toppra) finds along its chord spline through the same waypoints
(``own_path.chord_spline``), and the durations of 445, 434 and 555 with
uniform (paper) and optimal timing, as ratios to TOPP-RA, with planning
times; then the median and worst ratios and whether every limit held.
Then the paper's example, and the planning time of optimal timing against
TOPP-RA's on the same 100 x 7 and 1000 x 7 requests (ratios from this run;
SPLINES445_BENCH_QUICK=1 skips 1000 x 7).  Every planning time is the best
of 3 calls, each plan and TOPP-RA on the same request in turn
(``wall_time.timed_against``: the TOPP-RA time next to a plan's is from the
same rounds; a case's TOPP-RA time in the first table is the best of all
its calls).  555 optimal is plan()'s default, with inner knots
(bench_inner_knots.py compares it with knots only).
Next to every median duration: the median shaking of a lightly damped 4 and
8 Hz mode on every joint, peak while moving and residual after the end, each
divided by TOPP-RA's on the same request (``shaking.py``).
"""

from functools import partial
import logging
import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_planning import toppra_plan, toppra_trajectory  # noqa: E402, I100
import bench_seeds  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
from shaking import of_toppra, shaking_figures, shaking_header, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.robot import paper_example as pe  # noqa: E402
from wall_time import best_of, timed_against  # noqa: E402

N_CASES = 20
METHODS = ('445', '434', '555')


def limits_held(traj, rtol=1e-7):
    """Return True when every exact peak is within its limit."""
    return traj.within_limits(rtol=rtol)


def main():
    """Run the comparison and print the tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    quick = os.environ.get('SPLINES445_BENCH_QUICK') == '1'
    rng = bench_seeds.generator()
    keys = [f'{m} {t}' for m in METHODS for t in ('uniform', 'optimal')]
    print('Optimal timing vs TOPP-RA: duration ratio to TOPP-RA (planning time [ms]; 4 Hz '
          "shaking peak / TOPP-RA's)")
    print('| case | N x n | TOPP-RA [s] (ms) | ' + ' | '.join(keys) + ' |')
    print('|' + '---|' * (3 + len(keys)))
    ratios = {key: [] for key in keys}
    held = dict.fromkeys(keys, True)
    shaking = {key: [] for key in keys}
    for case in range(bench_seeds.case_count(N_CASES)):
        n_joints = 3 if case % 2 == 0 else 7
        n_points = int(rng.integers(5, 51))
        waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
        vmax, amax = np.full(n_joints, 2.0), np.full(n_joints, 10.0)
        rival = partial(toppra_trajectory, waypoints, vmax, amax)
        top = rival()
        d_top = top.duration
        reference = shaking_figures(of_toppra(top), d_top, amax)
        cells, t_tops = [], []
        for key in keys:
            method, timing = key.split()
            (t_top, _), (elapsed, traj) = timed_against(
                rival, lambda: plan(waypoints, method, timing, max_velocity=vmax,
                                    max_acceleration=amax))
            t_tops.append(t_top)
            ratio = traj.duration / d_top
            ratios[key].append(ratio)
            held[key] &= limits_held(traj)
            shaking[key].append(shaking_ratios(traj, reference, amax))
            cells.append(f'{ratio:.2f} ({1e3 * elapsed:.0f}; {shaking[key][-1][0]:.2f})')
        print(f'| {case} | {n_points} x {n_joints} | {d_top:.2f} ({1e3 * min(t_tops):.0f}) | '
              + ' | '.join(cells) + ' |')
        sys.stdout.flush()
    print()
    print('| method, timing | median ratio to TOPP-RA | worst | all limits held | '
          + shaking_header() + ' (medians / TOPP-RA) |')
    print('|' + '---|' * 8)
    for key, values in ratios.items():
        print(f'| {key} | {np.median(values):.3f} | {np.max(values):.3f} | {held[key]} | '
              + ' | '.join(f'{v:.2f}' for v in np.median(shaking[key], axis=0)) + ' |')
    print()
    kwargs = pe.plan_kwargs()
    waypoints = pe.joint_waypoints()
    print("Paper's example (v <= 2, a <= 10, no jerk limit, paper boundary values), "
          'best of 5:')
    for key in keys:
        method, timing = key.split()
        elapsed, traj = best_of(lambda: plan(waypoints, method, timing, **kwargs), 5)
        print(f'  {key}: {traj.duration:.4f} s, planned in {1e3 * elapsed:.1f} ms')
    print()
    print('Optimal timing against TOPP-RA on the same requests (best of 3, each plan and '
          'TOPP-RA in turn):')
    print('| N x n | method | optimal duration [s] | uniform [s] | TOPP-RA [s] '
          '| planning time [s] | TOPP-RA time [s] | time / TOPP-RA time |')
    print('|---|---|---|---|---|---|---|---|')
    for n_points in ((100,) if quick else (100, 1000)):
        waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, 7)), axis=0)
        vmax, amax = np.full(7, 2.0), np.full(7, 10.0)
        for method in ('555', '434', '445'):
            (t_top, d_top), (elapsed, traj) = timed_against(
                lambda: toppra_plan(waypoints, vmax, amax),
                lambda: plan(waypoints, method, 'optimal', max_velocity=vmax,
                             max_acceleration=amax))
            uniform = plan(waypoints, method, 'uniform', max_velocity=vmax,
                           max_acceleration=amax)
            print(f'| {n_points} x 7 | {method} | {traj.duration:.2f} '
                  f'| {uniform.duration:.2f} | {d_top:.2f} '
                  f'| {elapsed:.2f} | {t_top:.2f} | {elapsed / t_top:.2f} |')
            sys.stdout.flush()
    return 0


if __name__ == '__main__':
    sys.exit(main())
