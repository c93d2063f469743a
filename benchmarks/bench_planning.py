"""
Planning-time benchmark: 445/434/555 uniform timing against scipy and TOPP-RA.

Prints a table of planning times (best of several runs, all in this one run,
so the ratios compare like with like on a noisy machine) for random
rest-to-rest requests of 12x3, 100x7, 1000x7 and 10000x7 waypoints x joints
(v <= 2, a <= 10 per joint, a fresh seed every run, printed: bench_seeds.py):

* 445, 434 and 555 with timing="uniform" (plan() from the waypoints to a
  PPoly, limits met exactly), and the durations they reach;
* scipy.interpolate.CubicSpline fitted to the same waypoints over chord
  length (a fit only: no timing, no limits) - the floor of what any spline
  fit costs;
* TOPP-RA (toppra, time-optimal path parameterisation with the same v/a
  limits along its chord spline: its cubic spline through the same
  waypoints against their normalised chord length,
  ``own_path.chord_spline``); skipped at 10000x7 unless
  SPLINES445_BENCH_FULL=1 (it takes about half a minute there).

Every planner of a size is called in turn, the same number of rounds
(``wall_time.interleaved_best_of``), toppra imported before any is timed.

Then, on the same requests, every uniform timing's duration and oscillator
shaking (4 and 8 Hz, peak while moving and residual after the end,
``shaking.py``) over TOPP-RA's: a faster plan is only better if it is not
rougher.  Also the paper's example (12x3 with its non-zero boundary values).
"""

import logging
import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_seeds  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
import own_path  # noqa: E402, I100
from scipy.interpolate import CubicSpline  # noqa: E402

from shaking import (of_toppra, of_trajectory, shaking_figures, shaking_header,  # noqa: E402
                     shaking_ratios)
from splines445_ros.planning import chord_durations, plan  # noqa: E402
from splines445_ros.robot import paper_example as pe  # noqa: E402
# toppra imported here, with this module: no timed call pays for the import.
import toppra  # noqa: E402, F401, I100
import toppra.algorithm  # noqa: E402, F401
import toppra.constraint  # noqa: E402, F401
from wall_time import best_of, interleaved_best_of  # noqa: E402

SIZES = ((12, 3), (100, 7), (1000, 7), (10000, 7))
METHODS = ('445', '434', '555')


def random_request(n_points, n_joints, rng):
    """Random-walk waypoints and the benchmark limits."""
    waypoints = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    return waypoints, np.full(n_joints, 2.0), np.full(n_joints, 10.0)


def toppra_plan(waypoints, vmax, amax):
    """TOPP-RA through the waypoints (its chord spline); returns its duration."""
    return toppra_trajectory(waypoints, vmax, amax).duration


def toppra_trajectory(waypoints, vmax, amax):
    """
    TOPP-RA through the waypoints with v/a limits (n,); returns its trajectory.

    Its chord spline (``own_path.chord_spline``: toppra's cubic spline
    through the waypoints against their cumulative chord length, normalised
    to [0, 1]; a waypoint coinciding with the one before it is merged into
    it), toppra's default grid, ``ParametrizeConstAccel``; RuntimeError when
    it finds no parametrisation.
    """
    return own_path.toppra_on(own_path.chord_spline(waypoints),
                              own_path.velocity_acceleration(vmax, amax))


def cubic_fit(waypoints):
    """Fit a CubicSpline over cumulative chord length (a fit: no timing)."""
    x = np.concatenate([[0.0], np.cumsum(chord_durations(waypoints))])
    return CubicSpline(x, waypoints, axis=0)


def main():
    """Run and print the table."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    full = os.environ.get('SPLINES445_BENCH_FULL') == '1'
    rng = bench_seeds.generator()
    print('Planning time, best of k runs [ms]; ratios from the same run.')
    print('| waypoints x joints | 445 uniform | 434 uniform | 555 uniform | CubicSpline fit '
          '| TOPP-RA | 555 / CubicSpline | TOPP-RA / 555 | 445 duration [s] '
          '| 434 duration [s] | 555 duration [s] | TOPP-RA duration [s] |')
    print('|' + '---|' * 12)
    shaking_rows = []
    for n_points, n_joints in SIZES:
        waypoints, vmax, amax = random_request(n_points, n_joints, rng)
        repeats = 50 if n_points <= 100 else (10 if n_points <= 1000 else 3)
        with_toppra = n_points <= 1000 or full
        calls = [lambda method=method: plan(waypoints, method, max_velocity=vmax,
                                            max_acceleration=amax) for method in METHODS]
        calls.append(lambda: cubic_fit(waypoints))
        if with_toppra:
            calls.append(lambda: toppra_trajectory(waypoints, vmax, amax))
        # Every call in turn, the same rounds: TOPP-RA's best of as many as ours.
        timed = interleaved_best_of(calls, repeats)
        times = {m: timed[k][0] for k, m in enumerate(METHODS)}
        trajs = {m: timed[k][1] for k, m in enumerate(METHODS)}
        tfit = timed[len(METHODS)][0]
        if with_toppra:
            ttop, reference = timed[-1]
            top = f'{1e3 * ttop:.1f}'
            top_ratio = f'{ttop / times["555"]:.0f}x'
            top_duration = f'{reference.duration:.2f}'
            figures = shaking_figures(of_toppra(reference), reference.duration, amax)
            shaking_rows.append((n_points, n_joints, {
                m: (trajs[m].duration / reference.duration,
                    shaking_ratios(trajs[m], figures, amax)) for m in METHODS}))
        else:
            top, top_ratio, top_duration = 'skipped', '-', '-'
        cells = ' | '.join(f'{1e3 * times[m]:.2f}' for m in METHODS)
        durations = ' | '.join(f'{trajs[m].duration:.2f}' for m in METHODS)
        print(f'| {n_points} x {n_joints} | {cells} | {1e3 * tfit:.2f} | {top} '
              f'| {times["555"] / tfit:.1f}x | {top_ratio} | {durations} | {top_duration} |')
        sys.stdout.flush()
    print('(The shaking beside these durations: the next table, on the requests TOPP-RA ran.)')
    print()
    print('Speed and shaking on the same requests: uniform timing / TOPP-RA (duration; a '
          'lightly damped mode on every joint, benchmarks/shaking.py)')
    print('| waypoints x joints | method | duration / TOPP-RA | ' + shaking_header() + ' |')
    print('|---|---|---|' + '---|' * 4)
    for n_points, n_joints, by_method in shaking_rows:
        for m, (ratio, shaking) in by_method.items():
            print(f'| {n_points} x {n_joints} | {m} uniform | {ratio:.3f} | '
                  + ' | '.join(f'{x:.2f}' for x in shaking) + ' |')
    kwargs = pe.plan_kwargs()
    waypoints = pe.joint_waypoints()
    print()
    print("Paper's example (12 x 3, non-zero boundary values, factor searched); shaking / "
          "434's (Ho and Cook's, the paper's baseline): " + shaking_header())
    found = {m: best_of(lambda method=m: plan(waypoints, method, **kwargs), 50)
             for m in METHODS}
    amax = np.asarray(kwargs['max_acceleration'], dtype=float)
    baseline = found['434'][1]
    reference = shaking_figures(of_trajectory(baseline), baseline.duration, amax)
    for method, (elapsed, traj) in found.items():
        shaking = ', '.join(f'{x:.2f}' for x in shaking_ratios(traj, reference, amax))
        print(f'  {method} uniform: {1e3 * elapsed:.2f} ms, duration {traj.duration:.4f} s, '
              f'shaking {shaking}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
