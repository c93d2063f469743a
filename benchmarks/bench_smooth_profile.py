"""
A third-order profile that can be followed (issue 38) on the 6-7-joint arms, one run.

``splines445_ros.planning.speed_profile.smooth_profile`` plans ``x(s) = sdot**2`` as a C2
function of ``s`` under the v/a/j limits; this bench measures it against
TOPP-RA (v/a, ``bench_planning.toppra_trajectory``), the grid LP of
``jerk_profile.ThirdOrderProfile`` (``bench_arm_moves.profile_bounds``:
it holds the jerk only on its grid, and cannot be followed as it is) and
plan()'s default (``plan(points, '555', 'optimal', v, a, j)``) on the same
random joint paths (``bench_torque.random_path``, the arm's stream + 101 of
the run's seed), on the path of ``construction_path`` (the natural cubic
through the waypoints at their rest-to-rest times, 24 grid steps a
segment).

Per arm, median / worst over the paths:

* smooth x f / TOPP-RA: the smooth profile's exact duration times its
  slow-down factor ``f``, over TOPP-RA's.  ``f = max(rv, sqrt(ra),
  cbrt(rj))`` of ``q(s(t))`` sampled every 1 ms (``SmoothProfile.samples``,
  exact time law; three rest samples before, four after), v/a/j by finite
  differences over the limits: the uniform slow-down that makes the
  samples hold every limit;
* grid LP / TOPP-RA and default / TOPP-RA;
* the shaking of a lightly damped 4 Hz mode (``shaking.py``: peak while
  moving, residual after the end), over TOPP-RA's, of the slowed-down
  motion ``q(s(t / f))`` (accelerations by second differences every 1 ms)
  and of plan()'s default: a faster motion is only better if it is not
  rougher;
* the wall time of the smooth profile (one call), of the grid LP and of
  plan().

Usage: ``python benchmarks/bench_smooth_profile.py``;
``SPLINES445_BENCH_SEED=<seed>`` repeats a run,
``SPLINES445_BENCH_CASES=<count>`` sets the paths per arm (default
:data:`CASES`), ``SPLINES445_BENCH_ARMS=<names>`` keeps some arms,
``SPLINES445_BENCH_LINPROG=1`` solves with scipy's cold linprog as when
highspy is missing (the same profile, slower).  Set
``OPENBLAS_NUM_THREADS=1`` on a shared machine.
"""

import os
import time

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_arm_moves import (  # noqa: E402, I100
    construction_path, profile_bounds, rest_to_rest_knots)
import bench_arms  # noqa: E402
from bench_planning import toppra_trajectory  # noqa: E402
from bench_torque import arm_paths  # noqa: E402
import numpy as np  # noqa: E402
from shaking import FREQUENCIES, of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.speed_profile import smooth_profile  # noqa: E402
from splines445_ros.planning.speed_profile.smooth_profile import SmoothProfile  # noqa: E402
from splines445_ros.planning.spline.limits import JointLimits  # noqa: E402

CASES = 3
PERIOD = 1e-3           # the controller's: samples every 1 ms
PATH_STREAM = 101       # the arm's stream + this: the paths (as the prototype's study drew them)
REST_BEFORE, REST_AFTER = 3, 4


def motion(path, profile, period):
    """Return q(s(t)) at every ``period`` of the profile's time, with rest samples around it."""
    _, s = profile.samples(period)
    q = path(s)
    return np.vstack([np.repeat(q[:1], REST_BEFORE, 0), q, np.repeat(q[-1:], REST_AFTER, 0)])


def slow_down(q, vmax, amax, jmax):
    """Return the uniform slow-down factor of the samples ``q`` (every PERIOD) to hold v/a/j."""
    ratios = [np.max(np.abs(np.diff(q, k, axis=0)) / PERIOD ** k / limit)
              for k, limit in ((1, vmax), (2, amax), (3, jmax))]
    return max(ratios[0], np.sqrt(ratios[1]), np.cbrt(ratios[2]))


def slowed_shaking(path, profile, factor, reference, amax):
    """
    Return :func:`shaking.shaking_ratios`' figures of the profile slowed down by ``factor``.

    The motion followed is ``q(s(t / factor))``: sampled every PERIOD of its
    own time, its accelerations by second differences.
    """
    q = motion(path, profile, PERIOD / factor)
    acceleration = np.diff(q, 2, axis=0) / PERIOD ** 2
    times = (np.arange(acceleration.shape[0]) + 1 - REST_BEFORE) * PERIOD

    def acceleration_of(t):
        return np.column_stack([np.interp(t, times, column) for column in acceleration.T])

    ours = shaking_figures(acceleration_of, profile.duration * factor, amax)
    return [ours[f][k] / reference[f][k] for f in FREQUENCIES for k in (0, 1)]


def run_case(arm, points):
    """Return the figures of one path: durations over TOPP-RA's, factor, shaking, wall times."""
    limits = arm.plan_limits()
    vmax, amax, jmax = (limits[k] for k in ('max_velocity', 'max_acceleration', 'max_jerk'))
    joint = JointLimits.from_user(points.shape[1], vmax, amax, jmax)
    top = toppra_trajectory(points, vmax, amax)
    reference = shaking_figures(of_toppra(top), top.duration, amax)
    start = time.perf_counter()
    default = plan(points, '555', 'optimal', **limits)
    t_default = time.perf_counter() - start
    path, grid = construction_path(rest_to_rest_knots(points, joint), points)
    start = time.perf_counter()
    grid_lp = profile_bounds(path, grid, joint)[1]
    t_grid = time.perf_counter() - start
    start = time.perf_counter()
    profile = SmoothProfile(path, grid, vmax, amax, jmax)
    t_smooth = time.perf_counter() - start
    factor = slow_down(motion(path, profile, PERIOD), vmax, amax, jmax)
    shaking = slowed_shaking(path, profile, factor, reference, amax)
    default_shaking = shaking_ratios(default, reference, amax)
    return {'smooth': profile.duration * factor / top.duration, 'factor': factor,
            'grid': grid_lp / top.duration, 'default': default.duration / top.duration,
            'peak': shaking[0], 'residual': shaking[1], 'default_peak': default_shaking[0],
            'default_residual': default_shaking[1], 'lps': profile.lps, 't_smooth': t_smooth,
            't_grid': t_grid, 't_default': t_default, 'points': len(points)}


def cell(values, digits=3):
    """Return 'median / worst' of ``values``."""
    return f'{np.median(values):.{digits}f} / {np.max(values):.{digits}f}'


def main():
    """Run every arm and print the table."""
    seed, cases, arms = bench_arms.start_run(CASES)
    if os.environ.get('SPLINES445_BENCH_LINPROG', '').strip() not in ('', '0'):
        smooth_profile.HIGHSPY = False
    print('smooth profile LPs: ' + ('HiGHS warm (highspy)' if smooth_profile.HIGHSPY
                                    else "scipy's linprog, cold"))
    print(f"{cases} random joint paths per arm (seed {seed}, the arm's stream + {PATH_STREAM}), "
          "the arm's v/a/j limits; durations over TOPP-RA's (v/a, no jerk) on the same path; "
          'median / worst; wall times of one call [s]')
    names = ('smooth x f / TOPP-RA', 'f (1 kHz)', 'grid LP / TOPP-RA', 'default / TOPP-RA',
             'smooth / default',
             '4 Hz peak / TOPP-RA: smooth x f (median / worst) / default (median / worst)',
             '4 Hz residual / TOPP-RA: smooth x f (median / worst) / default (median / worst)',
             'LPs', 't smooth', 't grid LP',
             't default')
    print('| arm | paths (points) | ' + ' | '.join(names) + ' |')
    print('|' + '---|' * (len(names) + 2))
    every = []
    for arm in arms:
        rows = [run_case(arm, points) for points in arm_paths(arm, cases, PATH_STREAM)]
        every += rows
        print_row(arm.name, rows)
    print_row('all', every)


def print_row(name, rows):
    """Print one table row of ``rows`` (dicts of run_case)."""
    get = {key: np.array([row[key] for row in rows]) for key in rows[0]}
    points = get['points']
    print(f"| {name} | {len(rows)} ({points.min()}-{points.max()}) | {cell(get['smooth'])} | "
          f"{cell(get['factor'], 4)} | {cell(get['grid'])} | {cell(get['default'])} | "
          f"{cell(get['smooth'] / get['default'])} | "
          f"{cell(get['peak'], 2)} / {cell(get['default_peak'], 2)} | "
          f"{cell(get['residual'], 2)} / {cell(get['default_residual'], 2)} | "
          f"{cell(get['lps'], 0)} | "
          f"{cell(get['t_smooth'], 2)} | {cell(get['t_grid'], 2)} | "
          f"{cell(get['t_default'], 2)} |", flush=True)


if __name__ == '__main__':
    main()
