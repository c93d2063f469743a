"""
A vendor arm's seam: straight tool lines on a table at 1 mm and 1 degree, any method.

The UR5 (or the Franka Panda) from ``example-robot-data``'s URDF, the tool
pointing down (``tool0``, or ``panda_hand_tcp``), a rectangle of 4 straight
edges on a table in the robot's base frame; the last edge also turns the
tool 60 degrees about the vertical, so the orientation tolerance has work to
do.  Limits: velocity from the URDF, acceleration and jerk from
``config/<robot>_joint_limits.yaml`` (MoveIt format).

* :func:`seam_table`: every method and timing with
  :func:`~splines445_ros.cartesian.tool_paths.plan_tool_path` (the library): the
  deviation before and after (the refinement's maxima, and an independent
  1 kHz sampling of the trajectory through forward kinematics), waypoints
  inserted, durations and planning time (median of repeats for uniform
  timing).
* :func:`play_seam`: the seam through the nodes, planned by ``planner_node``
  (``kinematics: model``) with 555 and played by ``arm_sim_node`` on the
  dynamic arm built from the same URDF alone; writes a figure of the tool path
  (top and side views) against the straight lines.

Run alone: ``python -m splines445_ros.tools.robot_seam_demo --out out [--robot panda]``.
"""

import argparse
import math
import os
import sys
import time

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Pose, PoseArray
import numpy as np

from . import vendor_robots as vr
from .command_line import run_main
from .figures import plt
from .in_process import InProcessSystem
from ..cartesian.tool_paths import plan_tool_path
from ..nodes.diagnostics import status_values
from ..planning.constraints.torque import CHECK_PERIOD
from ..robot import rotations as rot
from ..robot.inverse_kinematics import ModelKinematics
from ..robot.joint_limits_file import read_joint_limits_file, resolve_limits
from ..robot.robot_model import load_robot_model

TOLERANCE = 1e-3                    # m
ANGLE_TOLERANCE = math.radians(1.0)
SEAM_RUNS = tuple((m, t) for m in ('555', '434', '445') for t in ('uniform', 'optimal'))
UNIFORM_REPEATS = 5
SEAM_MAX_INSERTED = 2000
LAST_EDGE_TURN = math.radians(60.0)
HERE = os.path.dirname(os.path.abspath(__file__))
SEAM_ROBOTS = {
    'ur5': {'urdf': vr.ur5_urdf, 'tool': 'tool0', 'base': 'base_link', 'joints': vr.UR5_JOINTS,
            'ready': vr.UR5_READY, 'height': 0.15,
            'corners': ((0.3, -0.2), (0.55, -0.2), (0.55, 0.2), (0.3, 0.2), (0.3, -0.2))},
    'panda': {'urdf': vr.panda_urdf, 'tool': 'panda_hand_tcp', 'base': 'panda_link0',
              'joints': vr.PANDA_ARM_JOINTS, 'ready': vr.PANDA_READY, 'height': 0.25,
              'corners': ((0.35, -0.15), (0.55, -0.15), (0.55, 0.15), (0.35, 0.15),
                          (0.35, -0.15))},
}


def limits_file(robot):
    """Return the shipped MoveIt joint_limits.yaml of ``robot`` (installed or in the tree)."""
    name = f'{robot}_joint_limits.yaml'
    candidates = [os.path.join(HERE, '..', '..', 'config', name)]
    try:
        from ament_index_python.packages import get_package_share_directory
        candidates.insert(0, os.path.join(get_package_share_directory('splines445_ros'),
                                          'config', name))
    except Exception:  # noqa: B902 - not installed: the source tree's copy
        pass
    for path in candidates:
        if os.path.isfile(path):
            return os.path.abspath(path)
    raise FileNotFoundError(f'no {name} in {candidates}')


def setup(robot='ur5'):
    """Return (kinematics, limits dict for plan(), seam poses (5, 7)) of a robot."""
    spec = SEAM_ROBOTS[robot]
    model = load_robot_model(spec['urdf']())
    kin = ModelKinematics(model, spec['tool'], spec['base'], spec['joints'], seed=spec['ready'])
    limits = resolve_limits(kin.joint_names, {j.name: j.velocity for j in kin.joints},
                            read_joint_limits_file(limits_file(robot)))
    down = kin.forward(np.array(spec['ready']))[3:]
    turned = rot.multiply(rot.from_axis_angle([0.0, 0.0, 1.0], LAST_EDGE_TURN), down)
    poses = np.array([[x, y, spec['height'], *down] for x, y in spec['corners']])
    poses[-1, 3:] = turned
    kwargs = {'max_velocity': limits.velocity, 'max_acceleration': limits.acceleration,
              'max_jerk': limits.jerk_limits()}
    return kin, kwargs, poses


def sampled_deviation(result, poses, kinematics, period=CHECK_PERIOD):
    """Return the largest (position [m], angle [rad]) deviation at ``period`` sampling."""
    traj = result.trajectory
    samples = traj.sample(period)
    tool = kinematics.forward(samples.positions)
    passed = traj.waypoint_times[result.waypoint_knots]
    edge = np.clip(np.searchsorted(passed, samples.times, side='right') - 1, 0, len(poses) - 2)
    a, ab = poses[edge, :3], poses[edge + 1, :3] - poses[edge, :3]
    s = np.clip(np.sum((tool[:, :3] - a) * ab, axis=1) / np.sum(ab * ab, axis=1), 0.0, 1.0)
    position = np.linalg.norm(tool[:, :3] - a - s[:, None] * ab, axis=1)
    wanted = rot.slerp(poses[edge, 3:], poses[edge + 1, 3:], s)
    return float(position.max()), float(rot.angle_between(wanted, tool[:, 3:]).max())


def seam_table(robot='ur5', runs=SEAM_RUNS):
    """Refine the seam for every (method, timing); return one dict per run."""
    kin, kwargs, poses = setup(robot)
    out = []
    for method, timing in runs:
        repeats = UNIFORM_REPEATS if timing == 'uniform' else 1
        times, result, error = [], None, None
        for _ in range(repeats):
            # Fresh kinematics every run: no IK walk remembered from the previous one.
            spec = SEAM_ROBOTS[robot]
            kin = ModelKinematics(kin.robot, spec['tool'], spec['base'], spec['joints'],
                                  seed=spec['ready'])
            started = time.perf_counter()
            try:
                result = plan_tool_path(poses, kin, TOLERANCE, ANGLE_TOLERANCE,
                                        max_inserted=SEAM_MAX_INSERTED, method=method,
                                        timing=timing, **kwargs)
            except ValueError as exc:
                error = str(exc)
                break
            times.append(time.perf_counter() - started)
        out.append({'robot': robot, 'method': method, 'timing': timing, 'result': result,
                    'error': error, 'planning_time': float(np.median(times)) if times else None,
                    'sampled': None if result is None else sampled_deviation(result, poses,
                                                                             kin)})
    return out


def markdown_table(runs):
    """Return the Markdown table of :func:`seam_table`'s runs."""
    lines = ['| robot | method | timing | deviation before [mm] / [deg] | after [mm] / [deg] | '
             f'after, sampled at {1 / CHECK_PERIOD:g} Hz [mm] / [deg] | inserted | '
             'duration before [s] | after [s] | planning time [ms] |',
             '|---|---|---|---|---|---|---|---|---|---|']
    for run in runs:
        head = f"| {run['robot']} | {run['method']} | {run['timing']} | "
        result = run['result']
        if result is None:
            lines.append(head + f"not reached: {run['error']} | | | | | | |")
            continue
        before = result.initial_deviation
        lines.append(
            head + f'{1e3 * before.max_position:.2f} / {math.degrees(before.max_orientation):.2f}'
            f' | {1e3 * result.max_deviation:.3f} / '
            f'{math.degrees(result.max_orientation_deviation):.3f} | '
            f'{1e3 * run["sampled"][0]:.3f} / {math.degrees(run["sampled"][1]):.3f} | '
            f'{result.inserted} | {result.initial_duration:.3f} | '
            f'{result.trajectory.duration:.3f} | {1e3 * run["planning_time"]:.1f} |')
    return '\n'.join(lines)


def play_seam(out_dir, robot='ur5', method='555', timing='optimal'):
    """Plan the seam with planner_node, play it on the dynamic arm; return (values, figure)."""
    spec = SEAM_ROBOTS[robot]
    kin, _, poses = setup(robot)
    start = kin.inverse(poses[:1])[0]
    urdf = spec['urdf']()
    planner = {'kinematics': 'model', 'model_file': urdf, 'joint_names': list(spec['joints']),
               'tool_frame': spec['tool'], 'base_frame': spec['base'],
               'joint_limits_file': limits_file(robot), 'max_velocity': [0.0],
               'max_acceleration': [0.0], 'max_jerk': [0.0], 'method': method,
               'timing': timing, 'max_path_deviation': TOLERANCE,
               'max_orientation_deviation': ANGLE_TOLERANCE,
               'max_inserted_waypoints': SEAM_MAX_INSERTED, 'sample_period': 0.002}
    arm = {'simulation': 'dynamic', 'model_file': urdf, 'joint_names': list(spec['joints']),
           'tool_frame': spec['tool'], 'initial_positions': start.tolist(),
           'publish_rate': 200.0}
    msg = PoseArray()
    msg.header.frame_id = spec['base']
    for row in poses:
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = (float(v) for v in row[:3])
        pose.orientation.w, pose.orientation.x = float(row[3]), float(row[4])
        pose.orientation.y, pose.orientation.z = float(row[5]), float(row[6])
        msg.poses.append(pose)
    with InProcessSystem(planner_parameters=planner, arm_parameters=arm) as system:
        system.spin_for(0.3)  # joint_states reach the planner: its IK seed
        n_arm = len(system.arm_status)
        status, _ = system.request(msg, timeout=120.0)
        if status.level != DiagnosticStatus.OK:
            raise RuntimeError(f'planner_node: {status.message}')
        values = status_values(status)
        played, _ = system.wait_until_played(n_arm, float(values['duration']))
        finished = system.spin_until(
            lambda: any('settling_error' in status_values(s) for s in system.arm_status[n_arm:]),
            10.0)
        tracking = next((status_values(s) for s in system.arm_status[n_arm:]
                         if 'settling_error' in status_values(s)), {}) if finished else {}
    q = np.array([s.position for s in played])
    tool = kin.forward(q)
    os.makedirs(out_dir, exist_ok=True)
    figure = os.path.join(out_dir, f'{robot}_seam.png')
    plot_seam(poses, tool, figure, f'{robot.upper()} seam, {method} {timing}, refined to '
              f'1 mm / 1 deg, played on the dynamic arm (MuJoCo)')
    return {**values, **{f'arm_{k}': v for k, v in tracking.items()}}, figure


def plot_seam(poses, tool, path, title):
    """Top (x-y) and side (x-z) views of the tool path against the straight lines."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.6))
    for ax, (i, j, name) in zip(axes, ((0, 1, 'top view (x, y)'), (0, 2, 'side view (x, z)'))):
        ax.plot(poses[:, i], poses[:, j], 'k-', lw=0.8, label='straight lines')
        ax.plot(tool[:, i], tool[:, j], 'C0-', lw=1.0, label='tool (played)')
        ax.plot(poses[:, i], poses[:, j], 'ko', ms=4)
        ax.set_title(name)
        ax.set_xlabel('x [m]')
        ax.set_ylabel('y [m]' if j == 1 else 'z [m]')
        if j == 1:
            ax.set_aspect('equal')
        ax.legend(fontsize=8)
    axes[1].set_ylim(poses[0, 2] - 0.005, poses[0, 2] + 0.005)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def run_robot_seam_demo(out_dir, robot='ur5'):
    """Table and played seam for ``robot``; write them to ``out_dir``; return (text, paths)."""
    os.makedirs(out_dir, exist_ok=True)
    table = markdown_table(seam_table(robot))
    values, figure = play_seam(out_dir, robot)
    table_path = os.path.join(out_dir, f'{robot}_seam_table.md')
    played = (f"Played through the nodes (555 optimal): planning {values['planning_time_ms']} "
              f"ms in planner_node, {values['inserted_waypoints']} inserted, deviation "
              f"{1e3 * float(values['max_path_deviation_reached']):.3f} mm; on the dynamic "
              f"arm: max tracking error {values.get('arm_tracking_max_error', '?')} rad, tool "
              f"max error {values.get('arm_tool_max_error', '?')} m, peak torque "
              f"{values.get('arm_peak_effort', '?')} N m.")
    with open(table_path, 'w', encoding='utf-8') as handle:
        handle.write(table + '\n\n' + played + '\n')
    return table + '\n\n' + played, [figure, table_path]


def main(argv=None):
    """Run the seam demo, print the table, write the figure and the table to --out."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--out', default='out', help='folder for the figure and the table')
    parser.add_argument('--robot', default='ur5', choices=sorted(SEAM_ROBOTS))
    args = parser.parse_args(argv)

    def run():
        text, paths = run_robot_seam_demo(args.out, args.robot)
        print(text)
        print(f'written: {", ".join(paths)}')
        return 0
    return run_main('robot_seam_demo', run)


if __name__ == '__main__':
    sys.exit(main())
