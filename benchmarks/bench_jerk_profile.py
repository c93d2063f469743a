"""
The third-order profile of issue 38 against plan()'s default and TOPP-RA, one run.

Fresh random rest-to-rest requests every run (``bench_seeds``), drawn as
``bench_inner_knots.py`` draws them (5 to 50 waypoints, 3 to 7 joints, v in
[1, 3] rad/s, a in [5, 15] rad/s^2), with j = 20 a.  Per request: plan()'s default
(555 optimal, inner knots, the second-order profile pulled back by its
rounds), and ``inner_knots.plan_with_inner_knots(..., third_order=True)``
with 8 inner knots at most and three choices of smoothing windows: the
profile then holds the jerk limits itself (:mod:`planning.speed_profile.jerk_profile`).
Every row prints the figures of ``bench_figures.NAMES`` (duration over
TOPP-RA's and over TOPP-RA's along our own path, shaking at 4 and 8 Hz,
planning time over TOPP-RA's: each plan and TOPP-RA on the same request in
turn, best of 3 each, ``wall_time.timed_against``), median and worst.

Usage: ``python benchmarks/bench_jerk_profile.py``
(``SPLINES445_BENCH_SEED`` repeats a run, ``SPLINES445_BENCH_CASES`` sets
how many requests; default 12).
"""

from functools import partial
import logging
import os

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_figures  # noqa: E402, I100
from bench_inner_knots import random_case  # noqa: E402
from bench_planning import toppra_trajectory  # noqa: E402
import bench_seeds  # noqa: E402
import numpy as np  # noqa: E402
import own_path  # noqa: E402
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.path_following.inner_knots import plan_with_inner_knots  # noqa: E402
from splines445_ros.planning.spline.limits import JointLimits  # noqa: E402
from wall_time import timed_against  # noqa: E402

N_CASES = 12
JERK_RATIO = 20.0
MOST_KNOTS = 8
# Smoothing windows [s] of the third-order rows: ramp-sized ones, a box of
# 1/4 s and its half, and plan()'s default.
WINDOWS = ((0.1, 0.05), (0.25, 0.125), (0.3, 0.15))
CASES_STREAM = 38


def main():
    """Plan every request every way and print the table."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    seed = bench_seeds.run_seed()
    n_cases = bench_seeds.case_count(N_CASES)
    rng = bench_seeds.generator(CASES_STREAM)
    names = ['plan() default'] + [f'third order, windows {w[0]:g} + {w[1]:g} s'
                                  for w in WINDOWS]
    rows = {name: [] for name in names}
    for _ in range(n_cases):
        waypoints, vmax, amax = random_case(rng)
        n = waypoints.shape[1]
        jerk = JERK_RATIO * amax
        limits = JointLimits.from_user(n, vmax, amax, jerk)
        zero = np.zeros(n)
        rival = partial(toppra_trajectory, waypoints, vmax, amax)
        top = rival()
        reference = shaking_figures(of_toppra(top), top.duration, amax)
        plans = [timed_against(rival, lambda: plan(waypoints, method='555', timing='optimal',
                                                   max_velocity=vmax, max_acceleration=amax,
                                                   max_jerk=jerk))]
        for windows in WINDOWS:
            plans.append(timed_against(rival, lambda: plan_with_inner_knots(
                waypoints, (zero,) * 4, limits, MOST_KNOTS, windows=windows,
                third_order=True)))
        for name, ((t_top, _), (elapsed, traj)) in zip(names, plans):
            if traj is None or not traj.within_limits(rtol=1e-9):
                raise AssertionError(f'{name}: no plan within the limits (seed {seed})')
            own = own_path.toppra_along(traj, own_path.velocity_acceleration(vmax, amax))
            rows[name].append(bench_figures.figures(
                traj.duration, own.duration, top.duration,
                shaking_ratios(traj, reference, amax), elapsed, t_top))
    print(f'{n_cases} random requests (seed {seed}, stream {CASES_STREAM}), j = '
          f'{JERK_RATIO:g} a, every limit held (exact peaks); median / worst')
    print(f'| plan | {bench_figures.header()} |')
    print(bench_figures.rule(1 + len(bench_figures.NAMES)))
    for name in names:
        print(f'| {name} | {bench_figures.summary(rows[name])} |')


if __name__ == '__main__':
    main()
