"""
The main job: the paper's example end to end through both nodes in one process.

Plans the triangle of Section III with each method through ``planner_node``,
lets ``arm_sim_node`` play every trajectory, and prints a table: duration,
per-joint peaks against the limits, the largest jumps of acceleration and
jerk across waypoints, and where the tool ended.
"""

import argparse
import sys

import numpy as np

from . import paper_example as pe
from .diagnostics import status_values
from .in_process import InProcessSystem, waypoint_message

RUNS = (('434', 'uniform'), ('445', 'uniform'))


def run_paper_example(runs=RUNS):
    """Run every (method, timing); return one dict of results per run."""
    waypoints = pe.joint_waypoints()
    request = waypoint_message(pe.JOINT_NAMES, waypoints,
                               pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION,
                               pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION)
    planner = {'max_velocity': pe.MAX_VELOCITY.tolist(),
               'max_acceleration': pe.MAX_ACCELERATION.tolist(),
               'max_jerk': [0.0, 0.0, 0.0]}  # the paper sets no jerk limit
    results = []
    with InProcessSystem(planner_parameters=planner,
                         arm_parameters={'initial_positions': waypoints[0].tolist()}) as system:
        for method, timing in runs:
            outcome = system.set_planner_parameters({'method': method, 'timing': timing})
            if not all(r.successful for r in outcome):
                raise RuntimeError(f'planner refused {method}/{timing}: {outcome}')
            n_arm_status = len(system.arm_status)
            status, trajectory = system.request(request)
            if trajectory is None:
                raise RuntimeError(f'{method}/{timing} failed: {status.message}')
            values = status_values(status)
            played, final = system.wait_until_played(n_arm_status, float(values['duration']))
            system.spin_for(0.05)
            pose = system.tool_poses[-1].pose.position
            results.append({'method': method, 'timing': timing, 'status': values,
                            'trajectory': trajectory, 'joint_states': played,
                            'final_state': final, 'tool_end': (pose.x, pose.y)})
    return results


def _vector(text):
    return np.array([float(v) for v in text.split(',')])


def _peaks_against_limits(values, quantity):
    peaks = _vector(values[f'peak_{quantity}'])
    limits = _vector(values[f'limit_{quantity}'])
    return ' '.join(f'{p:.3g}/{"-" if np.isinf(lim) else f"{lim:.3g}"}'
                    for p, lim in zip(peaks, limits))


def format_table(results):
    """Markdown table of the runs."""
    header = ('| method | timing | duration [s] | peak abs v / limit [rad/s] '
              '| peak abs a / limit [rad/s^2] | peak abs j / limit [rad/s^3] '
              '| max a jump | max j jump | tool end (x, y) |')
    rule = '|' + '---|' * 9
    rows = [header, rule]
    for r in results:
        v = r['status']
        rows.append(
            f"| {r['method']} | {r['timing']} | {float(v['duration']):.4f} "
            f"| {_peaks_against_limits(v, 'velocity')} "
            f"| {_peaks_against_limits(v, 'acceleration')} "
            f"| {_peaks_against_limits(v, 'jerk')} "
            f"| {float(v['max_acceleration_jump']):.3g} | {float(v['max_jerk_jump']):.3g} "
            f"| ({r['tool_end'][0]:.6f}, {r['tool_end'][1]:.6f}) |")
    return '\n'.join(rows)


def main(argv=None):
    """Run the demo and print the table."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--out', default='out', help='folder for figures and tables')
    args = parser.parse_args(argv)
    try:
        results = run_paper_example()
    except KeyboardInterrupt:
        return 130
    print()
    print("Paper's example (Petrinec & Kovacic, Sec. III): 12 triangle waypoints, "
          'v <= 2 rad/s, a <= 10 rad/s^2, no jerk limit,')
    print('boundary v = [-0.1, 0.4, 0], a = [1, 3, 0] at both ends; '
          'played by arm_sim_node; tool should end at (1, 0).')
    print()
    print(format_table(results))
    del args
    return 0


if __name__ == '__main__':
    sys.exit(main())
