"""
A recording of topics in MCAP, rosbag2's default storage (``ros2 bag``, Foxglove).

:class:`McapRecording` subscribes to topics on a node, as serialized messages
(``raw=True``: nothing is deserialized), and writes each to an MCAP file the
way rosbag2 does: profile ``ros2``, one schema per message type named
``pkg/msg/Type`` with encoding ``ros2msg`` and the full definition text (the
type's ``.msg`` file followed by every type it uses, each after a line of 80
``=`` and ``MSG: pkg/Type``), channels with message encoding ``cdr`` and
their ``offered_qos_profiles`` (the QoS given for the topic, in the YAML
form of Jazzy's rosbag2, so that ``ros2 bag play`` offers latched topics as
transient-local again), and log and publish times from the node's clock at
receipt, strictly increasing.

The ``.msg`` texts are read from the installed message packages (their share
folders, found through the ament index, else below this Python's prefix as
the PyPI wheels install them): nothing is copied into this code.
"""

import os
import re
import sys

from mcap.writer import Writer
import yaml

# Types of the ROS 2 interface definition language that are not messages.
PRIMITIVES = {'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16',
              'uint16', 'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'}
SEPARATOR = '=' * 80


def type_name(msg_type):
    """Return ``pkg/msg/Type`` of a message class, e.g. ``trajectory_msgs/msg/JointTrajectory``."""
    package = msg_type.__module__.split('.')[0]
    return f'{package}/msg/{msg_type.__name__}'


def _share_folders(package):
    folders = []
    try:
        from ament_index_python.packages import (get_package_share_directory,
                                                 PackageNotFoundError)
        try:
            folders.append(get_package_share_directory(package))
        except (PackageNotFoundError, OSError):  # not indexed, or AMENT_PREFIX_PATH unset
            pass
    except ImportError:
        pass
    folders.append(os.path.join(sys.prefix, 'share', package))
    return folders


def message_text(package, name):
    """Return the text of ``<package>/msg/<name>.msg`` as installed (FileNotFoundError)."""
    for folder in _share_folders(package):
        path = os.path.join(folder, 'msg', f'{name}.msg')
        if os.path.isfile(path):
            with open(path, encoding='utf-8') as handle:
                return handle.read()
    raise FileNotFoundError(f'no definition of {package}/msg/{name} in '
                            f'{_share_folders(package)}')


def used_types(text, package):
    """Return the ``(package, name)`` of every message type the fields of ``text`` use."""
    found = []
    for line in text.splitlines():
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        field_type = re.split(r'[\s\[<]', line, maxsplit=1)[0]
        if field_type in PRIMITIVES:
            continue
        parts = field_type.split('/')
        if len(parts) == 1:
            used = (package, parts[0])
        else:
            used = (parts[0], parts[-1])
        if used not in found:
            found.append(used)
    return found


def message_definition(msg_type):
    """Return the full ``ros2msg`` definition of a message class, dependencies appended."""
    package, name = msg_type.__module__.split('.')[0], msg_type.__name__
    text = message_text(package, name)
    parts = [text.rstrip('\n')]
    done = {(package, name)}
    queue = used_types(text, package)
    while queue:
        dependency = queue.pop(0)
        if dependency in done:
            continue
        done.add(dependency)
        dependency_text = message_text(*dependency)
        parts.append(f'{SEPARATOR}\nMSG: {dependency[0]}/{dependency[1]}\n'
                     + dependency_text.rstrip('\n'))
        queue += [d for d in used_types(dependency_text, dependency[0]) if d not in done]
    return '\n'.join(parts) + '\n'


def offered_qos_profiles(qos):
    """
    Return the ``offered_qos_profiles`` channel metadata of ``qos`` as rosbag2 writes it.

    A YAML list of one profile, in the form of Jazzy's rosbag2 (metadata
    version 9): policies by their rmw names (``keep_last``, ``reliable``,
    ``transient_local``, ...), durations as ``sec`` and ``nsec``.
    ``ros2 bag play`` publishes the topic with this profile.
    """
    def duration(value):
        sec, nsec = divmod(int(value.nanoseconds), 1_000_000_000)
        return {'sec': sec, 'nsec': nsec}
    profile = {'history': qos.history.name.lower(), 'depth': int(qos.depth),
               'reliability': qos.reliability.name.lower(),
               'durability': qos.durability.name.lower(),
               'deadline': duration(qos.deadline), 'lifespan': duration(qos.lifespan),
               'liveliness': qos.liveliness.name.lower(),
               'liveliness_lease_duration': duration(qos.liveliness_lease_duration),
               'avoid_ros_namespace_conventions': bool(qos.avoid_ros_namespace_conventions)}
    return yaml.safe_dump([profile], sort_keys=False, default_flow_style=False)


# Messages are written to the file a chunk at a time: mcap's default 1 MiB held a whole
# demo's recording in memory, so a process killed (SIGKILL) left an empty file; with 64
# KiB every chunk but the last is on disk (``mcap recover`` reads them), for 1-2 % more
# file (the chunks' indexes).
CHUNK_BYTES = 64 * 1024


class McapRecording:
    """Record ``topics`` [(name, message class, QoS)] seen by ``node`` to ``path``."""

    def __init__(self, node, path, topics):
        """
        Open ``path``, register the schemas and channels, and subscribe.

        A write that fails later (a full disk) stops the recording with a
        logged error, its reason in :attr:`error`; the executor goes on.
        """
        self._node = node
        self.error = None
        self.subscriptions = []
        self._handle = open(path, 'wb')
        try:
            self._start(topics)
        except BaseException:
            self._handle.close()    # (no file handle left open by a failed start)
            self._handle = None
            raise

    def _start(self, topics):
        """Write the header, the schemas and the channels; subscribe to ``topics``."""
        node = self._node
        self._writer = Writer(self._handle, chunk_size=CHUNK_BYTES)
        self._writer.start(profile='ros2', library='splines445_ros')
        self._last_ns = 0
        self.counts = {}
        schemas = {}
        for topic, msg_type, qos in topics:
            name = type_name(msg_type)
            if name not in schemas:
                schemas[name] = self._writer.register_schema(
                    name=name, encoding='ros2msg',
                    data=message_definition(msg_type).encode('utf-8'))
            channel = self._writer.register_channel(
                topic=topic, message_encoding='cdr', schema_id=schemas[name],
                metadata={'offered_qos_profiles': offered_qos_profiles(qos)})
            self.counts[topic] = 0
            self.subscriptions.append(node.create_subscription(
                msg_type, topic, self._recorder(topic, channel), qos, raw=True))

    def _recorder(self, topic, channel):
        def record(data):
            if self.error is not None:
                return
            now = max(self._node.get_clock().now().nanoseconds, self._last_ns + 1)
            self._last_ns = now
            try:
                self._writer.add_message(channel_id=channel, log_time=now, data=bytes(data),
                                         publish_time=now, sequence=self.counts[topic])
            except OSError as exc:
                self.error = f'recording stopped: {exc}'
                self._node.get_logger().error(self.error)
                return
            self.counts[topic] += 1
        return record

    def close(self):
        """Stop recording and finish the file (its summary and index); OSError if it cannot."""
        if self._handle is None:
            return
        for subscription in self.subscriptions:
            self._node.destroy_subscription(subscription)
        self.subscriptions = []
        handle, self._handle = self._handle, None
        try:
            self._writer.finish()
        finally:
            handle.close()      # whatever the finish did (its own flush may fail too)

    def __enter__(self):
        """Use as a context manager."""
        return self

    def __exit__(self, *exc):
        """Finish the file on exit."""
        self.close()
