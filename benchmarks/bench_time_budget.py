"""
Where the default plan's time goes, step by step along its own path (issue 38), one run.

Fresh random rest-to-rest requests every run (``bench_seeds``), drawn as
``bench_inner_knots.py`` draws them, with j = 20 a.  Per request, every
figure over TOPP-RA's duration on its chord spline:

* ``TOPP-RA own``: TOPP-RA along the geometric path of plan()'s default plan
  (:mod:`own_path`);
* ``profile v/a``: the fastest second-order profile along the construction's
  path (the natural cubic on the rest-to-rest times, 24 grid steps per
  segment: :mod:`planning.speed_profile.path_velocity`), no spline, no jerk limit;
* ``profile v/a/j``: the same with the jerk limits held by the profile
  itself (:mod:`planning.speed_profile.jerk_profile`);
* ``+ windows``: ``profile v/a`` plus the widths of the smoothing windows
  (the box averages of step 2 lengthen a profile by exactly their widths);
* ``averaged, scaled``: that averaged profile ``q(s(t))`` sampled every
  millisecond, slowed down uniformly until it holds v, a and j (finite
  differences): how far the averaged profile is from feasible;
* ``plan``: ``plan_with_inner_knots`` with those windows (8 inner knots),
  then plan()'s default (4 knots, windows 0.3 + 0.15 s).

The shaking columns are the plans' peak and residual at 4 Hz over TOPP-RA's
(:mod:`shaking`).  Medians and worst over the cases; the gap between
``+ windows`` and ``plan`` is what the spline that follows the profile gives
away, the gap between ``profile v/a`` and ``+ windows`` what the smoothing
costs.

Usage: ``python benchmarks/bench_time_budget.py`` (``SPLINES445_BENCH_SEED``
repeats a run, ``SPLINES445_BENCH_CASES`` sets how many requests; default 10).
"""

import logging
import os

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_inner_knots import random_case  # noqa: E402, I100
from bench_planning import toppra_trajectory  # noqa: E402
import bench_seeds  # noqa: E402
import numpy as np  # noqa: E402
import own_path  # noqa: E402
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.constraints import (  # noqa: E402
    GriddedPath, JointAcceleration, JointJerk, JointVelocity)
from splines445_ros.planning.durations.timing import rest_to_rest_durations  # noqa: E402
from splines445_ros.planning.path_following.inner_knots import (  # noqa: E402
    GRID_STEPS, plan_with_inner_knots)
from splines445_ros.planning.speed_profile.averaged_timing import AveragedTiming  # noqa: E402
from splines445_ros.planning.speed_profile.jerk_profile import ThirdOrderProfile  # noqa: E402
from splines445_ros.planning.speed_profile.path_velocity import (  # noqa: E402
    PathLimits, traversal_times)
from splines445_ros.planning.spline.limits import JointLimits  # noqa: E402
from splines445_ros.planning.spline.natural_cubic import natural_cubic_spline  # noqa: E402

N_CASES = 10
JERK_RATIO = 20.0
MOST_KNOTS = 8
WINDOWS = (0.25, 0.125)
SAMPLE = 1e-3       # [s] the averaged profile's samples
CASES_STREAM = 39
COLUMNS = ('TOPP-RA own', 'profile v/a', 'profile v/a/j', '+ windows', 'averaged, scaled',
           f'plan, windows {WINDOWS[0]:g} + {WINDOWS[1]:g} s', 'plan() default',
           '4 Hz peak / residual, windowed plan', '4 Hz peak / residual, default')


def construction_path(waypoints, limits):
    """Return the construction's path (natural cubic on the rest-to-rest times) and grid."""
    knots = np.concatenate([[0.0], np.cumsum(rest_to_rest_durations(waypoints, limits))])
    spline = natural_cubic_spline(knots, waypoints)
    fractions = np.arange(GRID_STEPS) / GRID_STEPS
    s = np.concatenate([(knots[:-1, None] + fractions * np.diff(knots)[:, None]).reshape(-1),
                        knots[-1:]])
    return spline, GriddedPath.of_ppoly(spline, s, third=True)


def scaled_average(spline, gridded, x, limits):
    """Duration of the averaged profile ``q(s(t))`` slowed down until it holds v, a and j."""
    timing = AveragedTiming(traversal_times(x, gridded.steps), x, gridded.s, WINDOWS)
    t = np.arange(0.0, timing.duration + SAMPLE, SAMPLE)
    q = spline(timing.position_at(t))
    derivatives, ratios = q, []
    for order, limit in enumerate((limits.velocity, limits.acceleration, limits.jerk), 1):
        derivatives = np.gradient(derivatives, SAMPLE, axis=0)
        ratios.append(np.max(np.abs(derivatives) / limit) ** (1.0 / order))
    return timing.duration * max(1.0, *ratios)


def main():
    """Measure every request and print the table."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    seed = bench_seeds.run_seed()
    n_cases = bench_seeds.case_count(N_CASES)
    rng = bench_seeds.generator(CASES_STREAM)
    rows = []
    for _ in range(n_cases):
        waypoints, vmax, amax = random_case(rng)
        n = waypoints.shape[1]
        jerk = JERK_RATIO * amax
        limits = JointLimits.from_user(n, vmax, amax, jerk)
        zero = np.zeros(n)
        top = toppra_trajectory(waypoints, vmax, amax)
        reference = shaking_figures(of_toppra(top), top.duration, amax)
        spline, gridded = construction_path(waypoints, limits)
        constraints = (JointVelocity(limits.velocity), JointAcceleration(limits.acceleration))
        ones = np.ones(gridded.s.size)
        second = PathLimits(gridded, constraints).profile(ones)
        third = ThirdOrderProfile(gridded, constraints + (JointJerk(limits.jerk),)).profile(
            ones, second)
        windowed = plan_with_inner_knots(waypoints, (zero,) * 4, limits, MOST_KNOTS,
                                         windows=WINDOWS)
        default = plan(waypoints, method='555', timing='optimal', max_velocity=vmax,
                       max_acceleration=amax, max_jerk=jerk)
        for traj in (windowed, default):
            if traj is None or not traj.within_limits(rtol=1e-9):
                raise AssertionError(f'no plan within the limits (seed {seed})')
        own = own_path.toppra_along(default, own_path.velocity_acceleration(vmax, amax))
        raw = traversal_times(second, gridded.steps)[-1]
        durations = [own.duration, raw, traversal_times(third, gridded.steps)[-1],
                     raw + sum(WINDOWS), scaled_average(spline, gridded, second, limits),
                     windowed.duration, default.duration]
        shaking = [shaking_ratios(traj, reference, amax)[:2] for traj in (windowed, default)]
        rows.append([d / top.duration for d in durations] + shaking)
    print(f'{n_cases} random requests (seed {seed}, stream {CASES_STREAM}), j = '
          f'{JERK_RATIO:g} a, each over TOPP-RA on its chord spline; median / worst')
    print('| ' + ' | '.join(COLUMNS) + ' |')
    print('|' + '---|' * len(COLUMNS))
    cells = []
    for k in range(len(COLUMNS) - 2):
        column = np.array([row[k] for row in rows])
        cells.append(f'{np.median(column):.3f} / {np.max(column):.3f}')
    for k in (len(COLUMNS) - 2, len(COLUMNS) - 1):
        pairs = np.array([row[k] for row in rows])
        cells.append(f'{np.median(pairs[:, 0]):.2f} / {np.median(pairs[:, 1]):.2f}')
    print('| ' + ' | '.join(cells) + ' |')


if __name__ == '__main__':
    main()
