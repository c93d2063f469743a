"""
How much of the tool lines' time against TOPP-RA is the jerk limit (issue 38), one run.

``bench_tool_lines.py`` compares our tool lines (v/a/j limits) with dense IK
+ TOPP-RA (v/a, no jerk limit).  Arms without a limits file get a = 2 v and
j = 10 a there (``bench_arms``): a jerk ramp of 0.1 s, and a tool line stops
at every sharp corner of its seam, so each edge starts and ends with ramps
that TOPP-RA does not have.  Here the same random seams (fresh every run:
``bench_seeds``) are planned with the arm's jerk limits times
:data:`JERK_FACTORS`, without a tool speed limit; per arm and factor the
row gives, median / worst over the seams, each over dense IK + TOPP-RA's
duration:

* ours (``plan_tool_path``, method 555 optimal, 1 mm / 1 degree);
* TOPP-RA along our own joint path (``own_path``; v/a, no jerk);
* the fastest v/a profile along the joint path our construction timed
  (:mod:`planning.speed_profile.path_velocity`, with its stops at the corners): what a
  plan with no jerk limit could reach on it;
* the 4 Hz shaking peak of ours over TOPP-RA's;
* ``speed_profile='time_optimal'`` (the third-order profile, issue 38),
  and its 4 Hz shaking peak over TOPP-RA's, with a last row per arm with no
  jerk limit at all, time_optimal only (the default construction needs one).

If ours comes down towards the v/a profile as the jerk limit grows, the gap
at the arm's own limits is the price of the jerk limit, not of the speed
profile.  The time_optimal column does so monotonically: its profile is
optimal for the limits it is given (within about 1 %).

Usage: ``python benchmarks/bench_tool_jerk.py`` (``SPLINES445_BENCH_SEED``
repeats a run, ``SPLINES445_BENCH_CASES`` sets the seams per arm, default 2;
``SPLINES445_BENCH_ARMS=xArm7,Z1`` only those arms).
"""

import os

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_arms  # noqa: E402, I100
import bench_seeds  # noqa: E402
import bench_tool_lines as lines  # noqa: E402
import numpy as np  # noqa: E402
import own_path  # noqa: E402
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.cartesian import tool_lines  # noqa: E402
from splines445_ros.cartesian.tool_paths import plan_tool_path  # noqa: E402
from splines445_ros.planning.constraints import JointAcceleration, JointVelocity  # noqa: E402
from splines445_ros.planning.speed_profile.path_velocity import (  # noqa: E402
    PathLimits, traversal_times)
from splines445_ros.planning.spline.limits import JointLimits  # noqa: E402
from splines445_ros.tools import robot_seam_demo as rsd  # noqa: E402

JERK_FACTORS = (1.0, 2.0, 5.0, np.inf)   # inf: no jerk limit (time_optimal only)
SEAMS = 2


class TimedPaths:
    """Wraps ``tool_lines.plan_along_path`` to keep the last joint path it timed."""

    def __init__(self):
        self.last = None
        self._plan = tool_lines.plan_along_path

    def __call__(self, path, *args, **kwargs):
        """Remember ``path`` and time it."""
        self.last = path
        return self._plan(path, *args, **kwargs)


def fastest_profile(path, limits):
    """Duration of the fastest v/a profile along a timed ``JointPathSamples``, its stops kept."""
    profile = PathLimits(path.gridded, (JointVelocity(limits.velocity),
                                        JointAcceleration(limits.acceleration)))
    profile.stop_at(path.stops)
    x = profile.profile(np.ones(path.s.size))
    return float(traversal_times(x, path.steps)[-1])


def seam_row(arm, poses, factor, timed):
    """
    Return [ours, own, v/a profile, 4 Hz peak, time_optimal, its 4 Hz peak] / TOPP-RA's.

    Of a seam and jerk factor.  With no jerk limit (``factor`` inf) only
    time_optimal's (the others nan).
    """
    kin = arm.kinematics()
    limits = dict(arm.plan_limits())
    limits['max_jerk'] = np.asarray(limits['max_jerk'], float) * factor
    s, samples, _ = lines.dense_lines(poses)
    joints = np.asarray(arm.kinematics().inverse(samples), float)
    top = lines.toppra_plan(s, joints, kin, arm.velocity, arm.acceleration, None)[0]

    def planned(**more):
        traj = plan_tool_path(poses, arm.kinematics(), rsd.TOLERANCE, rsd.ANGLE_TOLERANCE,
                              max_inserted=rsd.SEAM_MAX_INSERTED, method='555',
                              timing='optimal', **limits, **more).trajectory
        if not traj.within_limits(rtol=1e-9):
            raise AssertionError(f'{arm.name}: a plan beyond its limits')
        return traj

    reference = shaking_figures(of_toppra(top), top.duration, arm.acceleration)
    fastest = planned(speed_profile='time_optimal')
    optimal = [fastest.duration / top.duration,
               shaking_ratios(fastest, reference, arm.acceleration)[0]]
    if np.isinf(factor):
        return [np.nan] * 4 + optimal
    traj = planned()
    own_s, own_q = own_path.arc_length_samples(traj)
    own = lines.toppra_plan(own_s, own_q, kin, arm.velocity, arm.acceleration, None)[0]
    joint_limits = JointLimits.from_user(kin.n_joints, limits['max_velocity'],
                                         limits['max_acceleration'], limits['max_jerk'])
    bound = fastest_profile(timed.last, joint_limits)
    peak = shaking_ratios(traj, reference, arm.acceleration)[0]
    return [traj.duration / top.duration, own.duration / top.duration,
            bound / top.duration, peak] + optimal


def main():
    """Plan every arm's seams at every jerk factor and print the table."""
    seed, count, arms = bench_arms.start_run(SEAMS)
    timed = TimedPaths()
    tool_lines.plan_along_path = timed
    print(f'{count} random seams per arm and the demo seam on the UR5 and Panda (seed '
          f'{seed}, stream: the CRC of the arm name, as bench_tool_lines draws them), no tool '
          'speed '
          'limit; each over dense IK + TOPP-RA (v/a, no jerk); median / worst')
    print("| arm | j / arm's j | j / a | ours | TOPP-RA along our path | v/a profile along "
          'our path | 4 Hz peak | time_optimal | its 4 Hz peak |')
    print('|---|---|---|---|---|---|---|---|---|')
    for arm in arms:
        ratio = float(np.median(np.asarray(arm.plan_limits()['max_jerk'], float)
                                / np.asarray(arm.plan_limits()['max_acceleration'], float)))
        # The arm's own stream: a seed repeats its seams whichever arms run with it.
        own = bench_seeds.generator(arm.stream)
        seams = [poses for _, poses in lines.seams(arm, own, count)]
        for factor in JERK_FACTORS:
            rows = []
            for poses in seams:
                try:
                    rows.append(seam_row(arm, poses, factor, timed))
                except (ValueError, RuntimeError) as exc:
                    print(f'{arm.name}: a seam failed at j x {factor:g}: '
                          f'{str(exc).splitlines()[0][:120]}')
            if not rows:
                continue
            rows = np.array(rows)
            if np.isinf(factor):
                cells = ['-'] * 4
            else:
                cells = [f'{np.median(rows[:, k]):.3f} / {np.max(rows[:, k]):.3f}'
                         for k in range(3)] + [f'{np.median(rows[:, 3]):.2f}']
            cells += [f'{np.median(rows[:, 4]):.3f} / {np.max(rows[:, 4]):.3f}',
                      f'{np.median(rows[:, 5]):.2f}']
            print(f'| {arm.name} | {factor:g} | {ratio * factor:.0f} | ' + ' | '.join(cells)
                  + ' |', flush=True)


if __name__ == '__main__':
    main()
