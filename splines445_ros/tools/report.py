"""
Figures-side numbers of a demo run: metrics per method, as Markdown and CSV.

Pure Python (no rclpy): a *run* is a dict with the planned core
``Trajectory`` (``'plan'``), the tool positions from forward kinematics of the
``joint_states`` the arm actually published (``'tool_path'``, (K, 2)), the
tool's final position (``'tool_end'``) and, from the dynamic arm, its
end-of-trajectory status values (``'tracking'``: tracking errors, torques,
settling error; per joint as comma-separated strings) with the torque limits
(``'torque_limits'``).
"""

import csv

import numpy as np

from ..robot.paper_example import distance_to_triangle

QUANTITIES = ('velocity', 'acceleration', 'jerk')
TRACKING = ('tracking_rms_error', 'tracking_max_error', 'peak_effort', 'peak_effort_rate',
            'settling_error')


def run_metrics(run):
    """Duration, peaks against limits, jumps at waypoints and tool-path deviation."""
    traj = run['plan']
    peaks = traj.peaks()
    metrics = {
        'method': traj.method,
        'timing': traj.timing,
        'duration_s': traj.duration,
        'max_acceleration_jump': float(np.max(traj.knot_jumps(2))),
        'max_jerk_jump': float(np.max(traj.knot_jumps(3))),
        'max_tool_deviation': float(np.max(distance_to_triangle(run['tool_path']))),
        'tool_end_x': float(run['tool_end'][0]),
        'tool_end_y': float(run['tool_end'][1]),
    }
    limits = traj.limits.as_array()
    for q, name in enumerate(QUANTITIES):
        for j in range(traj.n_joints):
            metrics[f'peak_{name}_{j + 1}'] = float(peaks[name][j])
            metrics[f'limit_{name}_{j + 1}'] = float(limits[q, j])
    tracking = run.get('tracking')
    if tracking:
        for key in TRACKING:
            for j, value in enumerate(tracking[key].split(',')):
                metrics[f'{key}_{j + 1}'] = float(value)
        metrics['tool_max_error'] = float(tracking['tool_max_error'])
        metrics['saturated_steps'] = int(tracking['saturated_steps'])
        for j, limit in enumerate(run['torque_limits']):
            metrics[f'torque_limit_{j + 1}'] = float(limit)
    return metrics


def _peaks_cell(m, name, n_joints):
    cells = []
    for j in range(1, n_joints + 1):
        limit = m[f'limit_{name}_{j}']
        shown = '-' if np.isinf(limit) else f'{limit:.3g}'
        cells.append(f"{m[f'peak_{name}_{j}']:.3g}/{shown}")
    return ' '.join(cells)


def _joints_cell(m, key, n_joints, scale=1.0):
    return ' '.join(f"{m[f'{key}_{j}'] * scale:.3g}" for j in range(1, n_joints + 1))


def _tracking_cells(m, n_joints):
    if 'tool_max_error' not in m:
        return ' | - | - | - | - | - | -'
    torque = ' '.join(f"{m[f'peak_effort_{j}']:.3g}/{m[f'torque_limit_{j}']:.3g}"
                      for j in range(1, n_joints + 1))
    return (f" | {_joints_cell(m, 'tracking_rms_error', n_joints, 1e3)} "
            f"| {_joints_cell(m, 'tracking_max_error', n_joints, 1e3)} "
            f"| {m['tool_max_error'] * 1e3:.3g} "
            f'| {torque} '
            f"| {_joints_cell(m, 'peak_effort_rate', n_joints, 1e-3)} "
            f"| {_joints_cell(m, 'settling_error', n_joints, 1e3)}")


def markdown_table(metrics, n_joints=3):
    """One row per run: the table printed by the demo and written next to the figures."""
    rows = ['| method | timing | duration [s] | peak abs v / limit [rad/s] '
            '| peak abs a / limit [rad/s^2] | peak abs j / limit [rad/s^3] '
            '| max a jump | max j jump | max tool deviation [m] | tool end (x, y) '
            '| tracking RMS [mrad] | tracking max [mrad] | tool max error [mm] '
            '| peak abs torque / limit [N m] | peak abs dtorque/dt [kN m/s] '
            '| settling error [mrad] |',
            '|' + '---|' * 16]
    for m in metrics:
        rows.append(
            f"| {m['method']} | {m['timing']} | {m['duration_s']:.4f} "
            f"| {_peaks_cell(m, 'velocity', n_joints)} "
            f"| {_peaks_cell(m, 'acceleration', n_joints)} "
            f"| {_peaks_cell(m, 'jerk', n_joints)} "
            f"| {m['max_acceleration_jump']:.3g} | {m['max_jerk_jump']:.3g} "
            f"| {m['max_tool_deviation']:.4f} "
            f"| ({m['tool_end_x']:.6f}, {m['tool_end_y']:.6f})"
            + _tracking_cells(m, n_joints) + ' |')
    return '\n'.join(rows)


def write_csv(metrics, path):
    """Write the metrics, one row per run, with a header."""
    with open(path, 'w', newline='', encoding='utf-8') as handle:
        writer = csv.DictWriter(handle, fieldnames=list(metrics[0]))
        writer.writeheader()
        for m in metrics:
            writer.writerow({k: (f'{v:.12g}' if isinstance(v, float) else v)
                             for k, v in m.items()})
