"""
Near-duplicate waypoints next to a rest end: durations and excursions (issue 18).

The replanning case: the arm's measured pose plus noise, then the commanded
pose, then two goals ([q0 + e u, q0, g1, g2], v <= 2, a <= 10; u a random
unit vector, g1 and g2 a random walk from q0).  Printed for every method and
timing, with the default waypoint tolerance and with 0 (no merging: what
plan() did before), next to the plan without the near-duplicate.  Then the
teach-pendant case: a copy of the first waypoint of a random 5-point path,
offset along a random unit vector by 1e-12 to 1e-2, 555 optimal.

Fresh random cases every run (``bench_seeds``: the seed is printed, and
``SPLINES445_BENCH_SEED=<seed>`` repeats a run).

Run: ``python benchmarks/bench_near_duplicates.py`` (part of ``make bench``).
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bench_seeds  # noqa: E402, I100
from splines445_ros.planning import DEFAULT_WAYPOINT_TOLERANCE, plan  # noqa: E402

LIMITS = {'max_velocity': [2.0] * 3, 'max_acceleration': [10.0] * 3}
BASE_LIMITS = {'max_velocity': [1.0, 2.0, 1.5], 'max_acceleration': [3.0, 2.0, 4.0]}
# bench_seeds streams of the two tables.
REPLANNING_STREAM, OFFSETS_STREAM = 0, 1


def unit_vector(rng):
    """Return a random unit vector of 3 joints."""
    u = rng.normal(size=3)
    return u / np.linalg.norm(u)


def excursion(traj):
    """Largest distance beyond the waypoints' range over all joints [rad]."""
    return float(np.max(traj.excursion()))


def replanning_table():
    print('| noise | method | timing | tolerance 0: duration [s] | excursion [rad] | '
          f'tolerance {DEFAULT_WAYPOINT_TOLERANCE:g}: duration [s] | excursion [rad] | '
          'without the near-duplicate [s] |')
    print('|---|---|---|---|---|---|---|---|')
    rng = bench_seeds.generator(REPLANNING_STREAM)
    goals = np.cumsum(np.vstack([np.zeros(3), rng.uniform(-1.0, 1.0, (2, 3))]), axis=0)
    for noise in (1e-4, 1e-5):
        noisy = np.vstack([goals[0] + noise * unit_vector(rng), goals])
        for method in ('445', '555', '434'):
            for timing in ('uniform', 'optimal'):
                old = plan(noisy, method, timing, waypoint_tolerance=0.0, **LIMITS)
                new = plan(noisy, method, timing, **LIMITS)
                clean = plan(goals, method, timing, **LIMITS)
                print(f'| {noise:g} | {method} | {timing} | {old.duration:.4g} | '
                      f'{excursion(old):.3g} | {new.duration:.4g} | {excursion(new):.3g} | '
                      f'{clean.duration:.4g} |')


def offsets_table():
    rng = bench_seeds.generator(OFFSETS_STREAM)
    base = np.cumsum(rng.uniform(-1.0, 1.0, (5, 3)), axis=0)
    direction = unit_vector(rng)
    clean = plan(base, '555', 'optimal', **BASE_LIMITS).duration
    print(f'\n555 optimal, copy of the first waypoint inserted after it (without: '
          f'{clean:.4f} s)\n')
    print('| offset | duration [s] | ratio | merged | excursion [rad] |')
    print('|---|---|---|---|---|')
    for offset in (1e-12, 1e-6, 1e-4, 1e-3, 2e-3, 1e-2):
        points = np.insert(base, 1, base[0] + offset * direction, axis=0)
        traj = plan(points, '555', 'optimal', **BASE_LIMITS)
        print(f'| {offset:g} | {traj.duration:.4f} | {traj.duration / clean:.3f} | '
              f'{bool(traj.dropped_waypoints)} | {excursion(traj):.3g} |')


if __name__ == '__main__':
    bench_seeds.run_seed()  # the seed line first
    replanning_table()
    offsets_table()
