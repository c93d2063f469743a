"""
``plot_trajectory``: plot a ``trajectory_msgs/JointTrajectory`` to a PNG.

Two sources:

* ``--file DUMP``: a YAML dump as written by
  ``ros2 topic echo --once /joint_trajectory > DUMP`` (or the same structure
  as JSON); the first message in the file is plotted.
* ``--topic NAME`` (default ``joint_trajectory``): wait for one message on the
  topic (transient-local, so the planner's latest trajectory arrives even if
  it was published before), plot it and exit.

The figure shows positions, velocities and accelerations of every joint over
``time_from_start`` and the jerk as the difference quotient of the sampled
accelerations.  Sparse points that carry velocities (``output: knots``: one
per spline knot) are interpolated as joint_trajectory_controller does
(quintic with accelerations, cubic without) at :data:`PLOT_POINTS` times, so
the figure shows the motion the controller runs, not a polyline.
"""

import argparse
import json
import sys

import numpy as np
import yaml

from .figures import plot_samples
from ..sim.playback import SampledTrajectory

# Fewer points than this (with velocities) are interpolated for the figure.
PLOT_POINTS = 2000


def _seconds(duration):
    return float(duration.get('sec', 0)) + 1e-9 * float(duration.get('nanosec', 0))


def samples_from_dict(message):
    """Return times (K,), positions, velocities, accelerations (K, n) or None, names."""
    names = list(message.get('joint_names') or [])
    points = message.get('points') or []
    if not names or not points:
        raise ValueError('the trajectory has no joint_names or no points')
    times = np.array([_seconds(p.get('time_from_start', {})) for p in points])
    columns = []
    for field in ('positions', 'velocities', 'accelerations'):
        rows = [p.get(field) or [] for p in points]
        if all(len(r) == len(names) for r in rows):
            columns.append(np.array(rows, dtype=float))
        elif field == 'positions':
            raise ValueError('every point needs one position per joint')
        else:
            columns.append(None)
    return times, columns[0], columns[1], columns[2], names


def controller_view(times, positions, velocities, accelerations, count=PLOT_POINTS):
    """
    Return the points, interpolated like joint_trajectory_controller when sparse.

    With velocities on every point and fewer than ``count`` points, the
    result holds ``count`` evenly spaced times plus the points' own, with the
    controller's interpolation between them; otherwise the points as given.
    Returns times, positions, velocities, accelerations and whether it
    interpolated.
    """
    if velocities is None or len(times) < 2 or len(times) >= count:
        return times, positions, velocities, accelerations, False
    played = SampledTrajectory(times, positions, velocities, accelerations)
    t = np.union1d(np.linspace(times[0], times[-1], count), times)[:-1]
    pos, vel, acc = played.states_at(t)
    last_acc = np.zeros((1, positions.shape[1])) if accelerations is None else accelerations[-1:]
    return (np.append(t, times[-1]), np.vstack([pos, positions[-1:]]),
            np.vstack([vel, velocities[-1:]]), np.vstack([acc, last_acc]), True)


def message_to_dict(msg):
    """Return the fields of a JointTrajectory that plotting needs, as plain data."""
    return {'joint_names': list(msg.joint_names),
            'points': [{'positions': list(p.positions), 'velocities': list(p.velocities),
                        'accelerations': list(p.accelerations),
                        'time_from_start': {'sec': p.time_from_start.sec,
                                            'nanosec': p.time_from_start.nanosec}}
                       for p in msg.points]}


def load_dump(path):
    """Read the first message of a YAML (ros2 topic echo) or JSON dump."""
    with open(path, encoding='utf-8') as handle:
        text = handle.read()
    if text.lstrip().startswith('{'):
        return json.loads(text)
    for document in yaml.safe_load_all(text):
        if document:
            return document
    raise ValueError(f'{path} holds no message')


def receive_one(topic, timeout):
    """Subscribe to ``topic`` and return the first JointTrajectory (as a dict)."""
    import rclpy
    from rclpy.node import Node
    from trajectory_msgs.msg import JointTrajectory

    from ..nodes.topics import LATCHED

    rclpy.init()
    node = Node('plot_trajectory')
    received = []
    node.create_subscription(JointTrajectory, topic, received.append, LATCHED)
    try:
        deadline = node.get_clock().now().nanoseconds + int(timeout * 1e9)
        while not received and node.get_clock().now().nanoseconds < deadline:
            rclpy.spin_once(node, timeout_sec=0.1)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    if not received:
        raise TimeoutError(f'no JointTrajectory on {topic} within {timeout} s')
    return message_to_dict(received[0])


def main(argv=None):
    """Plot a trajectory from a dump or a topic."""
    parser = argparse.ArgumentParser(description='Plot a trajectory_msgs/JointTrajectory.')
    source = parser.add_mutually_exclusive_group()
    source.add_argument('--file', help='YAML (ros2 topic echo) or JSON dump of the message')
    source.add_argument('--topic', default='joint_trajectory', help='topic to read one from')
    parser.add_argument('--out', default='trajectory.png', help='PNG to write')
    parser.add_argument('--timeout', type=float, default=10.0, help='seconds to wait (topic)')
    args, _ = parser.parse_known_args(argv)
    try:
        message = load_dump(args.file) if args.file else receive_one(args.topic, args.timeout)
        times, pos, vel, acc, names = samples_from_dict(message)
    except (OSError, ValueError, TimeoutError, yaml.YAMLError) as exc:
        print(f'plot_trajectory: {exc}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
    n_points = len(times)
    times, pos, vel, acc, interpolated = controller_view(times, pos, vel, acc)
    how = ', interpolated like joint_trajectory_controller' if interpolated else ''
    plot_samples(times, pos, vel, acc, names, args.out,
                 title=f'{args.file or args.topic}: {n_points} points{how}, {times[-1]:.3f} s')
    print(f'wrote {args.out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
