"""
Free inner knots (issue 17): planning time with the joints' LPs in threads, one run.

For seeded rest-to-rest N x 7 requests (v = 2 rad/s, a = 10 rad/s^2, no jerk
limit and j = 20 a): TOPP-RA's planning time (toppra, v/a only, default
grid) and 555 optimal with ``inner_knots=2`` planned twice, with the joints'
LPs solved one by one (``JOINT_THREADS = 1``, as before) and in threads
(the default, one per core).  The two results must be the same spline, bit
for bit; the script says so for every request.

Usage: ``python benchmarks/bench_inner_knots_threads.py [N ...]`` (default 20 50).
"""

import logging
import os
import sys
import time

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_planning import toppra_plan  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
from splines445_ros.planning import inner_knots, plan  # noqa: E402


def timed(func):
    """Wall time [s] of one call and its result."""
    started = time.perf_counter()
    result = func()
    return time.perf_counter() - started, result


def main():
    """Run the comparison and print the table."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    sizes = [int(a) for a in sys.argv[1:]] or [20, 50]
    threads = inner_knots.JOINT_THREADS
    print(f'555 optimal, inner_knots=2: joints one by one -> {threads} threads '
          f'({os.cpu_count()} cores)')
    print('| N x n | jerk limit | TOPP-RA [s] (planning [s]) | inner knots [s] '
          '| planning, 1 thread [s] | planning, threads [s] | same spline |')
    print('|---|---|---|---|---|---|---|')
    for n_points in sizes:
        rng = np.random.default_rng(100 + n_points)
        waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, 7)), axis=0)
        vmax, amax = np.full(7, 2.0), np.full(7, 10.0)
        t_top, d_top = timed(lambda: toppra_plan(waypoints, vmax, amax))
        for ratio in (None, 20.0):
            kwargs = {'max_velocity': vmax, 'max_acceleration': amax,
                      'max_jerk': None if ratio is None else ratio * amax}
            inner_knots.JOINT_THREADS = 1
            t_one, one = timed(lambda: plan(waypoints, '555', 'optimal', inner_knots=2,
                                            **kwargs))
            inner_knots.JOINT_THREADS = threads
            t_many, many = timed(lambda: plan(waypoints, '555', 'optimal', inner_knots=2,
                                              **kwargs))
            same = (np.array_equal(one.breakpoints, many.breakpoints)
                    and np.array_equal(one.ppoly.c, many.ppoly.c))
            jerk = 'none' if ratio is None else f'{ratio:g} a'
            print(f'| {n_points} x 7 | {jerk} | {d_top:.2f} ({t_top:.2f}) | {many.duration:.2f} '
                  f'| {t_one:.2f} | {t_many:.2f} | {same} |')
            sys.stdout.flush()
    return 0


if __name__ == '__main__':
    sys.exit(main())
