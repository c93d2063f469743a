"""
Figures of trajectories (matplotlib, headless Agg backend).

* :func:`plot_joint_curves`: position, velocity, acceleration and jerk of
  every joint over time, several plans overlaid, limits dashed, waypoint
  times marked (the paper's Figs. 3-6).
* :func:`plot_tool_path`: the tool path in the plane with the waypoints and
  the triangle's edges (the paper's Fig. 7).
* :func:`plot_samples`: a sampled ``JointTrajectory`` (times, positions,
  velocities, accelerations; jerk by differencing the accelerations).
* :func:`plot_tracking`: the dynamic arm's tracking error, torque and torque
  rate over time per method, from the ``joint_states`` it published.
"""

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

ROWS = (('position', 'rad'), ('velocity', 'rad/s'), ('acceleration', 'rad/s²'),
        ('jerk', 'rad/s³'))
POINTS_PER_SEGMENT = 200


def _label_grid(axes, joint_names, row_labels, xlabel):
    """Title every column with its joint, label every row and the bottom time axes."""
    for j, name in enumerate(joint_names):
        axes[0, j].set_title(name)
        axes[-1, j].set_xlabel(xlabel)
    for row, label in enumerate(row_labels):
        axes[row, 0].set_ylabel(label)


def _label(traj):
    return f'{traj.method} {traj.timing}'


def plot_joint_curves(trajectories, path, joint_names):
    """Plot q, v, a, j of every joint for every planned trajectory; save to ``path``."""
    n = len(joint_names)
    fig, axes = plt.subplots(4, n, figsize=(5 * n, 11), sharex='col', squeeze=False)
    for k, traj in enumerate(trajectories):
        color = f'C{k}'
        # Dense evaluation is only for drawing; peaks come from the polynomials.
        t = np.concatenate([np.linspace(a, b, POINTS_PER_SEGMENT, endpoint=False)
                            for a, b in zip(traj.breakpoints[:-1], traj.breakpoints[1:])]
                           + [[traj.duration]])
        for row in range(4):
            values = traj.evaluate(t, row)
            for j in range(n):
                ax = axes[row, j]
                ax.plot(t, values[:, j], color=color, lw=1.2, label=_label(traj))
                if row == 0:
                    ax.plot(traj.waypoint_times, traj.waypoints[:, j], 'o', color=color, ms=3)
                else:
                    for x in traj.breakpoints[1:-1]:
                        ax.axvline(x, color=color, lw=0.4, alpha=0.35)
        limits = traj.limits.as_array() if traj.limits is not None else None
        if limits is not None:
            for row in (1, 2, 3):
                for j in range(n):
                    bound = limits[row - 1, j]
                    if np.isfinite(bound):
                        for sign in (1, -1):
                            axes[row, j].axhline(sign * bound, color='k', ls='--', lw=0.8)
    _label_grid(axes, joint_names, [f'{name} [{unit}]' for name, unit in ROWS], 'time [s]')
    axes[0, 0].legend(loc='best', fontsize=8)
    fig.suptitle('Joint trajectories (dashed: limits; thin lines: waypoint times)')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_tool_path(paths, waypoints_xy, corners, path):
    """Plot tool paths {label: (K, 2)} with the waypoints and the closed polygon ``corners``."""
    fig, ax = plt.subplots(figsize=(6.5, 6.5))
    closed = np.vstack([corners, corners[:1]])
    ax.plot(closed[:, 0], closed[:, 1], 'k-', lw=0.8, label='triangle edges')
    for k, (label, xy) in enumerate(paths.items()):
        ax.plot(xy[:, 0], xy[:, 1], color=f'C{k}', lw=1.2, label=label)
    ax.plot(waypoints_xy[:, 0], waypoints_xy[:, 1], 'ko', ms=4, label='waypoints')
    ax.set_aspect('equal')
    ax.set_xlabel('x [m]')
    ax.set_ylabel('y [m]')
    ax.set_title('Tool path (forward kinematics of the published joint_states)')
    ax.legend(loc='best', fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_samples(times, positions, velocities, accelerations, joint_names, path, title=''):
    """Plot a sampled trajectory; jerk is the difference quotient of the accelerations."""
    n = len(joint_names)
    fig, axes = plt.subplots(4, n, figsize=(5 * n, 11), sharex='col', squeeze=False)
    rows = [positions, velocities, accelerations]
    if accelerations is not None and len(times) > 1:
        jerk = np.diff(accelerations, axis=0) / np.diff(times)[:, None]
        rows.append(jerk)
    else:
        rows.append(None)
    for row, values in enumerate(rows):
        for j in range(n):
            ax = axes[row, j]
            if values is None:
                ax.text(0.5, 0.5, 'not in the message', ha='center', transform=ax.transAxes)
                continue
            t = times if row < 3 else 0.5 * (times[1:] + times[:-1])
            ax.plot(t, values[:, j], lw=1.0)
    _label_grid(axes, joint_names,
                [f'{name} [{unit}]' + (' (from samples)' if row == 3 else '')
                 for row, (name, unit) in enumerate(ROWS)], 'time from start [s]')
    fig.suptitle(title or 'JointTrajectory')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


TRACKING_ROWS = (('tracking error', 'mrad'), ('torque', 'N m'), ('torque rate', 'kN m/s'))


def plot_tracking(runs, path, joint_names):
    """
    Plot tracking error, torque and torque rate of every joint per run; save to ``path``.

    A run is a dict with the planned core ``Trajectory`` (``'plan'``), the
    arm's ``joint_states`` (``'states'``, with ``effort``) from the start on and
    the start time ``'start_ns'``; the error is the plan minus the measured
    position, the rate the difference quotient of consecutive efforts.
    """
    n = len(joint_names)
    fig, axes = plt.subplots(3, n, figsize=(5 * n, 8.5), sharex='col', squeeze=False)
    bounds = {}
    for k, run in enumerate(runs):
        traj, states = run['plan'], run['states']
        t = np.array([s.header.stamp.sec * 1e9 + s.header.stamp.nanosec
                      for s in states]) * 1e-9 - run['start_ns'] * 1e-9
        measured = np.array([s.position for s in states])
        effort = np.array([s.effort for s in states])
        error = traj.evaluate(np.clip(t, 0.0, traj.duration)) - measured
        rate = np.diff(effort, axis=0) / np.diff(t)[:, None]
        label = _label(traj)
        for j in range(n):
            axes[0, j].plot(t, 1e3 * error[:, j], color=f'C{k}', lw=1.0, label=label)
            axes[1, j].plot(t, effort[:, j], color=f'C{k}', lw=1.0, label=label)
            axes[2, j].plot(0.5 * (t[1:] + t[:-1]), 1e-3 * rate[:, j], color=f'C{k}', lw=1.0,
                            label=label)
            for row in range(3):
                axes[row, j].axvline(traj.duration, color=f'C{k}', lw=0.6, ls=':')
            # Rows 0 and 2 are scaled to the motion, away from the start and the stop.
            inner = (t > 0.1) & (t < traj.duration - 0.05)
            for row, values in ((0, 1e3 * error[:, j]), (2, 1e-3 * rate[:, j])):
                window = inner[1:] if row == 2 else inner
                if np.any(window):
                    bound = max(bounds.get((row, j), 0.0), 1.3 * np.abs(values[window]).max())
                    bounds[row, j] = bound
                    axes[row, j].set_ylim(-bound, bound)
    _label_grid(axes, joint_names, [f'{name} [{unit}]' for name, unit in TRACKING_ROWS],
                'time from start [s] (dotted: end of the trajectory)')
    axes[0, 0].legend(loc='best', fontsize=8)
    fig.suptitle('Dynamic arm: tracking error, applied torque and its rate (joint_states); '
                 'error and rate scaled to the motion, start and stop steps off-scale')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
