"""
Torque limits with and without the smoothing windows (issue 25 against issue 23), one run.

plan()'s ``smoothing`` "auto" (the default) leaves a torque-limited
rest-to-rest profile without the windows of
``plan_options.DEFAULT_SMOOTHING`` (0.3 s and 0.15 s, issue 23's
smoothness, about 0.45 s a move); "windows" keeps them. On
bench_torque.py's 0.5-3 s moves that is most of the distance to issue 25's
duration target, and this bench measures what the windows buy: on
bench_torque.py's paths, limits and jerk (its functions, its seed and arms'
paths, the UR5 and the Panda unless ``SPLINES445_BENCH_ARMS`` names others,
the same paths for both payloads), every path is planned three ways:
plan()'s default, ``smoothing="windows"``, and ``inner_knots=0`` (knots at
the waypoints only, slowed down uniformly for the torque). Per robot and
payload the medians of the duration and of the shaking of a lightly damped
4 and 8 Hz mode (``shaking.py``: peak while moving, residual after the
end), each divided by TOPP-RA's (torque and velocity limits, its own path),
and how often a knots-only rival decided the plan.

Usage: ``python benchmarks/bench_torque_windows.py`` (about 4 minutes).
"""

import logging
import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_arms  # noqa: E402, I100
import bench_seeds  # noqa: E402
import bench_torque as bt  # noqa: E402
import numpy as np  # noqa: E402, I100
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.robot.dynamics import ArmDynamics  # noqa: E402

PLANS = ('default', 'smoothing=windows', 'inner_knots=0')
ARMS = 'UR5,Panda'      # unless SPLINES445_BENCH_ARMS names others


def planned(points, kwargs, how):
    """Return the plan of ``points`` the way ``how`` names (one of :data:`PLANS`)."""
    if how == 'inner_knots=0':
        return plan(points, '555', 'optimal', inner_knots=0, **kwargs)
    if how == 'default':
        return plan(points, '555', 'optimal', **kwargs)
    return plan(points, '555', 'optimal', smoothing='windows', **kwargs)


def main():
    """Plan every path three ways and print the medians per robot and payload."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    seed = bench_seeds.run_seed()
    cases = bench_seeds.case_count(bt.CASES)
    arms, _ = bench_arms.vendor_arms(os.environ.get('SPLINES445_BENCH_ARMS') or ARMS)
    print(f'Command: {bench_seeds.VARIABLE}={seed} python benchmarks/bench_torque_windows.py')
    print(f"Settings: bench_torque.py's (seed {seed}, {cases} paths per robot, jerk "
          f"{bt.JERK_RATIO:g} times each joint's peak acceleration in TOPP-RA's plan); "
          'ratios ours / TOPP-RA, medians; rival: paths where the knots-only plan was '
          'returned.')
    print()
    print('| robot | payload [kg] | plan | duration | 4 Hz peak | 4 Hz residual | 8 Hz peak '
          '| 8 Hz residual | rival decided |')
    print('|' + '---|' * 9)
    for arm in arms:
        name, robot, joints, tool = arm.name, arm.robot, arm.joints, arm.tool
        _, _, vmax, tau_max = bt.joint_limits(robot, joints)
        paths = bt.arm_paths(arm, cases)
        rated, _ = bt.bench_payload(arm, paths)
        n = len(joints)
        for payload in (0.0, rated):
            dynamics = ArmDynamics(robot, joints, tool, payload_mass=payload,
                                   payload_center_of_mass=bt.PAYLOAD_OFFSET)
            rows = {how: [] for how in PLANS}
            for points in paths:
                top = bt.toppra_torque(points, vmax, tau_max, dynamics.torques)
                if top is None:
                    continue    # no plan along this path (bench_torque.py lists it)
                kwargs = {'max_velocity': vmax,
                          'max_acceleration': np.full(n, bt.NO_ACCELERATION_LIMIT),
                          'max_jerk': bt.JERK_RATIO * bt.typical_accelerations(top),
                          'max_torque': tau_max, 'inverse_dynamics': dynamics.torques}
                # The ratios do not depend on the common scale of the accelerations.
                reference = shaking_figures(of_toppra(top), top.duration, np.ones(n))
                for how in PLANS:
                    traj = planned(points, kwargs, how)
                    rival = traj.optimizer.get('inner_knots', 0) == 0
                    rows[how].append([traj.duration / top.duration]
                                     + shaking_ratios(traj, reference, np.ones(n))
                                     + [rival])
            for how in PLANS:
                figures = np.array(rows[how], float)
                median = np.median(figures[:, :5], axis=0)
                decided = '-' if how == 'inner_knots=0' else f'{int(figures[:, 5].sum())}'
                print(f'| {name} | {payload:.2f} | {how} | {median[0]:.3f} | '
                      + ' | '.join(f'{value:.2f}' for value in median[1:])
                      + f' | {decided} |')
                sys.stdout.flush()
    return 0


if __name__ == '__main__':
    sys.exit(main())
