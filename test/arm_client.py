"""An arm_sim_node and a client recording its outputs, for the arm tests."""

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import JointState
from splines445_ros.nodes import topics
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.tools.in_process import overrides
from trajectory_msgs.msg import JointTrajectory


class ArmClient:
    """One arm node and a client recording its joint_states, status and tool poses."""

    def __init__(self, ros, parameters, client_name='arm_client', discovery_timeout=5.0):
        self.ros = ros
        self.node = ros.add(ArmSimNode(context=ros.context,
                                       parameter_overrides=overrides(parameters)))
        self.client = ros.add(Node(client_name, context=ros.context))
        self.publisher = self.client.create_publisher(JointTrajectory, topics.JOINT_TRAJECTORY,
                                                      topics.LATCHED)
        self.states, self.status, self.poses = [], [], []
        self.client.create_subscription(JointState, topics.JOINT_STATES, self.states.append,
                                        topics.STATE_QOS)
        self.client.create_subscription(DiagnosticStatus, '/arm_sim_node/status',
                                        self.status.append, topics.STATUS_QOS)
        self.client.create_subscription(PoseStamped, topics.TOOL_POSE, self.poses.append,
                                        topics.STATE_QOS)
        assert ros.spin_until(lambda: self.publisher.get_subscription_count() >= 1
                              and len(self.states) >= 2, discovery_timeout)

    def trajectory_status(self, first, count, timeout):
        """Wait for ``count`` statuses after index ``first`` about trajectories; return them."""
        def about_trajectories():
            # Rejected parameter updates are on ~/status too: skip those.
            return [s for s in self.status[first:] if 'parameters' not in status_values(s)]
        assert self.ros.spin_until(lambda: len(about_trajectories()) >= count, timeout)
        return about_trajectories()[:count]
