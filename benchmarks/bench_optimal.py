"""
Optimal timing against TOPP-RA: durations and planning times, one run.

20 random rest-to-rest requests (fixed seed; 3 and 7 joints; 5 to 50
waypoints; v <= 2, a <= 10 per joint, no jerk limit).  For each: the
time-optimal duration TOPP-RA (toppra) finds along its spline through the
same waypoints, and the durations of 445 and 434 with uniform (paper) and
optimal timing, as ratios to TOPP-RA, with planning times.  Then the
paper's example and a 100 x 7 request.
"""

import logging
import os
import sys
import time

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_planning import toppra_plan  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
from splines445_ros.arm import paper_example as pe  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402

SEED = 2024
N_CASES = 20


def timed(func):
    """Wall time [s] of one call and its result."""
    started = time.perf_counter()
    result = func()
    return time.perf_counter() - started, result


def main():
    """Run the comparison and print the tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    rng = np.random.default_rng(SEED)
    print('Optimal timing vs TOPP-RA: duration ratio to TOPP-RA (planning time [ms])')
    print('| case | N x n | TOPP-RA [s] (ms) | 445 uniform | 445 optimal | 434 uniform '
          '| 434 optimal |')
    print('|' + '---|' * 7)
    ratios = {key: [] for key in ('445 uniform', '445 optimal', '434 uniform', '434 optimal')}
    for case in range(N_CASES):
        n_joints = 3 if case % 2 == 0 else 7
        n_points = int(rng.integers(5, 51))
        waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
        vmax, amax = np.full(n_joints, 2.0), np.full(n_joints, 10.0)
        t_top, d_top = timed(lambda: toppra_plan(waypoints, vmax, amax))
        cells = []
        for method in ('445', '434'):
            for timing in ('uniform', 'optimal'):
                elapsed, traj = timed(lambda: plan(waypoints, method, timing,
                                                   max_velocity=vmax, max_acceleration=amax))
                ratio = traj.duration / d_top
                ratios[f'{method} {timing}'].append(ratio)
                cells.append(f'{ratio:.2f} ({1e3 * elapsed:.0f})')
        print(f'| {case} | {n_points} x {n_joints} | {d_top:.2f} ({1e3 * t_top:.0f}) | '
              + ' | '.join(cells) + ' |')
        sys.stdout.flush()
    print()
    for key, values in ratios.items():
        print(f'{key}: median ratio {np.median(values):.2f}, worst {np.max(values):.2f}')
    print()
    kwargs = pe.plan_kwargs()
    waypoints = pe.joint_waypoints()
    print("Paper's example (v <= 2, a <= 10, no jerk limit, paper boundary values):")
    for method in ('445', '434'):
        for timing in ('uniform', 'optimal'):
            elapsed, traj = timed(lambda: plan(waypoints, method, timing, **kwargs))
            print(f'  {method} {timing}: {traj.duration:.4f} s, planned in '
                  f'{1e3 * elapsed:.1f} ms')
    waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (100, 7)), axis=0)
    print('100 x 7 random walk:')
    for method in ('445', '434'):
        elapsed, traj = timed(lambda: plan(waypoints, method, 'optimal',
                                           max_velocity=np.full(7, 2.0),
                                           max_acceleration=np.full(7, 10.0)))
        print(f'  {method} optimal: {traj.duration:.2f} s (uniform '
              f'{traj.optimizer["uniform_duration"]:.2f} s), planned in {elapsed:.2f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
