"""A test client that drives ``/clock`` for a node with ``use_sim_time`` and records it."""

from builtin_interfaces.msg import Time as TimeMsg
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from splines445_ros.nodes import topics
from splines445_ros.tools.in_process import stamp_ns
from trajectory_msgs.msg import JointTrajectory

# Wall-time bound on waiting for an effect [s]: generous, it is only reached on failure.
WAIT = 10.0


class ClockDriver:
    """
    Publish simulated time and trajectories; record ``joint_states`` in ``states``.

    Every call waits for its effect, not for a fixed wall time, so a loaded
    machine only makes it slower: ``set_clock`` until the arm published a
    state stamped at the new time (or ``clock_of``'s clock reads it),
    ``send`` until the arm reported the trajectory on ``~/status``.
    """

    def __init__(self, ros, arm=True, clock_of=None):
        """Create the client node in ``ros`` (a LocalRos); wait for /clock (and the arm)."""
        self._ros = ros
        self._arm = arm
        self._clock_of = clock_of
        node = ros.add(Node('clock_driver', context=ros.context))
        self._clock = node.create_publisher(Clock, '/clock', 10)
        self._trajectories = node.create_publisher(JointTrajectory, topics.JOINT_TRAJECTORY,
                                                   topics.LATCHED)
        self.states = []
        self.arm_status = []
        subscriptions = [
            node.create_subscription(JointState, topics.JOINT_STATES, self.states.append,
                                     topics.STATE_QOS),
            node.create_subscription(DiagnosticStatus, '/arm_sim_node/status',
                                     self.arm_status.append, topics.STATUS_QOS)]
        assert ros.spin_until(
            lambda: self._clock.get_subscription_count() and (not arm or (
                self._trajectories.get_subscription_count()
                and all(sub.get_publisher_count() for sub in subscriptions))), WAIT)

    def set_clock(self, seconds):
        """Publish ``seconds`` on /clock; return once the nodes run at that time."""
        stamp = TimeMsg(sec=int(seconds), nanosec=int(round(seconds % 1 * 1e9)))
        target = stamp.sec * 1_000_000_000 + stamp.nanosec
        self._clock.publish(Clock(clock=stamp))
        if self._arm:
            reached = self._ros.spin_until(
                lambda: self.states and stamp_ns(self.states[-1]) >= target, WAIT)
        else:
            reached = self._ros.spin_until(
                lambda: self._clock_of.get_clock().now().nanoseconds >= target, WAIT)
        assert reached, f'the nodes did not reach simulated time {seconds} s'

    def send(self, joint_names, point):
        """Publish a one-point trajectory to ``point``; return once the arm reported it."""
        n_status = len(self.arm_status)
        self._trajectories.publish(JointTrajectory(joint_names=list(joint_names),
                                                   points=[point]))
        assert self._ros.spin_until(lambda: len(self.arm_status) > n_status, WAIT), \
            'the arm did not report the trajectory'
