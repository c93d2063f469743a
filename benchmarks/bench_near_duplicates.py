"""
Near-duplicate waypoints next to a rest end: durations and excursions (issue 18).

The replanning case: the arm's measured pose plus noise, then the commanded
pose, then the goal ([q0 + e (1, -1, 0.5), q0, (0.5, 1, -0.5), (1, 0.5, 0)],
v <= 2, a <= 10).  Printed for every method and timing, with the default
waypoint tolerance and with 0 (no merging: what plan() did before), next to
the plan without the near-duplicate.  Then the teach-pendant case: a copy of
the first waypoint of a 5-point path, offset from 1e-12 to 1e-2, 555 optimal.

Run: ``python benchmarks/bench_near_duplicates.py`` (part of ``make bench``).
"""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from splines445_ros.planning import DEFAULT_WAYPOINT_TOLERANCE, plan  # noqa: E402

LIMITS = {'max_velocity': [2.0] * 3, 'max_acceleration': [10.0] * 3}
GOALS = np.array([[0.0, 0.0, 0.0], [0.5, 1.0, -0.5], [1.0, 0.5, 0.0]])
BASE = np.array([[0, 0, 0], [1, .5, -.3], [2, -.5, .2], [2.5, 0, 1], [3, 1, 0]], dtype=float)
BASE_LIMITS = {'max_velocity': [1.0, 2.0, 1.5], 'max_acceleration': [3.0, 2.0, 4.0]}


def excursion(traj):
    """Largest distance beyond the waypoints' range over all joints [rad]."""
    return float(np.max(traj.excursion()))


def replanning_table():
    print('| noise | method | timing | tolerance 0: duration [s] | excursion [rad] | '
          f'tolerance {DEFAULT_WAYPOINT_TOLERANCE:g}: duration [s] | excursion [rad] | '
          'without the near-duplicate [s] |')
    print('|---|---|---|---|---|---|---|---|')
    for noise in (1e-4, 1e-5):
        noisy = np.vstack([GOALS[0] + noise * np.array([1.0, -1.0, 0.5]), GOALS])
        for method in ('445', '555', '434'):
            for timing in ('uniform', 'optimal'):
                old = plan(noisy, method, timing, waypoint_tolerance=0.0, **LIMITS)
                new = plan(noisy, method, timing, **LIMITS)
                clean = plan(GOALS, method, timing, **LIMITS)
                print(f'| {noise:g} | {method} | {timing} | {old.duration:.4g} | '
                      f'{excursion(old):.3g} | {new.duration:.4g} | {excursion(new):.3g} | '
                      f'{clean.duration:.4g} |')


def offsets_table():
    clean = plan(BASE, '555', 'optimal', **BASE_LIMITS).duration
    print(f'\n555 optimal, copy of the first waypoint inserted after it (without: '
          f'{clean:.4f} s)\n')
    print('| offset | duration [s] | ratio | merged | excursion [rad] |')
    print('|---|---|---|---|---|')
    for offset in (1e-12, 1e-6, 1e-4, 1e-3, 2e-3, 1e-2):
        points = np.insert(BASE, 1, BASE[0] + offset, axis=0)
        traj = plan(points, '555', 'optimal', **BASE_LIMITS)
        print(f'| {offset:g} | {traj.duration:.4f} | {traj.duration / clean:.3f} | '
              f'{bool(traj.dropped_waypoints)} | {excursion(traj):.3g} |')


if __name__ == '__main__':
    replanning_table()
    offsets_table()
