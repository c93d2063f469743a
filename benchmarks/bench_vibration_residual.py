"""
``vibration_frequency`` with ``speed_profile='time_optimal'``: the ringing left after the stop.

Random rest-to-rest requests (``bench_inner_knots.random_case``, fresh
every run, the seed printed first; j = 20 a), at mode frequencies
:data:`FREQUENCIES`.  For each: TOPP-RA (v/a, its chord spline); time_optimal
without and with ``vibration_frequency=f`` (its profile cancels the mode's
ringing, ``planning/speed_profile/residual_vibration.py``); the default construction
with ``vibration_frequency=f`` (its two windows of ``1 / f``, and its knots
moved to cancel the ringing, ``planning/path_following/residual_knots.py``),
and the same without that move (the plan before it).  Columns, median /
worst over the requests, each over TOPP-RA's on the same request:

* duration;
* the peak at ``f`` (the largest deflection during the motion);
* the residual at ``f`` (``shaking.py``: a damped oscillator at ``f``,
  damping 0.02 as the cancellation assumes, the largest ringing over two
  periods after the stop);
* the same residual for a mode the user mis-measured: at 0.9 f and 1.1 f,
  and at ``f`` with damping 0.01 and 0.05 (a cancellation is narrow);
* the residual at ``2 f`` (a harmonic);
* planning time (each plan and TOPP-RA on the same request in turn, best
  of 3 each: ``wall_time.timed_against``).

Usage: ``python benchmarks/bench_vibration_residual.py``;
``SPLINES445_BENCH_SEED=<seed>`` repeats a run,
``SPLINES445_BENCH_CASES=<count>`` draws another number of requests.
"""

from functools import partial
import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_inner_knots import random_case  # noqa: E402
from bench_planning import toppra_trajectory  # noqa: E402
import bench_seeds  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
from shaking import of_toppra, of_trajectory, shaking  # noqa: E402
from splines445_ros.planning import plan, planner  # noqa: E402
from wall_time import timed_against  # noqa: E402

N_CASES = 12
FREQUENCIES = (1.5, 4.0, 8.0)
JERK_RATIO = 20.0
# The mode as the plan assumes it, and as it may really be: (frequency share, damping).
MODES = ((1.0, 0.02), (0.9, 0.02), (1.1, 0.02), (1.0, 0.01), (1.0, 0.05), (2.0, 0.02))
PLANS = ('time_optimal', 'time_optimal, vibration_frequency=f', 'default, vibration_frequency=f',
         'the same, knots not moved')
CASES_STREAM = 3


def residuals(acceleration_of, duration, amax, frequency):
    """``shaking.shaking``'s peak at ``frequency``, and its residual for each of :data:`MODES`."""
    peak = shaking(acceleration_of, duration, amax, frequency)[0]
    return np.array([peak] + [shaking(acceleration_of, duration, amax, share * frequency,
                                      zeta=damping)[1] for share, damping in MODES])


def unmoved(waypoints, frequency, limits):
    """Return the default's plan with ``vibration_frequency``, its knots not moved."""
    keep = planner._with_ringing_cancelled
    planner._with_ringing_cancelled = lambda refined, options: refined
    try:
        return plan(waypoints, '555', 'optimal', vibration_frequency=frequency, **limits)
    finally:
        planner._with_ringing_cancelled = keep


def main():
    """Print one table per frequency."""
    rng = bench_seeds.generator(CASES_STREAM)
    cases = [random_case(rng) for _ in range(bench_seeds.case_count(N_CASES))]
    print(f'{len(cases)} random requests (bench_inner_knots.random_case), j = {JERK_RATIO:g} a; '
          'each figure over TOPP-RA on the same request, median / worst')
    for frequency in FREQUENCIES:
        print()
        print(f'Mode at f = {frequency:g} Hz')
        names = ['at f', 'at 0.9 f', 'at 1.1 f', 'damping 0.01', 'damping 0.05', 'at 2 f']
        print('| plan | duration | peak at f | ' + ' | '.join(f'residual {n}' for n in names)
              + ' | planning | time_optimal |')
        print('|' + '---|' * (len(names) + 5))
        rows = {name: [] for name in PLANS}
        followed = dict.fromkeys(PLANS, 0)
        for waypoints, vmax, amax in cases:
            rival = partial(toppra_trajectory, waypoints, vmax, amax)
            top = rival()
            reference = residuals(of_toppra(top), top.duration, amax, frequency)
            limits = {'max_velocity': vmax, 'max_acceleration': amax,
                      'max_jerk': JERK_RATIO * amax}
            plans = (
                timed_against(rival, lambda: plan(waypoints, '555', 'optimal',
                                                  speed_profile='time_optimal', **limits)),
                timed_against(rival, lambda: plan(waypoints, '555', 'optimal',
                                                  speed_profile='time_optimal',
                                                  vibration_frequency=frequency, **limits)),
                timed_against(rival, lambda: plan(waypoints, '555', 'optimal',
                                                  vibration_frequency=frequency, **limits)),
                timed_against(rival, lambda: unmoved(waypoints, frequency, limits)))
            for name, ((t_top, _), (elapsed, traj)) in zip(PLANS, plans):
                ours = residuals(of_trajectory(traj), traj.duration, amax, frequency)
                rows[name].append([traj.duration / top.duration] + list(ours / reference)
                                  + [elapsed / t_top])
                followed[name] += traj.optimizer.get('speed_profile') == 'time_optimal'
        for name in PLANS:
            values = np.array(rows[name])
            cells = [f'{np.median(values[:, k]):.3f} / {np.max(values[:, k]):.3f}'
                     if k == 0 else f'{np.median(values[:, k]):.2f} / {np.max(values[:, k]):.2f}'
                     for k in range(values.shape[1])]
            print(f'| {name} | ' + ' | '.join(cells) + f' | {followed[name]} of {len(cases)} |')
        sys.stdout.flush()
    return 0


if __name__ == '__main__':
    sys.exit(main())
