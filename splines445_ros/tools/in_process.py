"""
Both nodes and a client in one process and one executor, without launch files.

Used by the demo and the tests.  Creating an :class:`InProcessSystem` forces
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` (DDS traffic stays on this machine)
and reserves a ``ROS_DOMAIN_ID`` of its own unless one is set (:mod:`local_dds`).
"""

import math
import time

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Pose, PoseArray, PoseStamped
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from .local_dds import keep_dds_local
from ..nodes import topics
from ..nodes.arm_sim_node import ArmSimNode
from ..nodes.diagnostics import status_values
from ..nodes.planner_node import PlannerNode
from ..nodes.ros_conversions import seconds_to_duration


def waypoint_message(joint_names, waypoints, start_velocity=None, start_acceleration=None,
                     end_velocity=None, end_acceleration=None, times=None):
    """Build a waypoint request ``JointTrajectory`` from arrays."""
    msg = JointTrajectory()
    msg.joint_names = list(joint_names)
    for k, q in enumerate(waypoints):
        point = JointTrajectoryPoint(positions=[float(v) for v in q])
        if times is not None:
            point.time_from_start = seconds_to_duration(times[k])
        msg.points.append(point)
    for point, vel, acc in ((msg.points[0], start_velocity, start_acceleration),
                            (msg.points[-1], end_velocity, end_acceleration)):
        if vel is not None:
            point.velocities = [float(v) for v in vel]
        if acc is not None:
            point.accelerations = [float(v) for v in acc]
    return msg


def tool_waypoint_message(poses, frame_id='base_link'):
    """Build a ``tool_waypoints`` request ``PoseArray`` from (N, 3) rows (x, y, yaw)."""
    msg = PoseArray()
    msg.header.frame_id = frame_id
    for x, y, yaw in poses:
        pose = Pose()
        pose.position.x, pose.position.y = float(x), float(y)
        pose.orientation.z, pose.orientation.w = math.sin(0.5 * yaw), math.cos(0.5 * yaw)
        msg.poses.append(pose)
    return msg


def stamp_ns(msg):
    """Header stamp of a message in nanoseconds."""
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def overrides(values):
    """Parameter overrides from a dict."""
    return [Parameter(name, value=value) for name, value in values.items()]


class LocalRos:
    """A private rclpy context and executor, DDS on loopback only; closes its nodes."""

    def __init__(self):
        """Create the context and the executor."""
        keep_dds_local()
        self.context = Context()
        rclpy.init(context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self._nodes = []

    def add(self, node):
        """Spin ``node`` with this executor and destroy it on close; return it."""
        self.executor.add_node(node)
        self._nodes.append(node)
        return node

    def spin_until(self, predicate, timeout):
        """Spin the executor until ``predicate()`` is true; False on timeout."""
        deadline = time.monotonic() + timeout
        while not predicate():
            if time.monotonic() > deadline:
                return False
            self.executor.spin_once(timeout_sec=0.005)
        return True

    def spin_for(self, seconds):
        """Spin the executor for a while."""
        self.spin_until(lambda: False, seconds)

    def close(self):
        """Destroy the nodes and shut this context down."""
        self.executor.shutdown()
        for node in reversed(self._nodes):
            node.destroy_node()
        rclpy.try_shutdown(context=self.context)

    def __enter__(self):
        """Use as a context manager."""
        return self

    def __exit__(self, *exc):
        """Close on exit."""
        self.close()


# The planner's start_delay and replan_lead_time here [s]: their defaults, 0.05 s and
# 0.2 s, cover delivery between processes; in one process the nodes share one executor
# and the GIL, and on a 2-core machine loaded with four busy processes a trajectory
# reached the arm up to 0.27 s after it was published (then it starts part-way along:
# the arm jumps). The lead time must also hold the planning of a replanned one.
IN_PROCESS_START_DELAY = 0.4
IN_PROCESS_LEAD_TIME = 0.5


class InProcessSystem(LocalRos):
    """Planner, arm simulation and a recording client spun by one executor."""

    def __init__(self, planner_parameters=None, arm_parameters=None, params_file=None):
        """
        Start everything; ``*_parameters`` are dicts of overrides.

        The planner's ``start_delay`` and ``replan_lead_time`` are
        :data:`IN_PROCESS_START_DELAY` and :data:`IN_PROCESS_LEAD_TIME` unless
        ``planner_parameters`` set them (a ``params_file``'s are overridden).
        """
        super().__init__()
        try:
            self._start(planner_parameters, arm_parameters, params_file)
        except BaseException:
            # A node that failed to start (bad parameters, no connection)
            # must not stay in the domain, answering later systems' requests.
            self.close()
            raise

    def _start(self, planner_parameters, arm_parameters, params_file):
        cli = ['--ros-args', '--params-file', params_file] if params_file else None
        self.planner = self.add(PlannerNode(
            context=self.context, cli_args=cli,
            parameter_overrides=overrides({'start_delay': IN_PROCESS_START_DELAY,
                                           'replan_lead_time': IN_PROCESS_LEAD_TIME,
                                           **(planner_parameters or {})})))
        self.arm = self.add(ArmSimNode(context=self.context, cli_args=cli,
                                       parameter_overrides=overrides(arm_parameters or {})))
        self.client = self.add(Node('splines445_client', context=self.context))
        self.waypoint_publisher = self.client.create_publisher(
            JointTrajectory, topics.WAYPOINTS, topics.REQUEST_QOS)
        self.tool_waypoint_publisher = self.client.create_publisher(
            PoseArray, topics.TOOL_WAYPOINTS, topics.REQUEST_QOS)
        self.trajectory_publisher = self.client.create_publisher(
            JointTrajectory, topics.JOINT_TRAJECTORY, topics.LATCHED)
        self.trajectories = []
        self.planner_status = []
        self.arm_status = []
        self.joint_states = []
        self.tool_poses = []
        recorders = (
            (JointTrajectory, topics.JOINT_TRAJECTORY, self.trajectories, topics.LATCHED),
            (DiagnosticStatus, '/planner_node/status', self.planner_status, topics.STATUS_QOS),
            (DiagnosticStatus, '/arm_sim_node/status', self.arm_status, topics.STATUS_QOS),
            (JointState, topics.JOINT_STATES, self.joint_states, topics.STATE_QOS),
            (PoseStamped, topics.TOOL_POSE, self.tool_poses, topics.STATE_QOS),
        )
        self._subscriptions = [
            self.client.create_subscription(msg_type, topic, record.append, qos)
            for msg_type, topic, record, qos in recorders]
        self.wait_for_connections()

    def wait_for_connections(self, timeout=10.0):
        """Wait until the client's publishers and subscriptions have matched the nodes."""
        def matched():
            return (self.waypoint_publisher.get_subscription_count() >= 1
                    and self.tool_waypoint_publisher.get_subscription_count() >= 1
                    and self.planner.trajectory_publisher.get_subscription_count() >= 2
                    and self.arm.joint_state_publisher.get_subscription_count() >= 1
                    and self.planner.status_publisher.get_subscription_count() >= 1
                    and all(sub.get_publisher_count() >= 1 for sub in self._subscriptions))
        if not self.spin_until(matched, timeout):
            raise RuntimeError('in-process nodes did not discover each other')

    def request(self, msg, timeout=30.0):
        """Publish a waypoint (or PoseArray tool) request; return its status and trajectory."""
        n_status = len(self.planner_status)
        n_traj = len(self.trajectories)
        if isinstance(msg, PoseArray):
            self.tool_waypoint_publisher.publish(msg)
        else:
            self.waypoint_publisher.publish(msg)
        # The planner's answer to a request carries its number (parameter
        # rejections are on ~/status too, without one).
        status = self._next_status(self.planner_status, n_status,
                                   lambda values: 'request' in values, timeout)
        if status is None:
            raise TimeoutError('no status from the planner')
        if status.level == DiagnosticStatus.ERROR:
            return status, None
        # OK, or WARN (a slow plan): a trajectory was published.
        if not self.spin_until(lambda: len(self.trajectories) > n_traj, timeout):
            raise TimeoutError('planner reported success but no trajectory arrived')
        return status, self.trajectories[-1]

    def wait_until_played(self, n_arm_status, duration, timeout=10.0):
        """
        Wait until the arm has played the trajectory it accepted after status number n.

        Returns the ``joint_states`` published while it moved and the first one
        published after its end.
        """
        # The arm's answer to a trajectory: accepted (with its start) or an
        # ERROR; not a parameter rejection nor an earlier trajectory's report.
        status = self._next_status(
            self.arm_status, n_arm_status,
            lambda values: 'parameters' not in values and 'tracking_rms_error' not in values,
            timeout)
        if status is None:
            raise TimeoutError('the arm did not accept the trajectory')
        if status.level == DiagnosticStatus.ERROR:  # (a WARN: accepted, but late)
            raise RuntimeError(f'the arm rejected the trajectory: {status.message}')
        start = int({kv.key: kv.value for kv in status.values}['start_ns'])
        end = start + int(round(duration * 1e9))
        if not self.spin_until(lambda: self.joint_states
                               and stamp_ns(self.joint_states[-1]) > end, duration + timeout):
            raise TimeoutError('the arm did not finish the trajectory')
        played = [s for s in self.joint_states if start <= stamp_ns(s) <= end]
        return played, self.joint_states[-1]

    def _next_status(self, statuses, first, wanted, timeout):
        """Return the first of ``statuses[first:]`` whose values satisfy ``wanted``, or None."""
        def found():
            return next((s for s in statuses[first:] if wanted(status_values(s))), None)
        self.spin_until(lambda: found() is not None, timeout)
        return found()

    def set_planner_parameters(self, values):
        """Set planner parameters; return the SetParametersResult list."""
        return self.planner.set_parameters(overrides(values))
