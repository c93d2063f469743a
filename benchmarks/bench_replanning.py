"""
Replanning from a moving arm: how often a state admits no plan, and the delay that costs.

The planner node replans from the state of the running trajectory at the
switch time; when no plan exists from that state it switches later along the
running trajectory (``nodes.request_planning.plan_from_running``).  This
counts, for every method and timing, the share of switch times (every
20 ms along the running trajectory) from which the planning core finds no
plan, and the switch delay the node's retry then takes (mean and worst),
and whether any switch time stays without a plan.

Cases: the paper's example running, a new goal of three waypoints
(``test_replanning.py``'s), v <= 2 rad/s, a <= 10 rad/s^2, no jerk limit;
and 6 random running paths (a fresh seed every run, printed: bench_seeds.py) with random new goals.

Then ``speed_profile='time_optimal'`` (issue 38): from the state of a
running time_optimal plan (j = 20 a) every :data:`OPTIMAL_STEP` along it,
555 optimal time_optimal to the new goal; the share of the states it
follows itself (the others get the default construction's plan, which says
why in ``speed_profile_skipped``), split by how close the state is to a
velocity or acceleration limit, the fallbacks' reasons, and the followed
plans' duration and 4 Hz shaking (``shaking.py``: peak while moving,
residual after the stop) over the default's from the same state.  Then
the same on every 6-7-joint arm of example-robot-data (``bench_arms.py``,
:data:`ARM_PATHS` of ``bench_torque``'s random paths per arm, their own
limits): the first half of a path running, the rest of it reversed as the
new goal.

Run: ``make bench`` or ``python benchmarks/bench_replanning.py [method ...]`` (the
methods' rows only; the optimal rows of 445 and 434 take many minutes).
"""

import os
import sys

import numpy as np

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_arms  # noqa: E402, I100
import bench_seeds  # noqa: E402
from bench_torque import arm_paths  # noqa: E402
from shaking import of_trajectory, shaking  # noqa: E402
from splines445_ros.nodes.ros_conversions import WaypointRequest  # noqa: E402, I100
from splines445_ros.planning import METHODS, plan  # noqa: E402
from splines445_ros.robot import paper_example as pe  # noqa: E402
from splines445_ros.service.planner_config import PlannerConfig  # noqa: E402
from splines445_ros.service.request_planning import plan_from_running  # noqa: E402

SECOND = np.array([[0.2, 2.0, -2.0], [0.6, 1.6, -2.2], [0.9, 1.2, -1.5]])
VMAX, AMAX = 2.0, 10.0
STEP = 0.02  # s between the switch times tried
OPTIMAL_STEP = 0.1  # s between the states of a running time_optimal plan replanned from
NEAR_LIMIT = 0.96   # a state this close to a velocity or acceleration limit counts as at it
SHAKING_FREQUENCY = 4.0     # Hz: the mode whose shaking is compared (shaking.py)
ARM_PATHS = 2       # per arm (SPLINES445_BENCH_CASES)
N_RANDOM = 6


def cases():
    """(name, running waypoints, new goal waypoints) of the paper and random paths."""
    yield 'paper', pe.joint_waypoints(), SECOND
    rng = bench_seeds.generator()
    for i in range(N_RANDOM):
        running = np.cumsum(rng.uniform(-0.8, 0.8, (int(rng.integers(4, 9)), 3)), axis=0)
        goal = running[-1] + np.cumsum(rng.uniform(-0.8, 0.8, (3, 3)), axis=0)
        yield f'random {i}', running, goal


def measure(method, timing, inner_knots, running_points, goal):
    """Return (switch times tried, times without a direct plan, delays, none planned)."""
    limits = {'max_velocity': [VMAX] * 3, 'max_acceleration': [AMAX] * 3}
    running = plan(running_points, method=method, timing=timing, **limits)
    config = PlannerConfig(max_velocity=(VMAX,) * 3, max_acceleration=(AMAX,) * 3,
                           max_jerk=(), method=method, timing=timing, inner_knots=inner_knots)
    zero = np.zeros(3)
    request = WaypointRequest(goal, zero, zero, zero, zero, None)
    times = np.arange(0.0, running.duration, STEP)
    stuck, delays, failed = 0, [], 0
    for t in times:
        try:
            used, _ = plan_from_running(config, request, running, float(t))
        except ValueError:
            failed += 1
            continue
        if used > t:
            stuck += 1
            delays.append(used - t)
    return len(times), stuck + failed, delays, failed


def main():
    """Print the table."""
    print(f'Replanning from a moving state: v <= {VMAX}, a <= {AMAX}, switch every '
          f'{STEP * 1e3:.0f} ms along the running trajectory')
    print('The running trajectory and the replan use the same method and timing; 555 '
          'optimal replans with inner knots (the default) and with inner_knots=0.')
    print('| method | timing | paths | states without a plan | retry delay mean / worst '
          '[s] | states never planned |')
    print('|---|---|---|---|---|---|')
    all_cases = list(cases())
    methods = sys.argv[1:] or METHODS
    rows = [(method, timing, None) for method in methods for timing in ('uniform', 'optimal')]
    if '555' in methods:
        rows.insert(rows.index(('555', 'optimal', None)) + 1, ('555', 'optimal', 0))
    for method, timing, inner_knots in rows:
        config_knots = PlannerConfig.inner_knots if inner_knots is None else inner_knots
        name = timing if inner_knots is None else f'{timing}, inner_knots=0'
        for subset, chosen in (('paper', all_cases[:1]), ('random', all_cases[1:])):
            tried, stuck, delays, failed = 0, 0, [], 0
            for _, running_points, goal in chosen:
                n, s, d, f = measure(method, timing, config_knots, running_points, goal)
                tried, stuck, failed = tried + n, stuck + s, failed + f
                delays += d
            delay = (f'{np.mean(delays):.3f} / {np.max(delays):.3f}' if delays else '-')
            print(f'| {method} | {name} | {subset} | {stuck} of {tried} '
                  f'({100.0 * stuck / tried:.1f}%) | {delay} | {failed} |')


def running_states(running):
    """Yield (q, qd, qdd) of the running plan ``running`` every :data:`OPTIMAL_STEP`."""
    for t in np.arange(0.5 * OPTIMAL_STEP, running.duration, OPTIMAL_STEP):
        yield tuple(running.evaluate(np.array([t]), k)[0] for k in range(3))


def at_limit(qd, qdd, vmax, amax):
    """Whether a state is at :data:`NEAR_LIMIT` of a velocity or acceleration limit."""
    return max(np.max(np.abs(qd) / vmax), np.max(np.abs(qdd) / amax)) >= NEAR_LIMIT


def refused_cell(refused, no_default):
    """
    Return the refused column's cell: states time_optimal refused (ValueError).

    Those are left out of every other column.  Followed states whose default
    plan raised (no ratio to it) are counted after them when there are any.
    """
    extra = f' (+ {no_default} followed, default refused: no ratio)' if no_default else ''
    return f'{refused}{extra}'


def time_optimal_replanning():
    """Print how often time_optimal follows its own plan from its running plan's states."""
    limits = {'max_velocity': [VMAX] * 3, 'max_acceleration': [AMAX] * 3,
              'max_jerk': [20.0 * AMAX] * 3}
    counts = {False: [0, 0], True: [0, 0]}     # at a limit: [states, followed]
    reasons, ratios, refused, no_default = {}, [], 0, 0
    for _, running_points, goal in cases():
        running = plan(running_points, '555', 'optimal', speed_profile='time_optimal', **limits)
        for q, qd, qdd in running_states(running):
            points = np.vstack([q, goal])
            boundary = {'start_velocity': qd, 'start_acceleration': qdd}
            try:
                ours = plan(points, '555', 'optimal', speed_profile='time_optimal',
                            **boundary, **limits)
            except ValueError:
                refused += 1
                continue
            near = at_limit(qd, qdd, VMAX, AMAX)
            counts[near][0] += 1
            why = ours.optimizer.get('speed_profile_skipped')
            if why:
                reasons[why] = reasons.get(why, 0) + 1
                continue
            counts[near][1] += 1
            try:
                default = plan(points, '555', 'optimal', **boundary, **limits)
            except ValueError:
                no_default += 1     # the default has no plan from this state; time_optimal has
                continue
            amax = np.full(3, AMAX)
            ratios.append([ours.duration / default.duration] + list(
                np.array(shaking(of_trajectory(ours), ours.duration, amax, SHAKING_FREQUENCY))
                / shaking(of_trajectory(default), default.duration, amax, SHAKING_FREQUENCY)))
    print()
    print(f"speed_profile='time_optimal' replanned from a running time_optimal plan's state "
          f'every {OPTIMAL_STEP * 1e3:.0f} ms (paper and random paths, j = 20 a):')
    print(f'| states | followed | at >= {NEAR_LIMIT:g} of a v or a limit: followed | '
          'below: followed '
          '| followed / default: duration, median / worst '
          f'| {SHAKING_FREQUENCY:g} Hz peak, median / worst '
          f'| {SHAKING_FREQUENCY:g} Hz residual, median / worst | refused (ValueError) |')
    print('|---|---|---|---|---|---|---|---|')
    total = counts[False][0] + counts[True][0]
    followed = counts[False][1] + counts[True][1]
    ratios = np.array(ratios).reshape(-1, 3)
    cells = [f'{np.median(ratios[:, k]):.{digits}f} / {np.max(ratios[:, k]):.{digits}f}'
             if ratios.size else '-' for k, digits in ((0, 3), (1, 2), (2, 2))]
    print(f'| {total} | {followed} | {counts[True][1]} of {counts[True][0]} | '
          f'{counts[False][1]} of {counts[False][0]} | ' + ' | '.join(cells)
          + f' | {refused_cell(refused, no_default)} |')
    for why, count in sorted(reasons.items(), key=lambda item: -item[1]):
        print(f'fell back {count} times: {why}')


def arm_replanning():
    """Print, per arm, how often time_optimal follows its running plan's states (module)."""
    _, count, arms = bench_arms.start_run(ARM_PATHS)
    print()
    print(f"speed_profile='time_optimal' replanned every {OPTIMAL_STEP * 1e3:.0f} ms from a "
          f'running time_optimal plan on each arm ({count} random paths per arm):')
    print(f'| arm | at >= {NEAR_LIMIT:g} of a v or a limit: followed | below: followed | '
          'followed / default: duration, median '
          f'| {SHAKING_FREQUENCY:g} Hz peak, median | refused (ValueError) |')
    print('|---|---|---|---|---|---|')
    for arm in arms:
        limits = arm.plan_limits()
        vmax = np.asarray(limits['max_velocity'], float)
        amax = np.asarray(limits['max_acceleration'], float)
        counts = {False: [0, 0], True: [0, 0]}
        ratios, refused = [], [0, 0]     # refused: time_optimal, the default where followed
        for points in arm_paths(arm, count):
            half = max(2, points.shape[0] // 2)
            if points.shape[0] <= half:
                continue
            running = plan(points[:half], '555', 'optimal', speed_profile='time_optimal',
                           **limits)
            goal = points[half:][::-1]
            for q, qd, qdd in running_states(running):
                boundary = {'start_velocity': qd, 'start_acceleration': qdd}
                try:
                    ours = plan(np.vstack([q, goal]), '555', 'optimal',
                                speed_profile='time_optimal', **boundary, **limits)
                except ValueError:
                    refused[0] += 1
                    continue
                near = at_limit(qd, qdd, vmax, amax)
                counts[near][0] += 1
                if not ours.optimizer.get('speed_profile_skipped'):
                    counts[near][1] += 1
                    try:
                        default = plan(np.vstack([q, goal]), '555', 'optimal', **boundary,
                                       **limits)
                    except ValueError:
                        refused[1] += 1     # followed, but no default to compare with
                        continue
                    ratios.append((ours.duration / default.duration, shaking(
                        of_trajectory(ours), ours.duration, amax, SHAKING_FREQUENCY)[0]
                        / shaking(of_trajectory(default), default.duration, amax,
                                  SHAKING_FREQUENCY)[0]))
        cells = (f'{np.median([r[0] for r in ratios]):.3f} | '
                 f'{np.median([r[1] for r in ratios]):.2f}' if ratios else '- | -')
        print(f'| {arm.name} | {counts[True][1]} of {counts[True][0]} | '
              f'{counts[False][1]} of {counts[False][0]} | {cells} | {refused_cell(*refused)} |',
              flush=True)


if __name__ == '__main__':
    main()
    time_optimal_replanning()
    arm_replanning()
