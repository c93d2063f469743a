"""
``arm_sim_node``: the paper's planar 3-DOF arm, playing back joint trajectories.

Subscribes ``joint_trajectory`` (trajectory_msgs/JointTrajectory) and plays it
on the node's clock (``use_sim_time`` works), interpolating between points as
ros2_control's joint_trajectory_controller does.  A trajectory whose
``header.stamp`` is non-zero takes over at that time (zero = on receipt); until
then the running one continues.  A new trajectory replaces the running one.

Publishes ``joint_states`` (sensor_msgs/JointState) and the tool pose from the
forward kinematics (geometry_msgs/PoseStamped on ``tool_pose``, yaw = tool
orientation) at ``publish_rate``, also while idle; reports rejected
trajectories on ``~/status``.
"""

import math

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
import numpy as np
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from . import topics
from .arm_sim_config import ArmSimConfig
from .diagnostics import status_message
from .node_main import run_node
from .parameters import ConfigParameters
from .ros_conversions import sampled_trajectory_from_msg
from ..arm.kinematics import PlanarArm

PARAMETER_DESCRIPTIONS = {
    'joint_names': 'Names of joint 1 (shoulder), 2 (elbow) and 3 (tool).',
    'link_lengths': 'Lengths d1, d2 of the two links [m] (paper: 1.1, 0.9).',
    'initial_positions': 'Joint angles at start-up [rad].',
    'publish_rate': 'Rate of joint_states and tool_pose [Hz], in [0.001, 1000].',
    'frame_id': 'Frame of tool_pose.',
}


class ArmSimNode(Node):
    """A kinematic simulation of the planar arm."""

    def __init__(self, **kwargs):
        """Declare parameters, topics and the publishing timer."""
        super().__init__('arm_sim_node', **kwargs)
        self.parameters = ConfigParameters(self, ArmSimConfig, PARAMETER_DESCRIPTIONS,
                                           on_change=self._on_config)
        config = self.parameters.config
        self.arm = PlanarArm(*config.link_lengths)
        self.position = np.array(config.initial_positions, dtype=float)
        self.velocity = np.zeros(3)
        self.acceleration = np.zeros(3)
        self._active = None      # (SampledTrajectory, start time in ns)
        self._pending = None     # (SampledTrajectory, start time in ns)
        self._status_name = self.get_fully_qualified_name()
        self.joint_state_publisher = self.create_publisher(
            JointState, topics.JOINT_STATES, topics.STATE_QOS)
        self.pose_publisher = self.create_publisher(PoseStamped, topics.TOOL_POSE,
                                                    topics.STATE_QOS)
        self.status_publisher = self.create_publisher(DiagnosticStatus, topics.STATUS,
                                                      topics.STATUS_QOS)
        self.create_subscription(JointTrajectory, topics.JOINT_TRAJECTORY,
                                 self._on_trajectory, topics.LATCHED)
        self._timer = self.create_timer(1.0 / config.publish_rate, self._on_timer)

    def _on_config(self, config):
        self.arm = PlanarArm(*config.link_lengths)
        if hasattr(self, '_timer'):
            # The new timer first: if it cannot be made, the old one keeps running.
            timer = self.create_timer(1.0 / config.publish_rate, self._on_timer)
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = timer

    def _now_ns(self):
        return self.get_clock().now().nanoseconds

    def _on_trajectory(self, msg):
        config = self.parameters.config
        try:
            trajectory = sampled_trajectory_from_msg(msg, config.joint_names)
        except ValueError as exc:
            message = f'trajectory rejected: {exc}'
            self.get_logger().error(message)
            self.status_publisher.publish(status_message(self._status_name, False, message))
            return
        stamp = Time.from_msg(msg.header.stamp).nanoseconds
        start = stamp if stamp > 0 else self._now_ns()
        self._pending = (trajectory, start)
        message = (f'trajectory accepted: {len(msg.points)} points, '
                   f'{trajectory.duration:.4f} s')
        self.get_logger().info(message)
        self.status_publisher.publish(status_message(
            self._status_name, True, message,
            {'points': len(msg.points), 'duration': f'{trajectory.duration:.9g}',
             'start_ns': start}))
        self._on_timer()

    def _advance(self, now):
        if self._pending is not None and now >= self._pending[1]:
            if self._active is not None:
                self._set_state(now)  # the state at the switch, from the old trajectory
            trajectory, start = self._pending
            self._pending = None
            self._active = (trajectory.with_start_state(
                self.position, self.velocity, self.acceleration), start)
        self._set_state(now)

    def _set_state(self, now):
        if self._active is None:
            self.velocity[:] = 0.0
            self.acceleration[:] = 0.0
            return
        trajectory, start = self._active
        t = (now - start) * 1e-9
        self.position, self.velocity, self.acceleration = trajectory.state_at(t)
        if t >= trajectory.duration:
            self._active = None
            self.velocity = np.zeros(3)
            self.acceleration = np.zeros(3)

    def _on_timer(self):
        now = self._now_ns()
        self._advance(now)
        stamp = Time(nanoseconds=now).to_msg()
        config = self.parameters.config
        state = JointState()
        state.header.stamp = stamp
        state.name = list(config.joint_names)
        state.position = self.position.tolist()
        state.velocity = self.velocity.tolist()
        self.joint_state_publisher.publish(state)
        x, y, yaw = self.arm.forward(self.position)
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = config.frame_id
        pose.pose.position.x = float(x)
        pose.pose.position.y = float(y)
        pose.pose.orientation.z = math.sin(0.5 * yaw)
        pose.pose.orientation.w = math.cos(0.5 * yaw)
        self.pose_publisher.publish(pose)


def main(args=None):
    """Run the arm simulation until Ctrl-C or shutdown."""
    run_node(ArmSimNode, args)


if __name__ == '__main__':
    main()
