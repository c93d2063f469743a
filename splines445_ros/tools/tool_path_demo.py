"""
The paper's triangle with straight tool paths: Taylor's refinement at 1 mm for every method.

For every method of :data:`splines445_ros.planning.METHODS` and the timings
"uniform" and "optimal", plans the triangle's 12 tool waypoints (tool
orientation 0, rest to rest, v <= 2 rad/s, a <= 10 rad/s^2, no jerk limit)
with :func:`splines445_ros.cartesian.tool_paths.plan_tool_path` and a tolerance of
1 mm from the straight lines between consecutive waypoints, and reports the
deviation before and after, the waypoints inserted, the duration before and
after and the planning time.  The deviation "after" is given twice: the
refinement's own maxima and an independent check on the trajectory sampled
at 1 kHz.  Writes the figure ``tool_paths_refined.png``.

Run alone: ``python -m splines445_ros.tools.tool_path_demo --out out``.
"""

import argparse
import os
import sys
import time

import numpy as np

from .command_line import run_main
from .figures import plt
from ..cartesian.tool_paths import plan_tool_path
from ..planning import METHODS
from ..planning.constraints.torque import CHECK_PERIOD
from ..robot import paper_example as pe
from ..robot.kinematics import PlanarArm

TOLERANCE = 1e-3
TRIANGLE_TIMINGS = ('uniform', 'optimal')
# 445 needs far more knots than 434 and 555 (its disturbances do not decay):
# the cap is set high enough for it to get there with uniform timing.
TRIANGLE_MAX_INSERTED = 1000
UNIFORM_REPEATS = 5


def triangle_poses():
    """Tool waypoints (12, 3) of the paper's triangle, orientation 0."""
    xy = pe.triangle_points()
    return np.column_stack([xy, np.zeros(len(xy))])


def sampled_deviation(result, poses, kinematics, period=CHECK_PERIOD):
    """Largest distance [m] of the tool from its edge on the trajectory sampled every period."""
    traj = result.trajectory
    samples = traj.sample(period)
    xy = kinematics.forward(samples.positions)[:, :2]
    passed = traj.waypoint_times[result.waypoint_knots]
    edge = np.clip(np.searchsorted(passed, samples.times, side='right') - 1, 0, len(poses) - 2)
    a, ab = poses[edge, :2], poses[edge + 1, :2] - poses[edge, :2]
    s = np.clip(np.sum((xy - a) * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    return float(np.max(np.linalg.norm(xy - a - s[:, None] * ab, axis=1)))


def refine_triangle(methods=METHODS, timings=TRIANGLE_TIMINGS, tolerance=TOLERANCE):
    """Refine the triangle for every (method, timing); return one dict per run."""
    arm = PlanarArm()
    poses = triangle_poses()
    kwargs = {'max_velocity': pe.MAX_VELOCITY, 'max_acceleration': pe.MAX_ACCELERATION}
    runs = []
    for method in methods:
        for timing in timings:
            repeats = UNIFORM_REPEATS if timing == 'uniform' else 1
            times = []
            error = result = None
            for _ in range(repeats):
                started = time.perf_counter()
                try:
                    result = plan_tool_path(poses, arm, tolerance,
                                            max_inserted=TRIANGLE_MAX_INSERTED,
                                            method=method, timing=timing, **kwargs)
                except ValueError as exc:
                    error = str(exc)
                    break
                times.append(time.perf_counter() - started)
            unrefined = plan_tool_path(poses, arm, method=method, timing=timing, **kwargs)
            runs.append({'method': method, 'timing': timing, 'result': result, 'error': error,
                         'unrefined': unrefined, 'planning_time': np.median(times) if times
                         else None,
                         'sampled': None if result is None
                         else sampled_deviation(result, poses, arm)})
    return runs


def markdown_table(runs, tolerance=TOLERANCE):
    """Return the Markdown table of :func:`refine_triangle`'s runs."""
    lines = [f'| method | timing | max deviation before [mm] | after [mm] | after, sampled '
             f'at {1 / CHECK_PERIOD:g} Hz [mm] | inserted waypoints | duration before [s] '
             '| after [s] | duration cost | planning time [ms] |',
             '|---|---|---|---|---|---|---|---|---|---|']
    for run in runs:
        before = run['unrefined']
        head = (f"| {run['method']} | {run['timing']} | "
                f'{1e3 * before.max_deviation:.2f} | ')
        result = run['result']
        if result is None:
            lines.append(head + f"not reached: {run['error']} | | | "
                         f'{before.trajectory.duration:.3f} | | | |')
            continue
        cost = result.trajectory.duration / before.trajectory.duration
        lines.append(
            head + f'{1e3 * result.max_deviation:.3f} | {1e3 * run["sampled"]:.3f} | '
            f'{result.inserted} | {before.trajectory.duration:.3f} | '
            f'{result.trajectory.duration:.3f} | {cost:.2f}x | '
            f'{1e3 * run["planning_time"]:.1f} |')
    return '\n'.join(lines)


def plot_refined_paths(runs, path):
    """Plot refined against unrefined tool paths, one panel per (timing, method)."""
    arm = PlanarArm()
    poses = triangle_poses()
    methods = list(dict.fromkeys(r['method'] for r in runs))
    timings = list(dict.fromkeys(r['timing'] for r in runs))
    fig, axes = plt.subplots(len(timings), len(methods), squeeze=False,
                             figsize=(4.6 * len(methods), 4.6 * len(timings)))
    for run in runs:
        ax = axes[timings.index(run['timing']), methods.index(run['method'])]
        ax.plot(poses[:, 0], poses[:, 1], 'k-', lw=0.6, label='straight lines')
        for label, tool_path, style in (('unrefined', run['unrefined'], 'C1--'),
                                        ('refined', run['result'], 'C0-')):
            if tool_path is None:
                continue
            traj = tool_path.trajectory
            xy = arm.forward(traj.evaluate(np.linspace(0.0, traj.duration, 4000)))[:, :2]
            dev = 1e3 * tool_path.max_deviation
            ax.plot(xy[:, 0], xy[:, 1], style, lw=1.0, label=f'{label} ({dev:.2f} mm)')
        if run['result'] is not None:
            knots = run['result'].poses
            ax.plot(knots[:, 0], knots[:, 1], 'C0.', ms=2.5,
                    label=f"knots ({run['result'].inserted} inserted)")
        ax.plot(poses[:, 0], poses[:, 1], 'ko', ms=3.5)
        ax.set_aspect('equal')
        ax.set_title(f"{run['method']} {run['timing']}")
        ax.legend(loc='lower left', fontsize=7)
    fig.suptitle('Tool paths of the triangle: refined to 1 mm (solid) and unrefined (dashed)')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def run_tool_path_demo(out_dir):
    """Refine the triangle, write the figure and the table to ``out_dir``; return both."""
    os.makedirs(out_dir, exist_ok=True)
    runs = refine_triangle()
    table = markdown_table(runs)
    figure = os.path.join(out_dir, 'tool_paths_refined.png')
    plot_refined_paths(runs, figure)
    table_path = os.path.join(out_dir, 'tool_paths_table.md')
    with open(table_path, 'w', encoding='utf-8') as handle:
        handle.write(table + '\n')
    return table, [figure, table_path]


def main(argv=None):
    """Run the tool path demo, print the table, write the figure to --out."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--out', default='out', help='folder for the figure and the table')
    args = parser.parse_args(argv)

    def run():
        table, paths = run_tool_path_demo(args.out)
        print(table)
        print(f'written: {", ".join(paths)}')
        return 0
    return run_main('tool_path_demo', run)


if __name__ == '__main__':
    sys.exit(main())
