"""
The demo's MCAP recording, read back with independent readers (mcap, mcap_ros2).

Two runs of the paper's example through both nodes, recorded as ``make
demo`` records them; the file is read with ``mcap``'s summary and decoded
with ``mcap_ros2`` (its own CDR decoder, driven by the schema texts in the
file), and compared with what the in-process client received.
"""

import math

from mcap.reader import make_reader
from mcap_ros2.reader import read_ros2_messages
import numpy as np
import pytest
from splines445_ros.robot import paper_example as pe
from splines445_ros.tools.demo import RECORDED_TOPICS, run_paper_example
from test_recording import SCHEMAS as TYPES  # the expected type of every recorded topic

RUNS = (('555', 'optimal'), ('445', 'uniform'))


@pytest.fixture(scope='module')
def recorded(tmp_path_factory):
    path = str(tmp_path_factory.mktemp('recording') / 'demo.mcap')
    results, counts = run_paper_example(RUNS, recording=path)
    messages = list(read_ros2_messages(path))
    with open(path, 'rb') as handle:
        summary = make_reader(handle).get_summary()
    return path, results, counts, messages, summary


def planar_tool(q, d1=1.1, d2=0.9):
    """Return the tool (x, y) of the paper's planar arm at joint angles q (written out)."""
    return (d1 * math.cos(q[0]) + d2 * math.cos(q[0] + q[1]),
            d1 * math.sin(q[0]) + d2 * math.sin(q[0] + q[1]))


def test_topics_types_and_schemas(recorded):
    _, _, _, _, summary = recorded
    assert sorted(TYPES) == sorted(t for t, _, _ in RECORDED_TOPICS)
    channels = {c.topic: c for c in summary.channels.values()}
    assert sorted(channels) == sorted(TYPES)
    for topic, channel in channels.items():
        schema = summary.schemas[channel.schema_id]
        assert channel.message_encoding == 'cdr'
        assert schema.encoding == 'ros2msg'
        assert schema.name == TYPES[topic]
    assert summary.statistics.message_count > 100


def test_counts_and_times(recorded):
    _, results, counts, messages, summary = recorded
    by_topic = {}
    for m in messages:
        by_topic.setdefault(m.channel.topic, []).append(m)
    # The file holds what the recorder says it wrote, and the summary agrees.
    assert {t: len(v) for t, v in by_topic.items()} == counts
    per_channel = summary.statistics.channel_message_counts
    assert {summary.channels[c].topic: n for c, n in per_channel.items()} == counts
    assert len(by_topic['/waypoints']) == len(RUNS)
    assert len(by_topic['/joint_trajectory']) == len(RUNS)
    assert len(by_topic['/planner_node/planned_path']) == len(RUNS)
    assert len(by_topic['/joint_states']) > 100
    assert len(by_topic['/arm_sim_node/status']) >= 2 * len(RUNS)  # accepted + tracking
    times = [m.log_time_ns for m in messages]
    assert all(b > a for a, b in zip(times, times[1:]))


def test_decoded_messages_equal_what_the_client_received(recorded):
    _, results, _, messages, _ = recorded
    trajectories = [m.ros_msg for m in messages if m.channel.topic == '/joint_trajectory']
    for decoded, result in zip(trajectories, results):
        received = result['trajectory']
        assert list(decoded.joint_names) == list(received.joint_names)
        assert len(decoded.points) == len(received.points)
        np.testing.assert_array_equal(
            np.array([p.positions for p in decoded.points]),
            np.array([p.positions for p in received.points]))
    requests = [m.ros_msg for m in messages if m.channel.topic == '/waypoints']
    np.testing.assert_array_equal(np.array([p.positions for p in requests[0].points]),
                                  pe.joint_waypoints())
    statuses = [m.ros_msg.message for m in messages if m.channel.topic == '/planner_node/status']
    for (method, timing), result in zip(RUNS, results):
        assert any(f'{method}/{timing}' in text for text in statuses)


def test_markers_trace_the_tool_through_the_waypoints(recorded):
    _, _, _, messages, _ = recorded
    waypoints = pe.joint_waypoints()
    for m in messages:
        if m.channel.topic != '/planner_node/planned_path':
            continue
        markers = m.ros_msg.markers
        assert markers[0].action == 3  # DELETEALL
        line = next(k for k in markers if k.ns == 'tool_path')
        spheres = next(k for k in markers if k.ns == 'waypoints')
        assert line.type == 4 and spheres.type == 7  # LINE_STRIP, SPHERE_LIST
        assert line.header.frame_id == 'base_link'
        for point, q in ((line.points[0], waypoints[0]), (line.points[-1], waypoints[-1])):
            assert (point.x, point.y) == pytest.approx(planar_tool(q), abs=1e-9)
        assert len(spheres.points) == len(waypoints)
        for point, q in zip(spheres.points, waypoints):
            assert (point.x, point.y) == pytest.approx(planar_tool(q), abs=1e-9)


def test_a_run_that_fails_still_leaves_a_finished_file(tmp_path):
    """A failing run (a method the planner refuses) after a good one: the good one is kept."""
    path = str(tmp_path / 'failed.mcap')
    with pytest.raises(RuntimeError, match='planner refused'):
        run_paper_example((('555', 'optimal'), ('999', 'optimal')), recording=path)
    messages = list(read_ros2_messages(path))
    assert sum(m.channel.topic == '/joint_trajectory' for m in messages) == 1
    with open(path, 'rb') as handle:
        assert make_reader(handle).get_summary().statistics.message_count == len(messages)
