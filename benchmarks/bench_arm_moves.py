"""
Joint moves on every vendor arm (issue 38): plan()'s default against TOPP-RA, one run.

``bench_inner_knots.py`` draws joints and limits at random; a target there
holds only if it holds on real arms too.  Here, on every 6-7-joint arm of
example-robot-data (``bench_arms.py``: the skipped URDFs are listed with
their reasons), random joint paths (fresh every run, the seed printed
first: ``bench_seeds.py``; :func:`bench_torque.random_path`: 5 to 30
waypoints, a random walk from the ready pose with steps uniform in
+-0.3 rad per joint, clipped to the joint ranges less 0.05 rad) are planned
with the arm's own limits (velocity from the URDF, acceleration and jerk
from its limits file where it has one, else ``bench_arms``' ratios a = 2 v,
j = 10 a), no torque limit:

* ours: ``plan(points, '555', 'optimal', **arm.plan_limits())``, the
  default (inner knots, smoothing windows); the same with
  ``vibration_frequency=4``; and with ``speed_profile='time_optimal'``
  (``planning/path_following/time_optimal.py``: the third-order profile followed by a C4
  spline), also with ``vibration_frequency=4`` (the mode's ringing after
  the stop cancelled by the profile, ``planning/speed_profile/residual_vibration.py``);
* TOPP-RA: as in ``bench_inner_knots`` (``bench_planning.toppra_trajectory``:
  toppra's chord spline through the waypoints, v/a, its default grid; no
  jerk limit).

Every row gives the figures of ``bench_figures.py`` (duration, duration over
TOPP-RA along our own path, that one over TOPP-RA, shaking at 4 and 8 Hz
peak and residual, planning time; each over TOPP-RA's on the same path),
median / worst over the arm's paths, and whether the plan held every limit
on all of them.  Planning times: each plan and TOPP-RA in turn, best of
:data:`REPEATS` each (``wall_time.timed_against``: each ratio's two times
from the same rounds).  Then, per arm, what a speed
profile alone could reach on the path the construction starts from
(:func:`profile_bounds`: the natural cubic through the waypoints at their
rest-to-rest times, step 1 of ``planning/path_following/inner_knots.py``), over TOPP-RA's
duration: the fastest v/a profile (``planning/speed_profile/path_velocity.py``), and the
fastest v/a/j one that the sequential LPs of ``planning/speed_profile/jerk_profile.py``
find (their jerk rows are conservative: a profile that holds the jerk
limits on the grid, not a lower bound).  Their ratio is the price of the
jerk limit on that path; our duration over the v/a/j one is what the
spline and its rounds give away beyond it.  Paths where the sequential LPs
find no v/a/j profile are left out of its columns, and counted.

Usage: ``python benchmarks/bench_arm_moves.py``; ``SPLINES445_BENCH_SEED``
repeats a run, ``SPLINES445_BENCH_CASES`` sets the paths per arm,
``SPLINES445_BENCH_ARMS=UR5,Panda`` only those arms.
"""

import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_arms  # noqa: E402, I100
import bench_figures  # noqa: E402
from bench_planning import toppra_trajectory  # noqa: E402
from bench_torque import arm_paths  # noqa: E402
import numpy as np  # noqa: E402, I100
import own_path  # noqa: E402, I100
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.constraints import (  # noqa: E402
    GriddedPath, JointAcceleration, JointJerk, JointVelocity)
from splines445_ros.planning.durations.timing import rest_to_rest_durations  # noqa: E402
from splines445_ros.planning.path_following.inner_knots import first_path, GRID_STEPS  # noqa: E402
from splines445_ros.planning.speed_profile.jerk_profile import ThirdOrderProfile  # noqa: E402
from splines445_ros.planning.speed_profile.path_velocity import (  # noqa: E402
    PathLimits, traversal_times)
from splines445_ros.planning.spline.limits import JointLimits  # noqa: E402
from wall_time import timed_against  # noqa: E402

CASES = 10
REPEATS = 3
VIBRATION_FREQUENCY = 4.0           # [Hz] the second plan's vibration_frequency
PLANS = ('default', f'vibration_frequency={VIBRATION_FREQUENCY:g}',
         'speed_profile=time_optimal',
         f'speed_profile=time_optimal, vibration_frequency={VIBRATION_FREQUENCY:g}')


def construction_path(knots, points, steps=GRID_STEPS):
    """
    Return (q(s), s): the natural cubic through ``points`` at ``knots``, and its grid.

    Step 1's path of ``planning/path_following/inner_knots.py`` when ``knots`` are the
    cumulative rest-to-rest times (:func:`rest_to_rest_knots`); the grid has
    ``steps`` steps per segment (``inner_knots.GRID_STEPS``): plan()'s
    own :func:`inner_knots.first_path`, rest to rest.
    """
    rest = (np.zeros(points.shape[1]),) * 4
    return first_path(points, np.diff(knots), rest, steps)


def rest_to_rest_knots(points, limits):
    """Return the knots (N,) of step 1's path: the cumulative rest-to-rest times of ``limits``."""
    return np.concatenate([[0.0], np.cumsum(rest_to_rest_durations(points, limits))])


def profile_bounds(path, s, limits):
    """
    Return the durations [s] of the fastest v/a and v/a/j profiles along ``path`` on ``s``.

    ``path`` and ``s`` from :func:`construction_path` (step 1's path),
    ``limits`` a JointLimits; rest to rest.
    """
    gridded = GriddedPath.of_ppoly(path, s, third=True)
    constraints = (JointVelocity(limits.velocity), JointAcceleration(limits.acceleration))
    ones = np.ones(s.size)
    second = PathLimits(gridded, constraints).profile(ones)
    third = ThirdOrderProfile(gridded, constraints + (JointJerk(limits.jerk),)).profile(
        ones, second)
    steps = np.diff(s)
    return (traversal_times(second, steps)[-1],
            np.nan if third is None else traversal_times(third, steps)[-1])


def run_case(arm, points):
    """Return {plan name: figures} and {plan name: whether it held its limits}, on one path."""
    limits = arm.plan_limits()
    vmax, amax = limits['max_velocity'], limits['max_acceleration']
    options = ({}, {'vibration_frequency': VIBRATION_FREQUENCY},
               {'speed_profile': 'time_optimal'},
               {'speed_profile': 'time_optimal', 'vibration_frequency': VIBRATION_FREQUENCY})
    timed = {name: timed_against(lambda: toppra_trajectory(points, vmax, amax),
                                 lambda: plan(points, '555', 'optimal', **more, **limits),
                                 REPEATS)
             for name, more in zip(PLANS, options)}
    top = timed[PLANS[0]][0][1]
    ours = timed[PLANS[0]][1][1]
    reference = shaking_figures(of_toppra(top), top.duration, amax)
    joint = JointLimits.from_user(points.shape[1], vmax, amax, limits['max_jerk'])
    bounds = np.array(profile_bounds(
        *construction_path(rest_to_rest_knots(points, joint), points), joint))
    figures, held = {'bounds': list(bounds / top.duration) + [ours.duration / bounds[1]]}, {}
    for name, ((t_top, _), (elapsed, traj)) in timed.items():
        own = own_path.toppra_along(traj, own_path.velocity_acceleration(vmax, amax))
        figures[name] = bench_figures.figures(traj.duration, own.duration, top.duration,
                                              shaking_ratios(traj, reference, amax), elapsed,
                                              t_top)
        held[name] = traj.within_limits(rtol=1e-9)
    return figures, held


def main():
    """Run every arm and print the tables."""
    seed, cases, arms = bench_arms.start_run(CASES)
    print(f"{cases} random joint paths per arm (seed {seed}, the arm's stream), the arm's "
          'v/a/j limits, no torque; each plan over TOPP-RA (v/a, no jerk) on the same path; '
          f'planning times best of {REPEATS}, each plan and TOPP-RA in turn; median / worst')
    print('| arm | j / a | plan | ' + bench_figures.header() + ' | limits held (every path) |')
    print(bench_figures.rule(4 + len(bench_figures.NAMES)))
    bounds = {}
    for arm in arms:
        paths = arm_paths(arm, cases)
        rows = {name: [] for name in PLANS + ('bounds',)}
        held = dict.fromkeys(PLANS, True)
        for points in paths:
            figures, ok = run_case(arm, points)
            for name in PLANS:
                held[name] &= ok[name]
            for name in rows:
                rows[name].append(figures[name])
        bounds[arm.name] = np.array(rows['bounds'])
        ratio = np.median(arm.jerk / arm.acceleration)
        for name in PLANS:
            print(f'| {arm.name} | {ratio:g} | {name} | {bench_figures.summary(rows[name])} '
                  f'| {held[name]} |')
        sys.stdout.flush()
    print()
    print("Speed profiles alone on the construction's first path (the natural cubic at the "
          'rest-to-rest times), median / worst over the paths: ÷ TOPP-RA, and the default ÷ '
          'the v/a/j profile')
    print('| arm | v/a profile ÷ TOPP-RA | v/a/j profile ÷ TOPP-RA | v/a/j ÷ v/a (the jerk '
          'limit) | default ÷ v/a/j profile | paths without a v/a/j profile (left out) |')
    print(bench_figures.rule(6))
    for name, rows in bounds.items():
        cells = [f'{np.nanmedian(rows[:, k]):.3f} / {np.nanmax(rows[:, k]):.3f}'
                 for k in range(2)]
        price = rows[:, 1] / rows[:, 0]
        cells.append(f'{np.nanmedian(price):.3f} / {np.nanmax(price):.3f}')
        cells.append(f'{np.nanmedian(rows[:, 2]):.3f} / {np.nanmax(rows[:, 2]):.3f}')
        cells.append(f'{int(np.sum(np.isnan(rows[:, 1])))} of {len(rows)}')
        print(f'| {name} | ' + ' | '.join(cells) + ' |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
