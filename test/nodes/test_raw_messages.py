"""
The byte bounds of raw subscriptions hold every message the nodes accept, and bite beyond.

Real messages are serialized by rclpy here (the middleware's CDR) and compared
with the bounds of :mod:`splines445_ros.nodes.raw_messages`.
"""

from example_counts import examples
from geometry_msgs.msg import Pose, PoseArray
from hypothesis import given, settings, strategies as st
from rclpy.serialization import serialize_message
from splines445_ros.nodes import raw_messages
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint


def trajectory(points, joints, name_length, fields):
    msg = JointTrajectory()
    msg.header.frame_id = 'f' * 200
    msg.joint_names = [f'{k:0{name_length}d}'[-name_length:] for k in range(joints)]
    for k in range(points):
        values = [0.1 * k] * joints
        msg.points.append(JointTrajectoryPoint(**{field: values for field in fields}))
    return msg


@settings(max_examples=examples(40), deadline=None)
@given(points=st.integers(1, 300), joints=st.integers(1, 12), name_length=st.integers(1, 255),
       fields=st.sampled_from([('positions',), ('positions', 'velocities'),
                               ('positions', 'velocities', 'accelerations')]))
def test_every_trajectory_within_the_counts_is_within_the_bound(points, joints, name_length,
                                                                fields):
    size = len(serialize_message(trajectory(points, joints, name_length, fields)))
    assert size <= raw_messages.joint_trajectory_bytes(points, joints)


def test_the_trajectory_bound_bites_on_the_points():
    """Beyond the header's allowance it is tight: ten times the points are refused."""
    full = len(serialize_message(trajectory(1000, 7, 20, ('positions', 'velocities',
                                                          'accelerations'))))
    bound = raw_messages.joint_trajectory_bytes(1000, 7)
    allowance = raw_messages.NAMES_BYTES + 7 * raw_messages.NAME_BYTES
    assert full <= bound <= full + allowance
    ten_times = serialize_message(trajectory(10_000, 7, 20, ('positions',)))
    reason = raw_messages.too_large(ten_times, bound, 'trajectory')
    assert reason is not None and reason.startswith('trajectory rejected unread')


def test_pose_arrays_and_strings_within_their_bounds():
    poses = PoseArray(poses=[Pose() for _ in range(500)])
    poses.header.frame_id = 'base_link'
    assert len(serialize_message(poses)) <= raw_messages.pose_array_bytes(500)
    assert len(serialize_message(poses)) > (raw_messages.pose_array_bytes(400)
                                            - raw_messages.NAMES_BYTES)
    text = 'é' * 1000     # two bytes each in UTF-8
    assert len(serialize_message(String(data=text))) <= raw_messages.string_bytes(1000)
    assert raw_messages.too_large(b'x' * 10, 10, 'it') is None
