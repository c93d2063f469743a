"""
Messages bounded before they are read: the most bytes an accepted message can take.

A subscription created with ``raw=True`` hands the node the serialized
message (CDR, as the middleware carries it); its length is compared here
with the largest message the node would accept, before rclpy builds a
Python object of every point (a 1 million-point ``JointTrajectory`` takes
about 13 s to read on this machine, and would only then be refused for its
point count).  The bounds are generous: after the 4-byte encapsulation
header, a CDR sequence of ``n`` float64 is a 4-byte length, up to 4 bytes
of padding and ``8 n`` bytes, a joint name takes up to :data:`NAME_BYTES`
(names of up to 255 characters), and the header and frame id are allowed
:data:`HEADER_BYTES` (a frame id of up to some 65,000 characters).  The
count checks after reading stay as they are.
"""

from rclpy.serialization import deserialize_message

# The CDR encapsulation header of every serialized message [bytes].
ENCAPSULATION_BYTES = 4
# Header (stamp, frame id) of one message [bytes].
HEADER_BYTES = 64 * 1024
# A joint name: its length, up to 255 characters, the terminating 0, padding [bytes].
NAME_BYTES = 4 + 256 + 3


def _float64_sequence(count):
    return 4 + 4 + 8 * count


def joint_trajectory_bytes(points, joints):
    """
    Return the most bytes a ``JointTrajectory`` of ``points`` points of ``joints`` joints takes.

    Each point carries positions, velocities, accelerations and efforts
    (``joints`` values each) and its ``time_from_start``.
    """
    point = 4 * _float64_sequence(joints) + 8
    return ENCAPSULATION_BYTES + HEADER_BYTES + 4 + joints * NAME_BYTES + 4 + points * point


def pose_array_bytes(poses):
    """Return the most bytes a ``PoseArray`` of ``poses`` poses takes (7 float64 a pose)."""
    return ENCAPSULATION_BYTES + HEADER_BYTES + 4 + 4 + poses * 7 * 8


def string_bytes(characters):
    """Return the most bytes a ``String`` of ``characters`` characters takes (UTF-8)."""
    return ENCAPSULATION_BYTES + 4 + 4 * characters + 1


def too_large(data, limit):
    """Return why a serialized message ``data`` is refused unread, or None."""
    if len(data) <= limit:
        return None
    return (f'the message has {len(data)} bytes, more than the {limit} that the largest one '
            'accepted takes')


def read(data, msg_type):
    """Return the message of type ``msg_type`` in ``data`` (ValueError if it cannot be read)."""
    try:
        return deserialize_message(data, msg_type)
    except Exception as exc:  # noqa: B902 - rclpy raises its own or a RuntimeError
        raise ValueError(f'cannot read the message: {exc}') from None
