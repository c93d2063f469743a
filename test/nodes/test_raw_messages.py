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

FIELDS = ('positions', 'velocities', 'accelerations', 'effort')


def trajectory(points, joints, name_length, fields, frame_length=200):
    msg = JointTrajectory()
    msg.header.frame_id = 'f' * frame_length
    msg.joint_names = [f'{k:0{name_length}d}'[-name_length:] for k in range(joints)]
    for k in range(points):
        values = [0.1 * k] * joints
        msg.points.append(JointTrajectoryPoint(**{field: values for field in fields}))
    return msg


@settings(max_examples=examples(40), deadline=None)
@given(points=st.one_of(st.integers(1, 300), st.integers(2000, 4000)),
       joints=st.integers(1, 12), name_length=st.integers(1, 255),
       frame_length=st.integers(0, 60_000), fields=st.sets(st.sampled_from(FIELDS)))
def test_every_trajectory_within_the_counts_is_within_the_bound(points, joints, name_length,
                                                                frame_length, fields):
    msg = trajectory(points, joints, name_length, sorted(fields), frame_length)
    assert len(serialize_message(msg)) <= raw_messages.joint_trajectory_bytes(points, joints)


def test_the_trajectory_bound_is_tight_per_point_and_bites_beyond():
    """Its points part is the full points' own, to the padding; ten times the points fail."""
    joints, points = 7, 5000
    full = len(serialize_message(trajectory(points, joints, 20, FIELDS, frame_length=0)))
    bound = raw_messages.joint_trajectory_bytes(points, joints)
    fixed = raw_messages.joint_trajectory_bytes(0, joints)
    assert full <= bound
    assert (bound - fixed) - full <= 4 * 4 * points    # at most the padding of 4 sequences
    ten_times = serialize_message(trajectory(10 * points, joints, 20, ('positions',)))
    reason = raw_messages.too_large(ten_times, bound)
    assert reason is not None and reason.startswith('the message has')


def test_pose_arrays_and_strings_within_their_bounds():
    poses = PoseArray(poses=[Pose() for _ in range(500)])
    poses.header.frame_id = 'b' * 60_000
    assert len(serialize_message(poses)) <= raw_messages.pose_array_bytes(500)
    poses.header.frame_id = ''
    assert len(serialize_message(poses)) > (raw_messages.pose_array_bytes(400)
                                            - raw_messages.HEADER_BYTES)
    for character in ('a', 'é', '€', '😀'):   # one to four bytes in UTF-8
        text = character * 1000
        assert len(serialize_message(String(data=text))) <= raw_messages.string_bytes(1000)
    assert raw_messages.too_large(b'x' * 10, 10) is None
