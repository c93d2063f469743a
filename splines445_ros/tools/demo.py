"""
The main job: the paper's example end to end through both nodes in one process.

Plans the triangle of Section III through ``planner_node`` with 434 and 445
(uniform timing, as in the paper), 445 with optimal timing and the C4 quintic
555 with uniform and optimal timing, lets
``arm_sim_node`` play every trajectory on the dynamic arm (MuJoCo, the
default model and joint controller), prints a table (duration, per-joint
peaks against the limits, the largest jumps of acceleration and jerk across
waypoints, the tool path's largest deviation from the triangle's edges, where
the tool ended, and the arm's tracking errors and torques from its end-of-
trajectory status) and writes figures and the table to a folder.  Then it
refines the triangle's tool path to 1 mm (Taylor's method, the paper's remedy)
for every method and timing and prints and writes that table and figure too.
Last, a real arm: the UR5 from its vendor URDF, a seam of 4 straight edges on
a table, tool pointing down, refined to 1 mm and 1 degree for every method
and timing, and played with 555 through both nodes on the dynamic arm built
from the same URDF (:mod:`.robot_seam_demo`).
"""

import argparse
import os
import sys

from diagnostic_msgs.msg import DiagnosticStatus
import numpy as np
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from .command_line import run_main
from .figures import plot_joint_curves, plot_tool_path, plot_tracking
from .in_process import InProcessSystem, stamp_ns, waypoint_message
from .recording import McapRecording
from .report import markdown_table, run_metrics, write_csv
from .robot_seam_demo import run_robot_seam_demo
from .tool_path_demo import run_tool_path_demo, TOLERANCE
from ..nodes import topics
from ..nodes.diagnostics import status_values
from ..planning import plan
from ..robot import paper_example as pe
from ..robot.kinematics import PlanarArm
from ..service.arm_sim_config import ArmSimConfig

PAPER_RUNS = (('434', 'uniform'), ('445', 'uniform'), ('445', 'optimal'), ('555', 'uniform'),
              ('555', 'optimal'))
# kinematics planar_3dof: the planned paths are published as markers (and recorded).
PLANNER_PARAMETERS = {'kinematics': 'planar_3dof', 'max_velocity': pe.MAX_VELOCITY.tolist(),
                      'max_acceleration': pe.MAX_ACCELERATION.tolist(),
                      'max_jerk': [0.0, 0.0, 0.0],  # the paper sets no jerk limit
                      # A trajectory that reached the MuJoCo arm after its stamp would start
                      # part-way: the arm jumps and its torque saturates (in one process, on
                      # a loaded machine, delivery took up to 0.27 s).
                      'start_delay': 1.0}
# The dynamic arm with its default model and controller; 100 Hz joint_states for tracking.png.
ARM_PARAMETERS = {'simulation': 'dynamic', 'publish_rate': 100.0}
# What the demo records (MCAP): the requests, the trajectories, the arm, the markers
# and both nodes' statuses, each with the QoS of its publisher.
RECORDED_TOPICS = (
    ('/' + topics.WAYPOINTS, JointTrajectory, topics.REQUEST_QOS),
    ('/' + topics.JOINT_TRAJECTORY, JointTrajectory, topics.LATCHED),
    ('/' + topics.JOINT_STATES, JointState, topics.STATE_QOS),
    ('/planner_node/planned_path', MarkerArray, topics.LATCHED),
    ('/planner_node/status', DiagnosticStatus, topics.STATUS_QOS),
    ('/arm_sim_node/status', DiagnosticStatus, topics.STATUS_QOS),
)
RECORDING = 'demo.mcap'


def run_paper_example(runs=PAPER_RUNS, recording=None):
    """
    Run every (method, timing) through both nodes; return (one dict per run, counts).

    ``recording``: a path to record :data:`RECORDED_TOPICS` to (MCAP), or None;
    ``counts`` are the recorded messages per topic ({} without a recording).
    """
    waypoints = pe.joint_waypoints()
    boundary = (pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION,
                pe.BOUNDARY_VELOCITY, pe.BOUNDARY_ACCELERATION)
    request = waypoint_message(pe.JOINT_NAMES, waypoints, *boundary)
    arm = PlanarArm()
    results = []
    arm_parameters = {**ARM_PARAMETERS, 'initial_positions': waypoints[0].tolist()}
    with InProcessSystem(planner_parameters=PLANNER_PARAMETERS,
                         arm_parameters=arm_parameters) as system:
        recorder = (None if recording is None
                    else McapRecording(system.client, recording, RECORDED_TOPICS))
        try:
            if recorder is not None:
                system.spin_until(lambda: all(
                    s.get_publisher_count() >= 1 for s in recorder.subscriptions), 10.0)
            for method, timing in runs:
                results.append(_run_once(system, request, waypoints, boundary, arm,
                                         method, timing))
            if recorder is not None:
                system.spin_for(0.1)  # the last statuses
        finally:
            # A run that fails, or Ctrl-C, still leaves a finished, readable file.
            if recorder is not None:
                recorder.close()
    if recorder is not None and recorder.error is not None:
        raise OSError(f'{recording}: {recorder.error}')  # (the runs themselves went on)
    return results, ({} if recorder is None else dict(recorder.counts))


def _run_once(system, request, waypoints, boundary, arm, method, timing):
    """Plan ``request`` with ``method``/``timing`` on the running system; return its result."""
    outcome = system.set_planner_parameters({'method': method, 'timing': timing})
    if not all(r.successful for r in outcome):
        raise RuntimeError(f'planner refused {method}/{timing}: {outcome}')
    n_arm_status = len(system.arm_status)
    status, trajectory = system.request(request)
    if trajectory is None:
        raise RuntimeError(f'{method}/{timing} failed: {status.message}')
    values = status_values(status)
    played, final = system.wait_until_played(n_arm_status, float(values['duration']))
    tracking = _tracking_status(system, n_arm_status)
    system.spin_for(0.05)
    pose = system.tool_poses[-1].pose.position
    accepted = status_values(system.arm_status[n_arm_status])
    start = int(accepted['start_ns'])
    settled = [s for s in system.joint_states if start <= stamp_ns(s)]
    # The planner's plan, recomputed with the core for exact curves and peaks.
    planned = plan(waypoints, method, timing, max_velocity=pe.MAX_VELOCITY,
                   max_acceleration=pe.MAX_ACCELERATION, start_velocity=boundary[0],
                   start_acceleration=boundary[1], end_velocity=boundary[2],
                   end_acceleration=boundary[3])
    positions = np.array([s.position for s in played + [final]])
    return {'status': values, 'trajectory': trajectory, 'plan': planned,
            'joint_states': played, 'final_state': final,
            'tool_path': arm.forward(positions)[:, :2],
            'tool_end': (pose.x, pose.y),
            'tracking': tracking, 'start_ns': start, 'states': settled,
            'started_late_by': float(accepted.get('started_late_by', 0.0)),
            'torque_limits': ArmSimConfig().torque_limits}


def _tracking_status(system, n_arm_status, timeout=10.0):
    """Return the end-of-trajectory status (level and values) of the trajectory accepted at n."""
    start = status_values(system.arm_status[n_arm_status])['start_ns']

    def finished():
        return [s for s in system.arm_status[n_arm_status + 1:]
                if status_values(s).get('start_ns') == start
                and 'settling_error' in status_values(s)]
    if not system.spin_until(finished, timeout):
        raise TimeoutError('the arm did not report the end of the trajectory (replaced?)')
    status = finished()[0]
    names = {DiagnosticStatus.OK: 'OK', DiagnosticStatus.WARN: 'WARN'}
    level = names.get(status.level, 'ERROR')
    return {'level': level, 'message': status.message, **status_values(status)}


def write_report(results, out_dir):
    """Write joint_curves.png, tool_path.png, tracking.png and the tables; return the paths."""
    os.makedirs(out_dir, exist_ok=True)
    metrics = [run_metrics(r) for r in results]
    paths = {name: os.path.join(out_dir, name)
             for name in ('joint_curves.png', 'tool_path.png', 'tracking.png', 'table.md',
                          'table.csv')}
    plot_joint_curves([r['plan'] for r in results], paths['joint_curves.png'], pe.JOINT_NAMES)
    plot_tool_path({f"{r['plan'].method} {r['plan'].timing}": r['tool_path'] for r in results},
                   pe.triangle_points(), pe.TRIANGLE_CORNERS, paths['tool_path.png'])
    plot_tracking(results, paths['tracking.png'], pe.JOINT_NAMES)
    with open(paths['table.md'], 'w', encoding='utf-8') as handle:
        handle.write(markdown_table(metrics) + '\n')
    write_csv(metrics, paths['table.csv'])
    return metrics, paths


def main(argv=None):
    """Run the demo, print the table, write figures and tables to --out."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--out', default='out', help='folder for figures and tables')
    args = parser.parse_args(argv)
    return run_main('demo', lambda: _run(args))


def _run(args):
    """Run the demo's stages and print its tables (main()'s body)."""
    os.makedirs(args.out, exist_ok=True)
    recording = os.path.join(args.out, RECORDING)
    results, counts = run_paper_example(recording=recording)
    metrics, paths = write_report(results, args.out)
    tool_table, tool_paths = run_tool_path_demo(args.out)
    seam_text, seam_paths = run_robot_seam_demo(args.out, 'ur5')
    print()
    print("Paper's example (Petrinec & Kovacic, Sec. III): 12 triangle waypoints, "
          'v <= 2 rad/s, a <= 10 rad/s^2, no jerk limit,')
    print('boundary v = [-0.1, 0.4, 0], a = [1, 3, 0] at both ends; '
          'played by arm_sim_node on the dynamic arm (MuJoCo, PD + inverse-dynamics '
          'feed-forward);')
    print("the tool should end at (1, 0); tracking and torques from the arm's status, "
          'settling 0.5 s after the end.')
    print()
    print(markdown_table(metrics))
    print()
    print(f'Straight tool paths: the triangle refined to {1e3 * TOLERANCE:g} mm of the lines '
          "between its tool waypoints (Taylor's method; rest to rest, no boundary values):")
    print()
    print(tool_table)
    print()
    print('A real arm: the UR5 (example-robot-data URDF), a seam of 4 straight edges on a '
          'table, tool down (the last edge turns it 60 deg), refined to 1 mm and 1 deg; '
          'velocity limits from the URDF, acceleration and jerk from '
          'config/ur5_joint_limits.yaml:')
    print()
    print(seam_text)
    print()
    print(f'Recorded to {os.path.abspath(recording)} (MCAP, the rosbag2 format): '
          + ', '.join(f'{topic} {count}' for topic, count in counts.items()))
    print()
    print(f'Figures and tables written to {os.path.abspath(args.out)}/: '
          + ', '.join(os.path.basename(p)
                      for p in list(paths.values()) + tool_paths + seam_paths))
    return 0


if __name__ == '__main__':
    sys.exit(main())
