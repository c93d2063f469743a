"""
:class:`McapRecording` on its own: one request through both nodes, read back independently.

The file is read with ``mcap``'s summary and decoded with ``mcap_ros2`` (its
own CDR decoder, built from the schema texts in the file); the decoded
messages are compared with what the in-process client received.  The schema
texts are checked against the installed ``.msg`` files and against the
dependencies that the generated message classes name
(``get_fields_and_field_types``), not against the recorder's parsing.
"""

import glob
import importlib
import math
import os
import re
import signal
import sys

from diagnostic_msgs.msg import DiagnosticStatus
from mcap.exceptions import EndOfFile
from mcap.reader import make_reader
from mcap.records import Message as McapMessage
from mcap.stream_reader import StreamReader
from mcap_ros2.reader import read_ros2_messages
import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from splines445_ros.nodes import topics
from splines445_ros.tools.command_line import run_main, TERMINATED
from splines445_ros.tools.in_process import InProcessSystem, LocalRos, waypoint_message
from splines445_ros.tools.recording import McapRecording, message_definition
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import Marker, MarkerArray
import yaml

JOINTS = ('joint1', 'joint2', 'joint3')
WAYPOINTS = np.array([[0.0, 0.2, 0.0], [0.5, 1.0, -0.5], [1.0, 0.5, 0.0]])
D1, D2 = 1.1, 0.9  # the planner's default link_lengths
# topic, message type, QoS (the publishers')
TOPICS = (
    ('/waypoints', JointTrajectory, topics.REQUEST_QOS),
    ('/joint_trajectory', JointTrajectory, topics.LATCHED),
    ('/joint_states', JointState, topics.STATE_QOS),
    ('/planner_node/planned_path', MarkerArray, topics.LATCHED),
    ('/planner_node/status', DiagnosticStatus, topics.STATUS_QOS),
    ('/arm_sim_node/status', DiagnosticStatus, topics.STATUS_QOS),
)
SCHEMAS = {
    '/waypoints': 'trajectory_msgs/msg/JointTrajectory',
    '/joint_trajectory': 'trajectory_msgs/msg/JointTrajectory',
    '/joint_states': 'sensor_msgs/msg/JointState',
    '/planner_node/planned_path': 'visualization_msgs/msg/MarkerArray',
    '/planner_node/status': 'diagnostic_msgs/msg/DiagnosticStatus',
    '/arm_sim_node/status': 'diagnostic_msgs/msg/DiagnosticStatus',
}
DURABILITY = {'/waypoints': 'volatile', '/joint_trajectory': 'transient_local',
              '/joint_states': 'volatile', '/planner_node/planned_path': 'transient_local',
              '/planner_node/status': 'transient_local', '/arm_sim_node/status': 'transient_local'}


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    path = str(tmp_path_factory.mktemp('recording') / 'run.mcap')
    with InProcessSystem(planner_parameters={'kinematics': 'planar_3dof'},
                         arm_parameters={'initial_positions': WAYPOINTS[0].tolist()}) as system:
        recording = McapRecording(system.client, path, TOPICS)
        start_ns = system.client.get_clock().now().nanoseconds
        assert system.spin_until(lambda: all(s.get_publisher_count() >= 1
                                             for s in recording.subscriptions), 10.0)
        n_arm_status = len(system.arm_status)
        status, trajectory = system.request(waypoint_message(JOINTS, WAYPOINTS))
        assert status.level == DiagnosticStatus.OK, status.message
        duration = trajectory.points[-1].time_from_start
        system.wait_until_played(n_arm_status, duration.sec + 1e-9 * duration.nanosec)
        assert system.spin_until(lambda: recording.counts['/planner_node/planned_path'] >= 1,
                                 5.0)
        system.spin_for(0.1)
        recording.close()
        end_ns = system.client.get_clock().now().nanoseconds
        received = {'trajectory': trajectory, 'planner_status': list(system.planner_status),
                    'arm_status': list(system.arm_status),
                    'joint_states': list(system.joint_states)}
    counts = dict(recording.counts)
    messages = list(read_ros2_messages(path))
    with open(path, 'rb') as handle:
        reader = make_reader(handle)
        header, summary = reader.get_header(), reader.get_summary()
    return {'messages': messages, 'header': header, 'summary': summary, 'counts': counts,
            'received': received, 'window': (start_ns, end_ns)}


def by_topic(messages):
    found = {}
    for m in messages:
        found.setdefault(m.channel.topic, []).append(m)
    return found


def test_profile_topics_schemas_and_qos(recorded):
    summary = recorded['summary']
    assert recorded['header'].profile == 'ros2'
    channels = {c.topic: c for c in summary.channels.values()}
    assert sorted(channels) == sorted(SCHEMAS)
    for topic, channel in channels.items():
        schema = summary.schemas[channel.schema_id]
        assert (channel.message_encoding, schema.encoding) == ('cdr', 'ros2msg')
        assert schema.name == SCHEMAS[topic]
        # What ros2 bag play offers the topic with (rosbag2's channel metadata).
        profiles = yaml.safe_load(channel.metadata['offered_qos_profiles'])
        assert len(profiles) == 1
        profile = profiles[0]
        assert profile['reliability'] == 'reliable' and profile['history'] == 'keep_last'
        assert profile['durability'] == DURABILITY[topic]
        qos = next(q for t, _, q in TOPICS if t == topic)
        assert profile['depth'] == qos.depth
    # One schema per type, however many topics use it.
    assert len(summary.schemas) == len(set(SCHEMAS.values()))


def test_message_counts(recorded):
    messages, summary, counts = recorded['messages'], recorded['summary'], recorded['counts']
    found = {t: len(v) for t, v in by_topic(messages).items()}
    assert found == counts
    per_channel = summary.statistics.channel_message_counts
    assert {summary.channels[c].topic: n for c, n in per_channel.items()} == counts
    assert summary.statistics.message_count == len(messages)
    assert counts['/waypoints'] == 1
    assert counts['/joint_trajectory'] == 1
    assert counts['/planner_node/planned_path'] == 1
    assert counts['/joint_states'] > 20  # 50 Hz over a move of about a second and more
    assert counts['/planner_node/status'] >= 1
    assert counts['/arm_sim_node/status'] >= 1


def test_log_times_increase_within_the_run(recorded):
    times = [m.log_time_ns for m in recorded['messages']]
    assert all(b > a for a, b in zip(times, times[1:]))
    assert [m.publish_time_ns for m in recorded['messages']] == times
    start_ns, end_ns = recorded['window']
    assert start_ns <= times[0] and times[-1] <= end_ns
    stats = recorded['summary'].statistics
    assert (stats.message_start_time, stats.message_end_time) == (times[0], times[-1])


def test_decoded_messages_are_what_the_client_received(recorded):
    found = by_topic(recorded['messages'])
    received = recorded['received']
    sent = received['trajectory']
    (trajectory,) = [m.ros_msg for m in found['/joint_trajectory']]
    assert list(trajectory.joint_names) == list(sent.joint_names) == list(JOINTS)
    assert len(trajectory.points) == len(sent.points) > 10
    for field in ('positions', 'velocities', 'accelerations'):
        np.testing.assert_array_equal([getattr(p, field) for p in trajectory.points],
                                      [getattr(p, field) for p in sent.points])
    assert [(p.time_from_start.sec, p.time_from_start.nanosec) for p in trajectory.points] == \
        [(p.time_from_start.sec, p.time_from_start.nanosec) for p in sent.points]
    (request,) = [m.ros_msg for m in found['/waypoints']]
    np.testing.assert_array_equal([p.positions for p in request.points], WAYPOINTS)
    # Statuses: the same messages, in order, as the client's own subscriptions got.
    for topic, key in (('/planner_node/status', 'planner_status'),
                       ('/arm_sim_node/status', 'arm_status')):
        recorded_texts = [m.ros_msg.message for m in found[topic]]
        received_texts = [s.message for s in received[key]]
        assert recorded_texts == received_texts[len(received_texts) - len(recorded_texts):]
    # joint_states: a contiguous run of those the client got, with the same contents.
    states = [m.ros_msg for m in found['/joint_states']]
    got = {(s.header.stamp.sec, s.header.stamp.nanosec): s for s in received['joint_states']}
    for state in states:
        other = got[(state.header.stamp.sec, state.header.stamp.nanosec)]
        assert list(state.name) == list(other.name)
        np.testing.assert_array_equal(state.position, other.position)


def planar_tool(q):
    """Tool position (x, y) of the planar arm at joints q, written out."""
    return (D1 * math.cos(q[0]) + D2 * math.cos(q[0] + q[1]),
            D1 * math.sin(q[0]) + D2 * math.sin(q[0] + q[1]))


def test_decoded_markers_draw_the_planned_path(recorded):
    (markers,) = [m.ros_msg.markers for m in by_topic(recorded['messages'])
                  ['/planner_node/planned_path']]
    assert markers[0].action == Marker.DELETEALL
    line = next(m for m in markers if m.ns == 'tool_path')
    spheres = next(m for m in markers if m.ns == 'waypoints')
    assert (line.type, spheres.type) == (Marker.LINE_STRIP, Marker.SPHERE_LIST)
    assert all(m.header.frame_id == 'base_link' for m in markers)
    for point, q in ((line.points[0], WAYPOINTS[0]), (line.points[-1], WAYPOINTS[-1])):
        assert (point.x, point.y, point.z) == pytest.approx((*planar_tool(q), 0.0), abs=1e-9)
    np.testing.assert_allclose([(p.x, p.y) for p in spheres.points],
                               [planar_tool(q) for q in WAYPOINTS], atol=1e-9)


def installed_msg(package, name):
    """Return the text of an installed .msg file (found here, not by the recorder)."""
    prefixes = os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) + [sys.prefix]
    for prefix in filter(None, prefixes):
        for path in glob.glob(os.path.join(prefix, 'share', package, 'msg', f'{name}.msg')):
            with open(path, encoding='utf-8') as handle:
                return handle.read()
    raise FileNotFoundError(f'{package}/msg/{name}.msg')


def closure(package, name):
    """Every message type ``package/Name`` uses, from the generated classes' field types."""
    found, todo = set(), [(package, name)]
    while todo:
        pkg, typ = todo.pop()
        cls = getattr(importlib.import_module(f'{pkg}.msg'), typ)
        for field_type in cls.get_fields_and_field_types().values():
            for used in re.findall(r'([a-z][a-z0-9_]*)/([A-Z][A-Za-z0-9_]*)', field_type):
                if used not in found:
                    found.add(used)
                    todo.append(used)
    return found


def test_schema_texts_are_the_installed_definitions_with_every_dependency(recorded):
    summary = recorded['summary']
    separator = '\n' + '=' * 80 + '\n'
    for schema in summary.schemas.values():
        package, _, name = schema.name.split('/')
        blocks = schema.data.decode('utf-8').split(separator)
        assert blocks[0].rstrip('\n') == installed_msg(package, name).rstrip('\n')
        named = []
        for block in blocks[1:]:
            title, _, text = block.partition('\n')
            assert title.startswith('MSG: ')
            dependency = tuple(title[len('MSG: '):].split('/'))
            assert len(dependency) == 2  # pkg/Type, as rosbag2 writes them
            assert text.rstrip('\n') == installed_msg(*dependency).rstrip('\n')
            named.append(dependency)
        assert len(named) == len(set(named))  # each once
        assert set(named) == closure(package, name)
    marker_array = next(s for s in summary.schemas.values()
                        if s.name == 'visualization_msgs/msg/MarkerArray')
    assert b'MSG: builtin_interfaces/Time' in marker_array.data


def test_ties_on_the_clock_are_bumped_by_a_nanosecond(tmp_path):
    # With sim time and no /clock, every message arrives at time 0.
    path = str(tmp_path / 'ties.mcap')
    with LocalRos() as ros:
        node = ros.add(Node('tie_recorder', context=ros.context, parameter_overrides=[
            Parameter('use_sim_time', value=True)]))
        publisher = node.create_publisher(String, 'ties', topics.REQUEST_QOS)
        with McapRecording(node, path, [('/ties', String, topics.REQUEST_QOS)]) as recording:
            assert ros.spin_until(lambda: publisher.get_subscription_count() >= 1, 10.0)
            for k in range(5):
                publisher.publish(String(data=f'tie {k}'))
            assert ros.spin_until(lambda: recording.counts['/ties'] == 5, 10.0)
            assert node.get_clock().now().nanoseconds == 0
    messages = list(read_ros2_messages(path))
    assert [m.ros_msg.data for m in messages] == [f'tie {k}' for k in range(5)]
    assert [m.log_time_ns for m in messages] == [1, 2, 3, 4, 5]


def test_definitions_are_found_without_an_ament_index(monkeypatch):
    # A venv run without install/setup.bash has no AMENT_PREFIX_PATH; the
    # wheels' share folders below sys.prefix hold the .msg files.
    if not os.path.isfile(os.path.join(sys.prefix, 'share', 'trajectory_msgs', 'msg',
                                       'JointTrajectory.msg')):
        pytest.skip('message packages not installed below sys.prefix (apt ROS)')
    indexed = message_definition(MarkerArray)
    monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)
    assert message_definition(MarkerArray) == indexed


@pytest.mark.skipif(not os.path.exists('/dev/full'), reason='needs /dev/full (Linux)')
def test_a_full_disk_stops_the_recording_not_the_executor():
    """The write's OSError is logged and kept; close() raises it and still closes the file."""
    with LocalRos() as ros:
        node = ros.add(Node('full_recorder', context=ros.context))
        publisher = node.create_publisher(String, 'filling', topics.REQUEST_QOS)
        recording = McapRecording(node, '/dev/full', [('/filling', String, topics.REQUEST_QOS)])
        assert ros.spin_until(lambda: publisher.get_subscription_count() >= 1, 10.0)
        rng = np.random.default_rng(0)
        for _ in range(40):    # 4 MB that compress poorly: far more than a chunk
            publisher.publish(String(data=''.join(rng.choice(list('abcdefghij'), 100_000))))
            ros.spin_for(0.01)
        assert ros.spin_until(lambda: recording.error is not None, 10.0), recording.counts
        assert 'No space left' in recording.error
        stopped = recording.counts['/filling']
        publisher.publish(String(data='after'))
        ros.spin_for(0.2)       # the executor goes on; nothing more is written
        assert recording.counts['/filling'] == stopped
        with pytest.raises(OSError):
            recording.close()
        recording.close()       # closed: a second close does nothing


def test_a_recording_ended_by_sigterm_is_finished(tmp_path):
    """``kill`` (SIGTERM) left an empty file: the demo's recording was one unwritten chunk."""
    path = str(tmp_path / 'terminated.mcap')
    sent = []

    def body():
        with LocalRos() as ros:
            node = ros.add(Node('terminated_recorder', context=ros.context))
            publisher = node.create_publisher(String, 'chatter', topics.REQUEST_QOS)
            with McapRecording(node, path, [('/chatter', String, topics.REQUEST_QOS)]) as rec:
                assert ros.spin_until(lambda: publisher.get_subscription_count() >= 1, 10.0)
                for k in range(5):
                    publisher.publish(String(data=f'before {k}'))
                    sent.append(f'before {k}')
                assert ros.spin_until(lambda: rec.counts['/chatter'] == 5, 10.0)
                os.kill(os.getpid(), signal.SIGTERM)
                ros.spin_for(10.0)  # the handler raises in here
        return 0

    assert run_main('recorder', body) == TERMINATED
    assert [m.ros_msg.data for m in read_ros2_messages(path)] == sent
    with open(path, 'rb') as handle:
        assert make_reader(handle).get_summary().statistics.message_count == 5


def test_a_killed_recording_keeps_its_written_chunks(tmp_path):
    """SIGKILL runs no clean-up: every chunk but the last is on disk, read as a stream."""
    path = str(tmp_path / 'killed.mcap')
    with LocalRos() as ros:
        node = ros.add(Node('killed_recorder', context=ros.context))
        publisher = node.create_publisher(String, 'chatter', topics.REQUEST_QOS)
        recording = McapRecording(node, path, [('/chatter', String, topics.REQUEST_QOS)])
        assert ros.spin_until(lambda: publisher.get_subscription_count() >= 1, 10.0)
        rng = np.random.default_rng(1)
        for k in range(20):  # 20 x 10 kB that compress poorly: more than a few chunks
            publisher.publish(String(data=''.join(rng.choice(list('abcdefghij'), 10_000))))
        assert ros.spin_until(lambda: recording.counts['/chatter'] == 20, 10.0)
        # Not closed: what a killed process leaves (its file buffer flushed by the OS'
        # own close at exit would be more, not less).
        with open(path, 'rb') as handle:
            records = StreamReader(handle).records
            found = 0
            with pytest.raises(EndOfFile):
                for record in records:
                    found += isinstance(record, McapMessage)
        assert found >= 10, found
        recording.close()
