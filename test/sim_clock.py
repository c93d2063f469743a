"""A test client that drives ``/clock`` for a node with ``use_sim_time`` and records it."""

from builtin_interfaces.msg import Time as TimeMsg
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from splines445_ros.nodes import topics
from trajectory_msgs.msg import JointTrajectory


class ClockDriver:
    """Publish simulated time and trajectories; record ``joint_states`` in ``states``."""

    def __init__(self, ros, arm=True):
        """Create the client node in ``ros`` (a LocalRos); wait for /clock (and the arm)."""
        self._ros = ros
        node = ros.add(Node('clock_driver', context=ros.context))
        self._clock = node.create_publisher(Clock, '/clock', 10)
        self._trajectories = node.create_publisher(JointTrajectory, topics.JOINT_TRAJECTORY,
                                                   topics.LATCHED)
        self.states = []
        node.create_subscription(JointState, topics.JOINT_STATES, self.states.append,
                                 topics.STATE_QOS)
        assert ros.spin_until(lambda: self._clock.get_subscription_count()
                              and (self._trajectories.get_subscription_count() or not arm),
                              3.0)

    def set_clock(self, seconds):
        """Publish ``seconds`` on /clock, then spin 0.3 s of wall time."""
        self._clock.publish(Clock(clock=TimeMsg(sec=int(seconds),
                                                nanosec=int(round(seconds % 1 * 1e9)))))
        self._ros.spin_for(0.3)

    def send(self, joint_names, point):
        """Publish a one-point trajectory to ``point`` (a JointTrajectoryPoint)."""
        self._trajectories.publish(JointTrajectory(joint_names=list(joint_names),
                                                   points=[point]))
