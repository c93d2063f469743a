"""
planner_node with ``kinematics: model`` on a vendor URDF (UR5), in process.

The robot comes from ``model_file`` or from the ``robot_description`` topic;
tool seams are planned end to end and checked by the test's own forward
kinematics of the URDF; limits come from the URDF and a joint_limits.yaml;
bad input is reported and the last good robot stays.
"""

import math
import re

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Pose, PoseArray
from node_status import assert_planned
import numpy as np
import pytest
from rclpy.action import GoalResponse
from rclpy.node import Node
from scipy.spatial.transform import Rotation
from splines445_interfaces.action import FollowWaypoints
from splines445_ros.nodes import topics
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.nodes.ros_conversions import sampled_trajectory_from_msg
from splines445_ros.tools import vendor_robots as vr
from splines445_ros.tools.in_process import LocalRos, overrides, waypoint_message
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory
from urdf_reference import BatchedUrdfChain, distance_to_polyline

LIMITS_YAML = """joint_limits:
""" + ''.join(f"""  {name}:
    has_acceleration_limits: true
    max_acceleration: {acc}
""" for name, acc in zip(vr.UR5_JOINTS, [6.0, 6.0, 7.0, 9.0, 9.0, 9.0]))

# UR5 tool0 pointing down (as at UR5_READY), corners of a seam on a table at z = 0.15 m.
DOWN = (0.0, -0.70710678, 0.70710678, 0.0)  # (qw, qx, qy, qz)
CORNERS = np.array([[0.3, -0.2, 0.15], [0.55, -0.2, 0.15], [0.55, 0.2, 0.15],
                    [0.3, 0.2, 0.15], [0.3, -0.2, 0.15]])


def pose_array(points, quaternion=DOWN, frame_id='base_link'):
    msg = PoseArray()
    msg.header.frame_id = frame_id
    for x, y, z in points:
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = float(x), float(y), float(z)
        w, qx, qy, qz = quaternion
        pose.orientation.w, pose.orientation.x = float(w), float(qx)
        pose.orientation.y, pose.orientation.z = float(qy), float(qz)
        msg.poses.append(pose)
    return msg


class Planner(LocalRos):
    """
    A planner node and a client that sends requests and robot descriptions.

    Each in its own namespace: two planners alive at once (a module fixture's
    and a test's) must not answer each other's requests.
    """

    def __init__(self, parameters, namespace):
        super().__init__()
        try:
            self.node = self.add(PlannerNode(context=self.context, namespace=namespace,
                                             parameter_overrides=overrides(parameters)))
            self.client = self.add(Node('model_client', namespace=namespace,
                                        context=self.context))
            self.tools = self.client.create_publisher(PoseArray, topics.TOOL_WAYPOINTS,
                                                      topics.REQUEST_QOS)
            self.description = self.client.create_publisher(String, 'robot_description',
                                                            topics.LATCHED)
            self.status, self.trajectories = [], []
            self.client.create_subscription(DiagnosticStatus, 'planner_node/status',
                                            self.status.append, topics.STATUS_QOS)
            self.client.create_subscription(JointTrajectory, topics.JOINT_TRAJECTORY,
                                            self.trajectories.append, topics.LATCHED)
            assert self.spin_until(lambda: self.tools.get_subscription_count() >= 1
                                   and self.description.get_subscription_count() >= 1, 10.0)
            self.spin_for(0.2)
        except BaseException:
            self.close()
            raise

    def next_status(self, first, wanted=lambda values: True, timeout=60.0):
        def found():
            return next((s for s in self.status[first:] if wanted(status_values(s))), None)
        self.spin_until(lambda: found() is not None, timeout)
        return found()

    def request(self, msg):
        first, n_traj = len(self.status), len(self.trajectories)
        self.tools.publish(msg)
        status = self.next_status(first, lambda values: 'request' in values)
        assert status is not None, 'no answer'
        if status.level != DiagnosticStatus.ERROR:  # OK, or WARN: published
            assert self.spin_until(lambda: len(self.trajectories) > n_traj, 10.0)
            return status, self.trajectories[-1]
        return status, None

    def publish_description(self, text):
        first = len(self.status)
        self.description.publish(String(data=text))
        return self.next_status(first, lambda values: 'robot' in values
                                or 'robot_description_characters' in values)


def check_seam(msg, tolerance=1e-3, angle=math.radians(1.0)):
    """Play the trajectory at 1 kHz; the URDF's own FK must stay on the seam, tool down."""
    assert tuple(msg.joint_names) == vr.UR5_JOINTS
    played = sampled_trajectory_from_msg(msg, vr.UR5_JOINTS)
    t = np.arange(0.0, played.times[-1], 1e-3)
    q = np.array([played.state_at(x)[0] for x in t])
    pos, mat = BatchedUrdfChain(vr.ur5_urdf(), 'base_link', 'tool0', list(vr.UR5_JOINTS))(q)
    # Within the tolerance, plus the playback's interpolation between 10 ms samples.
    assert distance_to_polyline(pos, CORNERS).max() <= tolerance + 2e-5
    down = Rotation.from_quat(DOWN, scalar_first=True)
    assert (down.inv() * Rotation.from_matrix(mat)).magnitude().max() <= angle + 1e-4
    for corner in CORNERS:
        assert np.min(np.linalg.norm(pos - corner, axis=1)) < 1e-4


@pytest.fixture(scope='module')
def limits_file(tmp_path_factory):
    path = tmp_path_factory.mktemp('limits') / 'joint_limits.yaml'
    path.write_text(LIMITS_YAML)
    return str(path)


def base_parameters(limits_file, **more):
    # joint_names [''] = all of the model's actuated joints, in the model's order.
    values = {'kinematics': 'model', 'joint_names': [''], 'tool_frame': 'tool0',
              'base_frame': 'base_link', 'joint_limits_file': limits_file,
              'max_velocity': [0.0], 'max_acceleration': [0.0], 'max_jerk': [0.0],
              'method': '555', 'max_path_deviation': 1e-3,
              'max_orientation_deviation': math.radians(1.0),
              'max_inserted_waypoints': 2000, 'sample_period': 0.01}
    values.update(more)
    return values


@pytest.fixture(scope='module')
def by_file(limits_file):
    with Planner(base_parameters(limits_file, model_file=vr.ur5_urdf()), 'by_file') as planner:
        yield planner


def test_a_seam_planned_with_the_urdf_and_the_limits_file(by_file):
    loaded = by_file.next_status(0, lambda values: 'robot' in values)
    assert loaded is not None and loaded.level == DiagnosticStatus.OK, loaded
    status, msg = by_file.request(pose_array(CORNERS))
    assert_planned(status)
    values = status_values(status)
    assert int(values['inserted_waypoints']) > 0
    assert float(values['unrefined_max_path_deviation']) > 0.01
    # Velocity limits from the URDF (3.15 / 3.2), acceleration from the file.
    assert 'shoulder_pan_joint=3.15 (urdf)' in values['limit_velocity_sources']
    assert 'wrist_3_joint=3.2 (urdf)' in values['limit_velocity_sources']
    assert 'elbow_joint=7 (joint_limits_file)' in values['limit_acceleration_sources']
    assert values['limit_velocity'].startswith('3.15, 3.15, 3.15, 3.2')
    check_seam(msg)
    acc = np.array([p.accelerations for p in msg.points])
    assert np.all(np.abs(acc) <= np.array([6.0, 6.0, 7.0, 9.0, 9.0, 9.0]) * (1 + 1e-6))


def test_explicit_limits_override_the_description(by_file, limits_file):
    result = by_file.node.set_parameters(overrides(
        {'max_velocity': [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]}))
    assert result[0].successful, result[0].reason
    try:
        status, msg = by_file.request(pose_array(CORNERS[:3]))
        assert_planned(status)
        assert 'shoulder_pan_joint=1 (parameter)' in \
            status_values(status)['limit_velocity_sources']
        vel = np.array([p.velocities for p in msg.points])
        assert np.max(np.abs(vel[:, 0])) <= 1.0 * (1 + 1e-6)
    finally:
        by_file.node.set_parameters(overrides({'max_velocity': [0.0]}))


@pytest.mark.parametrize('values, reason', [
    ({'tool_frame': 'flange'}, "tool_frame 'flange' is not a link, body or site"),
    ({'base_frame': 'wrist_2_link'}, 'must be fixed to the world'),
    ({'model_file': '/nonexistent/robot.urdf'}, 'no such file'),
    ({'joint_names': ['shoulder_pan_joint', 'joint7']}, "no actuated joint 'joint7'"),
    ({'joint_limits_file': ''}, "joint 'shoulder_pan_joint' has no acceleration limit"),
    ({'max_acceleration': [1.0, 2.0]}, r'max_acceleration needs one value per joint \(6\)'),
])
def test_bad_parameters_are_rejected_and_the_robot_stays(by_file, values, reason):
    result = by_file.node.set_parameters(overrides(values))
    assert not result[0].successful
    assert re.search(reason, result[0].reason), result[0].reason
    status, _ = by_file.request(pose_array(CORNERS[:2]))
    assert_planned(status)


def test_a_bad_limits_file_is_rejected(by_file, tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('joint_limits:\n  elbow_joint:\n    max_acceleration_limit: 3\n')
    result = by_file.node.set_parameters(overrides({'joint_limits_file': str(bad)}))
    assert not result[0].successful
    assert "joint 'elbow_joint' has unknown key(s) ['max_acceleration_limit']" in \
        result[0].reason


def test_unreachable_and_misframed_requests_are_named(by_file):
    far = CORNERS[:3].copy()
    far[2] = [1.5, 0.2, 0.15]
    status, _ = by_file.request(pose_array(far))
    assert status.level == DiagnosticStatus.ERROR
    assert 'tool waypoint 2 at (x, y, z) = (1.5, 0.2, 0.15)' in status.message
    assert 'out of reach' in status.message
    status, _ = by_file.request(pose_array(CORNERS[:2], frame_id='world_frame'))
    assert status.level == DiagnosticStatus.ERROR
    assert "frame 'world_frame', but base_frame is 'base_link'" in status.message
    status, _ = by_file.request(pose_array(CORNERS[:2], quaternion=(0, 0, 0, 0)))
    assert status.level == DiagnosticStatus.ERROR and 'zero quaternion' in status.message


def test_the_robot_description_topic(limits_file):
    with open(vr.ur5_urdf(), encoding='utf-8') as stream:
        urdf = stream.read()
    with Planner(base_parameters(limits_file), 'by_topic') as planner:
        status, _ = planner.request(pose_array(CORNERS[:2]))
        assert status.level == DiagnosticStatus.ERROR
        assert 'no robot yet' in status.message
        # A follow_waypoints goal is refused for the same reason (it said "this node
        # controls 0 joints", helper-88), a joint goal and a tool goal alike.
        for goal in (FollowWaypoints.Goal(waypoints=waypoint_message(
                         [f'joint{i}' for i in range(6)], np.zeros((2, 6)))),
                     FollowWaypoints.Goal(tool_waypoints=pose_array(CORNERS[:2]))):
            first = len(planner.status)
            assert planner.node._follow_waypoints._on_goal(goal) == GoalResponse.REJECT
            rejected = planner.next_status(first, lambda values: 'interface' in values)
            assert 'goal rejected: kinematics "model" has no robot yet' in rejected.message
        assert planner.node.waiting_for_robot() and planner.node.planned_joint_names() == ()
        loaded = planner.publish_description(urdf)
        assert loaded.level == DiagnosticStatus.OK, loaded.message
        assert status_values(loaded)['robot'] == 'robot_description'
        assert not planner.node.waiting_for_robot()
        assert planner.node.planned_joint_names() == tuple(vr.UR5_JOINTS)
        status, msg = planner.request(pose_array(CORNERS))
        assert_planned(status)
        check_seam(msg)
        # Malformed, huge and jointless descriptions: reported, the last good robot stays.
        for text, reason in (('<robot name="ur5"><link name="a">', 'not well-formed XML'),
                             ('<robot>' + ' ' * 20_000_001 + '</robot>', 'more than'),
                             ('<robot name="x"><link name="base_link"/></robot>',
                              'has no actuated (hinge or slide) joints'),
                             ('<robot name="x"><link name="base_link"/><link name="b"/>'
                              '<joint name="j" type="revolute"><parent link="base_link"/>'
                              '<child link="b"/><limit lower="-1" upper="1" velocity="1"/>'
                              '</joint></robot>', "tool_frame 'tool0' is not a link")):
            rejected = planner.publish_description(text)
            assert rejected.level == DiagnosticStatus.ERROR
            assert reason in rejected.message and 'keeping the last good' in rejected.message
        status, msg = planner.request(pose_array(CORNERS[:2]))
        assert_planned(status)


def test_switching_to_the_topic_drops_the_old_files_robot(limits_file):
    # Found in review: model_file -> '' with no robot_description yet kept
    # planning with the old file's robot and its frozen configuration.
    with Planner(base_parameters(limits_file, model_file=vr.ur5_urdf()), 'switch') as planner:
        status, _ = planner.request(pose_array(CORNERS[:2]))
        assert_planned(status)
        result = planner.node.set_parameters(overrides({'model_file': ''}))[0]
        assert result.successful, result.reason
        status, _ = planner.request(pose_array(CORNERS[:2]))
        assert status.level == DiagnosticStatus.ERROR
        assert 'no robot yet' in status.message
        # The description then brings a robot again.
        with open(vr.ur5_urdf(), encoding='utf-8') as handle:
            loaded = planner.publish_description(handle.read())
        assert loaded.level == DiagnosticStatus.OK, loaded.message
        status, _ = planner.request(pose_array(CORNERS[:2]))
        assert_planned(status)
