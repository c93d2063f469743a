"""
``plot_trajectory``: plot a ``trajectory_msgs/JointTrajectory`` to a PNG.

Two sources:

* ``--file DUMP``: a YAML dump as written by
  ``ros2 topic echo --once --full-length /joint_trajectory > DUMP`` (or the
  same structure as JSON); the first message in the file is plotted.
  Without ``--full-length`` ``ros2 topic echo`` cuts every list after 128
  items and writes ``'...'``: such a dump is refused, saying so.
* ``--topic NAME`` (default ``joint_trajectory``): wait for one message on the
  topic (transient-local, so the planner's latest trajectory arrives even if
  it was published before), plot it and exit.

The figure shows positions, velocities and accelerations of every joint over
``time_from_start`` and the jerk as the difference quotient of the sampled
accelerations.  Sparse points that carry velocities (``output: knots``: one
per spline knot) are interpolated as joint_trajectory_controller does
(quintic with accelerations, cubic without) at :data:`PLOT_POINTS` times, so
the figure shows the motion the controller runs, not a polyline.

The file is untrusted: its size is bounded before it is read
(:data:`MAX_DUMP_BYTES`), and so are the joints and points plotted; a
dump of any other shape, or values that are not finite numbers or times
that do not increase, are refused with the reason (exit 1, no traceback).
"""

import argparse
import json
import math
import os
import sys

import numpy as np
import yaml

from .figures import plot_samples
from ..sim.playback import SampledTrajectory

# Fewer points than this (with velocities) are interpolated for the figure.
PLOT_POINTS = 2000
# The largest dump read [bytes]: a 100,000-point trajectory of 7 joints echoed
# as YAML is about 70 MB (a 4 MB dump took 17 s and 560 MB to parse).
MAX_DUMP_BYTES = 100 * 2**20
# The most joints plotted (a column of four plots each, 5 inches wide) and
# points (the planner's max_trajectory_points default).
MAX_JOINTS = 20
MAX_POINTS = 200_000
# What ros2 topic echo writes in place of the items it cut.
TRUNCATED = '...'
# yaml's C parser where there is one: a large echo parses several times faster.
_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)


def _number(value, where):
    """Return ``value`` as a finite float, or raise ValueError naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f'{where} must be a number, got {type(value).__name__}')
    if not math.isfinite(value):
        raise ValueError(f'{where} must be finite, got {value}')
    return float(value)


def _list(value, where):
    """Return ``value`` if it is a list (with no '...' item), or raise ValueError."""
    if not isinstance(value, list):
        raise ValueError(f'{where} must be a list, got {type(value).__name__}')
    if value and value[-1] == TRUNCATED:
        raise ValueError(f"{where} ends with '...': the dump was cut by ros2 topic echo; "
                         'save it with ros2 topic echo --once --full-length')
    return value


def _seconds(duration, where):
    if not isinstance(duration, dict):
        raise ValueError(f'{where} must be a mapping of sec and nanosec')
    sec = _number(duration.get('sec', 0), f'{where}.sec')
    nanosec = _number(duration.get('nanosec', 0), f'{where}.nanosec')
    return sec + 1e-9 * nanosec


def samples_from_dict(message):
    """
    Return times (K,), positions, velocities, accelerations (K, n) or None, names.

    Raises ValueError for anything not shaped like a JointTrajectory (a
    mapping of ``joint_names`` and ``points``), beyond :data:`MAX_JOINTS`
    joints or :data:`MAX_POINTS` points, with a value that is not a finite
    number, or cut by ``ros2 topic echo`` (``'...'``).
    """
    if not isinstance(message, dict):
        raise ValueError(f'the dump must hold a JointTrajectory (a mapping of joint_names and '
                         f'points), got {type(message).__name__}')
    names = _list(message.get('joint_names') or [], 'joint_names')
    points = _list(message.get('points') or [], 'points')
    if not names or not points:
        raise ValueError('the trajectory has no joint_names or no points')
    if not all(isinstance(n, str) for n in names):
        raise ValueError('joint_names must be strings')
    if len(names) > MAX_JOINTS or len(points) > MAX_POINTS:
        raise ValueError(f'{len(names)} joints and {len(points)} points: this plots at most '
                         f'{MAX_JOINTS} joints and {MAX_POINTS} points')
    if not all(isinstance(p, dict) for p in points):
        raise ValueError('every point must be a mapping (positions, velocities, ...)')
    times = np.array([_seconds(p.get('time_from_start', {}), f'points[{k}].time_from_start')
                      for k, p in enumerate(points)])
    back = np.flatnonzero(np.diff(times) <= 0.0)
    if back.size:
        k = int(back[0])
        raise ValueError(f'time_from_start must increase strictly: points {k} and {k + 1} '
                         f'are at {times[k]:.9g} and {times[k + 1]:.9g} s')
    columns = []
    for field in ('positions', 'velocities', 'accelerations'):
        rows = [_list(p.get(field) or [], f'points[{k}].{field}') for k, p in enumerate(points)]
        if all(len(r) == len(names) for r in rows):
            columns.append(np.array([[_number(v, f'points[{k}].{field}') for v in r]
                                     for k, r in enumerate(rows)]))
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
    """Read the first message of a YAML (ros2 topic echo) or JSON dump (at most MAX_DUMP_BYTES)."""
    with open(path, 'rb') as handle:
        data = handle.read(MAX_DUMP_BYTES + 1)
    if len(data) > MAX_DUMP_BYTES:
        raise ValueError(f'{path} is larger than {MAX_DUMP_BYTES} bytes: not read')
    try:
        text = data.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise ValueError(f'{path} is not UTF-8 text: {exc}') from None
    if text.lstrip().startswith('{'):
        return json.loads(text)
    for document in yaml.load_all(text, Loader=_LOADER):
        if document:
            return document
    raise ValueError(f'{path} holds no message')


def receive_one(topic, timeout, args=None):
    """
    Subscribe to ``topic`` and return the first JointTrajectory (as a dict).

    ``args``: the command line, for its ``--ros-args`` (remappings).
    """
    import rclpy
    from rclpy.node import Node
    from trajectory_msgs.msg import JointTrajectory

    from ..nodes.topics import LATCHED

    rclpy.init(args=args)
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


def output_path(out):
    """Return the PNG path ``--out`` names (a folder: trajectory.png in it), or ValueError."""
    if os.path.isdir(out):
        out = os.path.join(out, 'trajectory.png')
    if not out.lower().endswith('.png'):
        raise ValueError(f'--out must name a .png file (or a folder), got {out!r}')
    folder = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(folder):
        raise ValueError(f'--out: the folder {folder} does not exist')
    return out


def main(argv=None):
    """Plot a trajectory from a dump or a topic; 0 on success, 1 on an error, 130 on Ctrl-C."""
    from rclpy.exceptions import NameValidationException
    from rclpy.utilities import remove_ros_args

    full = list(sys.argv if argv is None else ['plot_trajectory', *argv])
    parser = argparse.ArgumentParser(
        prog='plot_trajectory', description='Plot a trajectory_msgs/JointTrajectory.')
    source = parser.add_mutually_exclusive_group()
    source.add_argument('--file', help='YAML (ros2 topic echo --full-length) or JSON dump '
                        'of the message')
    source.add_argument('--topic', default='joint_trajectory',
                        help='topic to read one from (default: %(default)s)')
    parser.add_argument('--out', default='trajectory.png',
                        help='PNG to write, or a folder for trajectory.png in it '
                        '(default: %(default)s)')
    parser.add_argument('--timeout', type=float, default=10.0,
                        help='seconds to wait on the topic (default: %(default)s)')
    args = parser.parse_args(remove_ros_args(full)[1:])
    if not (math.isfinite(args.timeout) and args.timeout > 0.0):
        parser.error(f'--timeout must be a finite number of seconds above 0, got {args.timeout}')
    try:
        out = output_path(args.out)
        message = (load_dump(args.file) if args.file
                   else receive_one(args.topic, args.timeout, full))
        times, pos, vel, acc, names = samples_from_dict(message)
        n_points = len(times)
        times, pos, vel, acc, interpolated = controller_view(times, pos, vel, acc)
        how = ', interpolated like joint_trajectory_controller' if interpolated else ''
        plot_samples(times, pos, vel, acc, names, out,
                     title=f'{args.file or args.topic}: {n_points} points{how}, '
                     f'{times[-1]:.3f} s')
    except KeyboardInterrupt:
        return 130
    except (OSError, ValueError, RuntimeError, TimeoutError, yaml.YAMLError,
            NameValidationException) as exc:
        # (RuntimeError: rcl's, such as a malformed --ros-args; NameValidationException:
        # a --topic that is no topic name.)
        print(f'plot_trajectory: {exc}', file=sys.stderr)
        return 1
    print(f'wrote {out}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
