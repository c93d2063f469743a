"""
``planner_node``: waypoints in, jerk-continuous ``JointTrajectory`` out.

Subscribes ``waypoints`` (trajectory_msgs/JointTrajectory) and
``tool_waypoints`` (geometry_msgs/PoseArray, tool poses: inverse kinematics
of ``kinematics``, refined until the tool stays within ``max_path_deviation``
of the straight lines; with method 555 and optimal timing timed along the
lines themselves, within ``max_tool_speed`` and ``max_tool_angular_speed``
when set), plans with the planning core and the limits from its
parameters, publishes ``joint_trajectory`` (sampled every ``sample_period``, or
with ``output: knots`` one point per knot of the spline, which the quintic
interpolation of joint_trajectory_controller reproduces exactly) and reports
every request's outcome on ``~/status`` (diagnostic_msgs/DiagnosticStatus).

With ``kinematics: model`` the robot comes from its description
(``model_file``, else the ``robot_description`` topic, std_msgs/String,
reliable and transient-local like robot_state_publisher's): tool poses are
6-D, limits come from the description (see :mod:`.model_planning`).  A
description or parameter that does not give a working robot is reported on
``~/status`` (a parameter change is rejected) and the last good robot stays.
With ``limit_torque`` every plan also keeps the rigid-body torque of the
planned joints (with ``payload_*`` held by the tool frame, and with
``torque_counts_friction`` the joints' damping and dry friction) within
``max_effort`` or the description's effort limits (rest to rest).

Planning runs on a worker thread, so a large request never blocks the node's
other callbacks (parameter services, state subscriptions).  A bad request is
reported and logged; the node keeps serving.
"""

import collections
from dataclasses import dataclass, field, replace
import hashlib
import os
import queue
import stat
import threading
import time
import traceback
from typing import Callable, Optional

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseArray
import numpy as np
from rclpy.node import Node
from rclpy.task import Future
from rclpy.time import Time
from sensor_msgs.msg import JointState
from splines445_interfaces.srv import Plan
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

from . import raw_messages, topics
from .clock_jumps import follow_clock_jumps
from .diagnostics import format_vector, status_message
from .follow_waypoints import FollowWaypointsServer
from .node_main import run_node
from .parameters import ConfigParameters
from .planned_path import (cleared_markers, planned_path_markers, tool_path_points,
                           tool_position_function)
from .ros_conversions import (hold_message, lasting_at_rest, parse_tool_request,
                              parse_waypoint_request, plan_response, trajectory_to_msg)
from ..robot.joint_limits_file import unapplied_note
from ..robot.robot_model import check_description_file, MAX_DESCRIPTION_CHARS
from ..service.interface_requests import (MAX_REQUEST_WAYPOINTS, override_values,
                                          request_message)
from ..service.joint_states import LatestJointStates
from ..service.model_planning import (build_robot_setup, description_source, load_model,
                                      NO_ROBOT_YET,
                                      plan_model_tool_request, robot_fields,
                                      tool_poses_from_message)
from ..service.planner_config import PlannerConfig
from ..service.request_planning import (ends_at_rest, gravity_overload_report, GravityOverload,
                                        no_room_report, NoRoomToMove, output_samples,
                                        plan_from_running, plan_from_state_at,
                                        plan_request, plan_stop, plan_tool_request,
                                        plan_warnings, raised_from, running_in_order,
                                        start_from_state, summary_values, tool_summary_values)

ROBOT_DESCRIPTION = 'robot_description'
PLAN_SERVICE = '~/plan'
PLAN_INTERFACE = 'plan service'
# Attempts at a stop while the trajectory on the arm changes under it (_serve_stop).
STOP_ATTEMPTS = 3

_STOP = object()
# A waypoints message is bounded on receipt as for at least this many joints (the
# robot it is for may still be compiling), and by its robot's joints before it is read.
RECEIPT_JOINTS = 64
_WAKE = object()    # wakes the worker for a stop job (PlannerNode._stops)


@dataclass
class PlanJob:
    """
    One request for the planning worker.

    ``msg``: a waypoints ``JointTrajectory`` or a tool_waypoints ``PoseArray``;
    ``overrides``: parameter values for this request only (see
    :mod:`.plan_overrides`); ``publish``: send the plan on joint_trajectory
    (topics and goals; not the plan service); ``from_running``: plan from the
    running trajectory's state while one runs (goals, so that a preempting
    goal never jumps); ``done``: called on the worker with the PlanOutcome;
    ``interface``: named on ``~/status``; ``kind`` 'stop' stops the running
    trajectory (a cancelled goal) instead: ``stopping``, the goal's
    Trajectory, when a newer one may have replaced it (then there is
    nothing to stop).
    """

    msg: object = None
    overrides: dict = field(default_factory=dict)
    publish: bool = True
    from_running: bool = False
    done: Optional[Callable] = None
    interface: str = ''
    kind: str = 'plan'
    stopping: object = None


@dataclass
class PlanOutcome:
    """What the worker made of a PlanJob: the status it reported, and the plan."""

    ok: bool
    message: str                 # the ~/status message
    values: dict                 # the ~/status values
    trajectory: object = None    # the planned Trajectory
    msg: object = None           # the JointTrajectory (published when the job said so)
    joint_names: tuple = ()
    start_ns: Optional[int] = None  # when the published trajectory takes over


class _Compile:
    """A worker job: compile the robot of a model_file (see PlannerNode._on_config_change)."""

    def __init__(self, source):
        self.source = source


class _Unread:
    """A worker job: a serialized message of a raw subscription, read on the worker."""

    def __init__(self, data, msg_type, what, refused=None):
        self.data, self.msg_type, self.what = data, msg_type, what
        self.refused = refused      # why it is not read (too large), or None


@dataclass(frozen=True)
class _Published:
    """A trajectory published to the arm: the plan, its start [ns], joints and config."""

    traj: object
    start_ns: int
    names: tuple
    config: object      # the PlannerConfig it was planned with (overrides, robot limits)

    @property
    def end_ns(self):
        """When it ends [ns]."""
        return self.start_ns + int(self.traj.duration * 1e9)

    def runs_at(self, ns):
        """Whether it has started at ``ns`` and not yet ended."""
        return self.start_ns <= ns < self.end_ns


@dataclass(frozen=True)
class _FileIdentity:
    """
    What tells whether a ``model_file`` changed: its stat, and the digest of its bytes.

    The stat (device, inode, size, modification and change times) is
    cheap; the digest (SHA-256) is read only when the stat differs, so a
    file touched or copied over with the same bytes is the same file (its
    robot is not compiled again, and values are still checked against it).
    """

    stat: tuple
    digest: Optional[bytes]

    @classmethod
    def of(cls, source, digest=True):
        """
        Return the identity of ``source`` (a description_source), or None.

        None for a robot_description (its text is its source) and for a
        file that is missing, not a regular file (a pipe is never read
        here) or larger than a description may be: nothing to reload then,
        the robot compiled from it stays.  ``digest`` False: the stat only.
        """
        if source[0] != 'model_file':
            return None
        try:
            info = os.stat(source[1])
            if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_DESCRIPTION_CHARS:
                return None
            key = (info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns, info.st_ctime_ns)
            if not digest:
                return cls(key, None)
            with open(source[1], 'rb') as handle:
                return cls(key, hashlib.sha256(handle.read(MAX_DESCRIPTION_CHARS + 1)).digest())
        except (OSError, ValueError):
            return None

    def changed(self, source):
        """
        Whether ``source`` now holds other bytes than this identity's (False when unknown).

        Returns (changed, the identity to keep): a file touched without a
        change keeps its new stat, so the next look is a stat again.
        """
        now = _FileIdentity.of(source, digest=False)
        if now is None or now.stat == self.stat:
            return False, self
        now = _FileIdentity.of(source)
        if now is None:
            return False, self
        return now.digest != self.digest, now


class PlannerNode(Node):
    """Plans a trajectory for every waypoint request."""

    def __init__(self, **kwargs):
        """Declare parameters, topics and the planning worker."""
        super().__init__('planner_node', **kwargs)
        self._robot = None        # RobotSetup of kinematics "model" (the last good one)
        self._set_up = False      # whether the last parameter update set the robot up
        self._robot_fields = None  # robot_fields() of the config it was set up for
        self._compiled = None     # (description_source, RobotModel, _FileIdentity) last compiled
        self._pending = None      # the description_source queued for compiling
        self._description = None  # the latest robot_description string
        self._robot_lock = threading.Lock()
        self._requests = queue.Queue()
        self._stops = collections.deque()   # stop jobs, served before the queued requests
        self.parameters = ConfigParameters(self, PlannerConfig,
                                           on_change=self._on_config_change,
                                           on_reject=self._on_parameters_rejected)
        self._robot_config = self.parameters.config  # the config last accepted
        self.add_post_set_parameters_callback(self._on_parameters_set)
        self._status_name = self.get_fully_qualified_name()
        self._request_count = 0
        self.trajectory_publisher = self.create_publisher(
            JointTrajectory, topics.JOINT_TRAJECTORY, topics.LATCHED)
        self.status_publisher = self.create_publisher(
            DiagnosticStatus, topics.STATUS, topics.STATUS_QOS)
        # Requests and descriptions arrive raw: bounded before they are read, and read on
        # the worker, in order, so a large one never holds the executor.
        self.create_subscription(JointTrajectory, topics.WAYPOINTS, self._on_waypoints,
                                 topics.REQUEST_QOS, raw=True)
        # Always subscribed: a tool request while kinematics is "" gets an ERROR, not silence.
        self.create_subscription(PoseArray, topics.TOOL_WAYPOINTS, self._on_tool_waypoints,
                                 topics.REQUEST_QOS, raw=True)
        self.create_subscription(JointState, topics.JOINT_STATES, self._on_joint_state,
                                 topics.STATE_QOS)
        self.create_subscription(String, ROBOT_DESCRIPTION, self._on_description,
                                 topics.LATCHED, raw=True)
        self._joint_states = LatestJointStates()   # the latest of each joint set
        self._active = None  # _Published: the last trajectory published to the arm
        self._previous = None   # _Published: the one before, while the last waits for its stamp
        # The stamp [ns] of the last hold published (a stop at rest: no trajectory), while
        # it may still wait for it; None otherwise.
        self._hold_ns = None
        # The sum of the clock's jumps so far [ns] (clock_jumps): a goal's start moves by it.
        self.clock_shift_ns = 0
        self._clock_jumps = follow_clock_jumps(self, self._on_clock_jump)
        self._worker = threading.Thread(target=self._work, name='planner', daemon=True)
        self._worker.start()
        self._markers_shown = False     # the latched markers draw a plan
        self.planned_path_publisher = self.create_publisher(
            MarkerArray, topics.PLANNED_PATH, topics.LATCHED)
        self.create_service(Plan, PLAN_SERVICE, self._on_plan, qos_profile=topics.PLAN_QOS)
        self._follow_waypoints = FollowWaypointsServer(self)
        config = self.parameters.config
        if config.kinematics == 'model':
            with self._robot_lock:  # a bad model at start-up: invalid parameters
                self._apply_robot_config(config, compile_now=True)
            if self._robot is None:
                self.get_logger().info('kinematics "model": waiting for robot_description')
        # The joints planned: the robot's with kinematics "model" (joint_names not set
        # showed [] after the model's joints were loaded; helper-78).
        self.get_logger().info(
            f'planning {config.method}/{config.timing} for {list(self.planned_joint_names())}')

    async def _on_plan(self, request, response):
        """Serve ``~/plan``: plan (never publish to the arm), answer with the outcome."""
        try:
            msg = request_message(request.waypoints, request.tool_waypoints)
            job = self.plan_job(msg, override_values(request.overrides,
                                                     msg is request.waypoints), publish=False,
                                interface=PLAN_INTERFACE)
        except ValueError as exc:
            outcome = self._rejected(f'{PLAN_INTERFACE} request rejected: {exc}',
                                     {'interface': PLAN_INTERFACE})
        else:
            outcome = await self.submit(job)
        return plan_response(response, outcome)

    def plan_job(self, msg, overrides, **kwargs):
        """Return a PlanJob of ``msg`` with the parameter ``overrides`` (see PlanJob)."""
        return PlanJob(msg, overrides, **kwargs)

    async def submit(self, job):
        """Queue ``job`` for the worker; await its outcome (the executor is not blocked)."""
        future = Future(executor=self.executor)

        def done(outcome):
            future.set_result(outcome)
            executor = self.executor
            if executor is not None:
                executor.wake()  # the awaiting coroutine resumes when the executor wakes
        job.done = done
        if job.kind == 'stop':
            # A stop goes before the queued plans: the arm is moving.
            self._stops.append(job)
            self._requests.put(_WAKE)
        else:
            self._requests.put(job)
        return await future

    def planned_joint_names(self):
        """Return the joints this node plans (the robot's with kinematics "model")."""
        names = self._planned_names()
        return () if names is None else names

    def _planned_names(self):
        """
        Return the planned joints, or None while kinematics "model" has no robot yet.

        The config and its robot are read together, under the lock: read
        apart, the worker could pair a new config with the old robot while
        the executor replaced them.
        """
        with self._robot_lock:
            config, robot = self._robot_config, self._robot
        if config.kinematics != 'model':
            return config.joint_names
        return None if robot is None else robot.config.joint_names

    def waiting_for_robot(self):
        """Return True while kinematics "model" has no robot to plan with (not compiled yet)."""
        return self._planned_names() is None

    def trajectory_running(self):
        """Return True while the last published trajectory runs (a goal's or a topic's)."""
        return self._running_at(self.get_clock().now().nanoseconds)

    def active_trajectory(self):
        """Return the Trajectory last published to the arm (None when stopped or none)."""
        active = self._active
        return None if active is None else active.traj

    def _base(self, now_ns):
        """
        Return the :class:`_Published` a new publication takes over from, or None.

        The last one published, unless it still waits for its stamp: the arm
        drops a waiting trajectory when a newer one arrives, so the new one
        takes over from the one before it, which runs meanwhile (two requests
        less than ``replan_lead_time`` apart; a cancel within a goal's start
        delay).
        """
        active = self._active
        if active is not None and active.start_ns > now_ns:
            return self._previous
        hold_ns = self._hold_ns  # (read once: the worker may clear it meanwhile)
        if active is None and hold_ns is not None and hold_ns > now_ns:
            # A hold waiting for its stamp is dropped for a newer trajectory as well; the
            # arm runs the one before it until then (helper-77: a request there was
            # planned and checked from joint_states taken while the arm still moved).
            return self._previous
        return active

    def _on_clock_jump(self, jump, _change):
        """
        Move the starts of the trajectories published by a jump of the clock (clock_jumps).

        ``arm_sim_node`` moves its own by the same amount, so the trajectory
        goes on from where it was; a stop or a preemption then plans from
        the state the arm is really in.
        """
        for name in ('_active', '_previous'):
            record = getattr(self, name)
            if record is not None:
                setattr(self, name, replace(record, start_ns=record.start_ns + jump))
        hold = self._hold_ns    # (read once: the worker may clear it meanwhile)
        if hold is not None:
            self._hold_ns = hold + jump
        self.clock_shift_ns += jump
        if self._active is not None:
            self.get_logger().warning(
                f'the clock jumped {"back" if jump < 0 else "ahead"} by {abs(jump) * 1e-9:.6g} '
                's: the trajectory on the arm goes on from where it was')

    def _published(self, traj, start_ns, names, config, now_ns):
        """Record a trajectory just published; see :meth:`_base`."""
        if self._base(now_ns) is self._active:     # not one waiting for its stamp
            self._previous = self._active
        self._hold_ns = start_ns if traj is None else None
        self._active = (None if traj is None
                        else _Published(traj, start_ns, tuple(names), config))

    def measured_state(self, names):
        """
        Latest joint_states (position, velocity or None) of the joints ``names``, or None.

        From the latest message that names them all (a gripper's own
        joint_states beside the arm's are not in the way); None when none
        has arrived.
        """
        state = self._joint_states.covering(names)
        if state is None or len(state.position) != len(state.name):
            return None
        index = {name: i for i, name in enumerate(state.name)}
        if any(name not in index for name in names):
            return None
        order = [index[name] for name in names]
        position = np.array([state.position[i] for i in order], dtype=float)
        velocity = (np.array([state.velocity[i] for i in order], dtype=float)
                    if len(state.velocity) == len(state.name) else None)
        return position, velocity

    def joint_state_clock_gap(self, names):
        """Return [s] the stamp of ``names``' joint_states less this node's clock (0: none yet)."""
        state = self._joint_states.covering(names)
        if state is None:
            return 0.0
        stamp = state.header.stamp.sec * 1_000_000_000 + state.header.stamp.nanosec
        return 1e-9 * (stamp - self.get_clock().now().nanoseconds)

    def report(self, ok, message, values, warn=False):
        """Log ``message`` and publish it on ``~/status`` (see diagnostics.status_message)."""
        self._report(ok, message, values, warn)

    def _take_raw(self, data, msg_type, limit, what):
        """Queue a serialized message for the worker (refused unread beyond ``limit``)."""
        reason = raw_messages.too_large(data, limit)
        self._requests.put(_Unread(data if reason is None else b'', msg_type, what, reason))

    def _known_joint_count(self):
        """Return how many joints the node plans now; None while its robot is not compiled."""
        names = self._planned_names()
        return None if names is None else len(names)

    def _on_waypoints(self, data):
        # The robot this request is for may still be compiling (a description queued
        # before it): on receipt the bound is for at least RECEIPT_JOINTS joints, and
        # the worker checks the robot's own before reading (_read_unread).
        joints = max(RECEIPT_JOINTS, self._known_joint_count() or 0)
        self._take_raw(data, JointTrajectory,
                       raw_messages.joint_trajectory_bytes(MAX_REQUEST_WAYPOINTS, joints),
                       'waypoints')

    def _on_tool_waypoints(self, data):
        self._take_raw(data, PoseArray, raw_messages.pose_array_bytes(MAX_REQUEST_WAYPOINTS),
                       'tool_waypoints')

    def _on_description(self, data):
        # Loaded by the worker, in order with the requests.
        self._take_raw(data, String, raw_messages.string_bytes(MAX_DESCRIPTION_CHARS),
                       'robot_description')

    def _read_unread(self, job):
        """
        Return the message of an ``_Unread`` job (on the worker), or None when refused.

        A request is measured against the joints planned now (the robot of every
        description and model file queued before it is set up by then), counted and
        refused with its number; a description is refused keeping the last good robot.
        """
        reason = job.refused
        joints = self._known_joint_count() if job.msg_type is JointTrajectory else None
        if reason is None and joints:
            reason = raw_messages.too_large(
                job.data, raw_messages.joint_trajectory_bytes(MAX_REQUEST_WAYPOINTS, joints))
        unread = reason is not None
        if not unread:
            try:
                return raw_messages.read(job.data, job.msg_type)
            except ValueError as exc:
                reason = str(exc)
        how = 'rejected unread' if unread else 'rejected'
        if job.msg_type is String:
            self._report(False, f'robot_description {how}: {reason}{self._kept_robot()}',
                         {'robot_description_bytes': len(job.data)})
            return None
        self._request_count += 1
        self._report(False, f'request {self._request_count} {how} ({job.what}): {reason}',
                     {'request': self._request_count})
        return None

    def _on_config_change(self, config):
        """
        Apply a new config's robot (kinematics "model"); ValueError rejects the config.

        Runs on the executor.  Nothing is rebuilt for a parameter the robot
        does not depend on (:data:`ROBOT_FIELDS`); a new tool frame, joint
        set or limits are set up from the compiled model at once (quick, so
        a bad one is rejected with the reason); a new model_file is only
        checked here (exists, is a file, size) and compiled on the worker,
        in order with the requests, so the executor never waits for MuJoCo.
        Until it is compiled the last good robot stays, and a model_file
        that does not compile is reported on ``~/status``.  A model_file
        that has changed on disk since it was compiled is compiled again
        like a new one when the robot is set up again, or when model_file
        is set again (:meth:`_on_parameters_set`).
        """
        with self._robot_lock:
            self._set_up = False     # (_use_robot: the robot was set up for this config)
            self._apply_robot_config(config, compile_now=False)

    def _apply_robot_config(self, config, compile_now):
        """Set the robot for ``config``, under the lock; see :meth:`_on_config_change`."""
        if config.kinematics != 'model':
            self._robot_config, self._robot = config, None
            return
        source = description_source(config, self._description)
        if source is None:  # waiting for robot_description
            self._robot_config, self._robot = config, None
            return
        if self._compiled is not None and self._compiled[0] == source:
            if self._robot is not None and self._robot_fields == robot_fields(config):
                self._robot_config = config     # nothing the robot depends on: no look
                return
            if not self._file_changed():    # else compiled again, below
                self._use_robot(build_robot_setup(config, self._description,
                                                  self._compiled[1]), config)
                self._robot_config = config
                return
        if compile_now:
            identity = _FileIdentity.of(source)  # before it is read: a later edit reloads it
            robot = load_model(source)
            setup = build_robot_setup(config, self._description, robot)
            self._compiled = (source, robot, identity)
            self._robot_config = config
            self._use_robot(setup, config)
            return
        if source[0] == 'model_file':
            check_description_file(config.model_file)
        self._robot_config = config
        if source != self._pending:  # the queued compile sets up the latest config
            self._pending = source
            self._requests.put(_Compile(source))

    def _on_parameters_set(self, parameters):
        """
        Read ``model_file`` again when it is set to the path in use and the file has changed.

        And ``joint_limits_file`` when it is set, to the same path too
        (:meth:`_reread_limits_file`).  Runs on the executor after an
        accepted update (post-set callback).
        The path is the compiled model's, so :meth:`_on_config_change` kept
        it; when the file has changed on disk since it was compiled (see
        :class:`_FileIdentity`), it is compiled again on the worker, in order
        with the requests, and a file that no longer compiles is reported
        on ``~/status`` while the last good robot stays.
        """
        if (any(parameter.name == 'joint_limits_file' for parameter in parameters)
                and not self._set_up and self._pending is None):
            # (Set up for this update already, or to be on the worker: read then.)
            self._reread_limits_file()
        if not any(parameter.name == 'model_file' for parameter in parameters):
            return
        try:
            with self._robot_lock:
                config = self._robot_config
                if config.kinematics != 'model' or not config.model_file:
                    return
                source = description_source(config)
                if (self._compiled is None or self._compiled[0] != source
                        or source == self._pending):  # being compiled anew already
                    return
                # Changed, or gone (set explicitly: the worker then reports why).
                if _FileIdentity.of(source, digest=False) is None or self._file_changed():
                    self._pending = source
                    self._requests.put(_Compile(source))
        except Exception as exc:  # noqa: B902 - a parameter must never kill the node
            self._report(False, f'model_file: internal error: {type(exc).__name__}: {exc}', {})

    def _reread_limits_file(self):
        """
        Read ``joint_limits_file`` again after it was set, the same path too (post-set).

        A new path was read when it was set (:meth:`_on_config_change`); the
        same path was not, so an edited file's limits were not used until
        another robot parameter changed (plans 4 times over the new limit,
        helper-92).  The robot is set up again from the model it was
        compiled into; a file that no longer reads is reported on
        ``~/status``, and the last good limits stay.
        """
        try:
            with self._robot_lock:
                config, robot = self._robot_config, self._robot
                if config.kinematics != 'model' or not config.joint_limits_file or robot is None:
                    return
                try:
                    setup = build_robot_setup(config, self._description, robot.robot)
                except ValueError as exc:
                    self._report(False, f'joint_limits_file rejected: {exc}; keeping the '
                                        f'limits of the last good one', {
                                            'joint_limits_file': config.joint_limits_file})
                    return
                self._use_robot(setup, config)
        except Exception as exc:  # noqa: B902 - a parameter must never kill the node
            self._report(False, f'joint_limits_file: internal error: {type(exc).__name__}: '
                                f'{exc}', {})

    def _file_changed(self):
        """Whether the compiled model_file now holds other bytes (under the lock)."""
        source, robot, identity = self._compiled
        if identity is None:
            return False
        changed, identity = identity.changed(source)
        self._compiled = (source, robot, identity)
        return changed

    def _use_robot(self, setup, config):
        self._robot = setup
        self._set_up = True
        self._robot_fields = robot_fields(config)
        for note in setup.robot.notes:
            self.get_logger().warning(note)
        if setup.limits.unapplied:
            self.get_logger().warning(
                f'joint_limits_file: {unapplied_note(setup.limits.unapplied)}')
        values = {'robot': setup.source, 'joint_names': ' '.join(setup.config.joint_names),
                  'tool_frame': setup.tool_frame}
        if setup.tool_problem:
            values['tool_frame_problem'] = setup.tool_problem
        values.update(setup.limits.report())
        if setup.torque is not None:
            values.update(setup.torque.report(setup.config.joint_names))
        self._report(True, f'robot model loaded from {setup.summary()}', values)

    def _compile(self, source, what):
        """
        Compile ``source`` off the lock (on the worker), then set up the latest config.

        ``what`` names the source in messages.  A description that does not
        compile, or whose setup fails, is reported; the last good robot stays.
        """
        identity = _FileIdentity.of(source)  # before it is read: a later edit reloads it
        try:
            robot = load_model(source)
        except Exception as exc:  # noqa: B902 - e.g. a RecursionError: reported as refused
            with self._robot_lock:
                if self._pending == source:
                    self._pending = None
                if self._compiled is not None and self._compiled[0] == source:
                    # Its robot stays; the file, once readable again, is read again.
                    self._compiled = self._compiled[:2] + (_FileIdentity((), None),)
            if not isinstance(exc, ValueError):
                exc = ValueError(f'{type(exc).__name__}: {exc}')
            self._report_kept(what, exc, source)
            return
        with self._robot_lock:
            if self._pending == source:
                self._pending = None
            description = (source[1] if source[0] == 'robot_description'
                           else self._description)
            config = self._robot_config
            if (config.kinematics != 'model'
                    or description_source(config, description) != source):
                # A later config uses another description: keep this one for later.
                self._description, self._compiled = description, (source, robot, identity)
                return
            try:
                setup = build_robot_setup(config, description, robot)
            except ValueError as exc:
                self._report_kept(what, exc, source)
                return
            self._description, self._compiled = description, (source, robot, identity)
            self._use_robot(setup, config)
            if identity is not None and source != self._pending and self._file_changed():
                # Edited while it compiled (set again meanwhile, or not): once more.
                self._pending = source
                self._requests.put(_Compile(source))

    def _kept_robot(self):
        """Say which robot the node keeps planning with after a refused one."""
        robot = self._robot     # once: the executor may replace it
        return (f'; keeping the last good robot, of {robot.source}'
                if robot is not None else '; no robot to plan with')

    def _report_kept(self, what, exc, source):
        values = ({'robot_description_characters': len(source[1])}
                  if source[0] == 'robot_description' else {'model_file': source[1]})
        self._report(False, f'{what} rejected: {exc}{self._kept_robot()}', values)

    def _load_description(self, msg):
        """Take a robot_description (on the worker): compile it when the config uses it."""
        if len(msg.data) > MAX_DESCRIPTION_CHARS:
            self._report_kept('robot_description', f'it has {len(msg.data)} characters, more '
                              f'than the {MAX_DESCRIPTION_CHARS} accepted',
                              ('robot_description', msg.data))
            return
        with self._robot_lock:
            config = self._robot_config
            if config.kinematics != 'model' or config.model_file:
                self._description = msg.data  # kept for a later config without model_file
                return
        self._compile(('robot_description', msg.data), 'robot_description')

    def _on_joint_state(self, msg):
        self._joint_states.take(msg)

    def _work(self):
        while True:
            try:
                job = self._stops.popleft()
            except IndexError:
                job = self._requests.get()
            if job is _STOP:
                return
            if job is _WAKE:
                continue
            if isinstance(job, _Unread):
                job = self._read_unread(job)
                if job is None:
                    continue
            if isinstance(job, (String, _Compile)):
                try:
                    if isinstance(job, String):
                        self._load_description(job)
                    else:
                        self._compile(job.source, f'model_file {job.source[1]!r}')
                except Exception as exc:  # noqa: B902 - a description must never kill the node
                    self._report(False, f'robot model: internal error: '
                                        f'{type(exc).__name__}: {exc}', {})
                    self.get_logger().error(traceback.format_exc())
                continue
            if not isinstance(job, PlanJob):
                job = PlanJob(job)  # a waypoints or tool_waypoints message
            stop = job.kind == 'stop'
            if not stop:
                self._request_count += 1
            try:
                outcome = (self._serve_stop(job) if stop
                           else self._serve(job, self._request_count))
            except Exception as exc:  # noqa: B902 - a request must never kill the node
                message = f'internal error: {type(exc).__name__}: {exc}'
                values = {} if stop else {'request': self._request_count}
                self._report(False, ('stop: ' if stop else '') + message, values)
                self.get_logger().error(traceback.format_exc())
                outcome = PlanOutcome(False, message, values)
            if job.done is not None:
                try:
                    job.done(outcome)
                except Exception:  # noqa: B902 - a client's callback must never kill the node
                    self.get_logger().error(traceback.format_exc())

    def _request_config(self, job):
        """Return the config of one request: the parameters with its overrides (ValueError)."""
        if not job.overrides:
            return self.parameters.config
        return self.parameters.overridden(job.overrides)

    def _robot_for(self, config):
        """
        Return the RobotSetup that plans under ``config`` (kinematics "model"; ValueError).

        The node's own, or for a request whose overrides change the limits a
        setup of its own, built from the model the node's own was built from
        (quick, nothing kept).  Not from ``_compiled``: that may be another
        description's, compiled for a config that has since been replaced.
        """
        with self._robot_lock:  # the robot and the fields it was set up for, together
            robot = self._robot
            if robot is None:
                raise ValueError(NO_ROBOT_YET)
            if robot_fields(config) == self._robot_fields:
                return robot
            return build_robot_setup(config, self._description, robot.robot)

    def _serve(self, job, request_id, again=True):
        """
        Plan one request, report it on ``~/status``, publish it if asked: a PlanOutcome.

        A replanned request whose trajectory to take over from changed while
        it was planned (the one waiting for its stamp started, or a stop's
        hold took over) is planned ``again`` once, from the new one.
        """
        msg = job.msg
        config = self.parameters.config
        started = time.perf_counter()
        switch_ns = None
        switch_delay = 0.0
        planned_from = False    # the _Published (or None) a replanned request starts from
        tool_values = {}
        torque = None
        values = {'request': request_id}
        if job.interface:
            values['interface'] = job.interface
        try:
            config = self._request_config(job)
            robot = None
            if config.kinematics == 'model':
                robot = self._robot_for(config)
                torque = robot.torque_options(config)
                config = robot.effective(config)  # joint names and limits of the robot
                tool_values = robot.limits.report()
                if torque is not None:
                    # The limits planned to: max_effort less the headroom.
                    tool_values['limit_torque'] = format_vector(torque.max_torque)
                    tool_values['torque_headroom'] = f'{config.torque_headroom:g}'
            if isinstance(msg, PoseArray) and robot is not None:
                tool_path = plan_model_tool_request(
                    robot, tool_poses_from_message(msg, config.base_frame,
                                                   robot.robot.root_link),
                    self._joint_state_seed(config), config, torque)
                traj = tool_path.trajectory
                tool_values.update(tool_summary_values(tool_path))
            elif isinstance(msg, PoseArray):
                tool_path = plan_tool_request(config, parse_tool_request(msg))
                traj = tool_path.trajectory
                tool_values = tool_summary_values(tool_path)
            else:
                request = parse_waypoint_request(
                    msg, config.joint_names, config.start_from_current_state or job.from_running)
                now_ns = self.get_clock().now().nanoseconds
                # A goal of one point starts from the arm at rest too: "go there".
                if config.start_from_current_state or (job.from_running and (
                        self._running_at(now_ns) or request.waypoints.shape[0] == 1)):
                    requested_ns = now_ns + int(config.replan_lead_time * 1e9)
                    planned_from = self._base(now_ns)
                    switch_ns, traj = self._replan(config, request, requested_ns, torque,
                                                   planned_from)
                    switch_delay = 1e-9 * (switch_ns - requested_ns)
                else:
                    if job.from_running and job.publish:
                        self._check_goal_start(config, request)
                    traj = plan_request(config, request, torque)
            if isinstance(msg, PoseArray) and job.from_running and job.publish:
                self._check_tool_start(config, traj)    # a goal's, as a joint goal's
            planned = time.perf_counter()
            samples = output_samples(config, traj)
        except ValueError as exc:
            overload = raised_from(exc, GravityOverload)
            no_room = raised_from(exc, NoRoomToMove)
            if overload is not None:
                text, details = gravity_overload_report(overload, config.joint_names,
                                                        config.torque_headroom)
                values.update(details)
                exc = text
            elif no_room is not None:
                text, details = no_room_report(no_room, config.joint_names,
                                               config.torque_headroom,
                                               config.torque_counts_friction)
                values.update(details)
                exc = text
            return self._rejected(f'request {request_id} rejected: {exc}', values)
        # A topic request planned from its first waypoint (not replanned): its start is
        # checked against where the arm is at its stamp, once the message is built.
        from_first_waypoint = job.publish and not job.from_running and switch_ns is None
        out = trajectory_to_msg(samples, config.joint_names)
        # The clock is read once the message is built (thousands of points take
        # milliseconds, far more on a loaded machine), just before it is published.
        now_ns = self.get_clock().now().nanoseconds
        if switch_ns is None and job.publish and config.start_delay > 0.0:
            # Every published trajectory starts at a stamped time, so the planner and the
            # arm agree on its clock: a later stop, preemption or replanning then switches
            # without a jump (from "on receipt", the arm started a few ms later than the
            # planner counted: 0.019 rad at 3.4 rad/s).
            switch_ns = now_ns + int(round(config.start_delay * 1e9))
        if switch_ns is not None:
            out.header.stamp = Time(nanoseconds=switch_ns).to_msg()
        # (At the stamp the message has, read after it was built: before, a slow build
        # moved the comparison by its time, 0.25 s hid a 0.225 rad jump; helper-77.)
        start_warning = (self._topic_start_warning(config, traj, now_ns, switch_ns or now_ns)
                         if from_first_waypoint else None)
        if planned_from is not False and self._base(now_ns) is not planned_from:
            held = self._active is None     # a stop's hold, not a trajectory, took over
            what = ('the stop waiting for its stamp took hold' if held
                    else 'the trajectory waiting for its stamp started')
            if again:
                self.get_logger().info(f'request {request_id}: {what} while it was planned '
                                       'from the one before it: planned again')
                return self._serve(job, request_id, again=False)
            return self._rejected(
                f'request {request_id} rejected: {what} while this request was planned from '
                'the one before it, twice; ' + ('the arm holds' if held else
                                                'the running trajectory continues')
                + ' (send the request again)', values)
        if switch_ns is not None and now_ns > switch_ns:
            return self._rejected(
                f'request {request_id} rejected: planning took '
                f'{1e3 * (time.perf_counter() - started):.1f} ms, longer than '
                f'replan_lead_time ({config.replan_lead_time} s); the running '
                'trajectory continues', values)
        start_ns = now_ns if switch_ns is None else switch_ns
        if job.publish:
            self.trajectory_publisher.publish(out)
            self._published(traj, start_ns, config.joint_names, config, now_ns)
        published = time.perf_counter()
        values.update({'points': len(out.points),
                       'planning_time_ms': f'{1e3 * (planned - started):.3f}',
                       'publishing_time_ms': f'{1e3 * (published - planned):.3f}'})
        if switch_ns is not None:
            values['switch_time_ns'] = switch_ns
            values['switch_delay'] = f'{switch_delay:.9g}'
        values.update(summary_values(traj, config.joint_names))
        values.update(tool_values)
        through = f'{traj.waypoints.shape[0]} waypoints'
        if 'tool_waypoints' in tool_values:
            speed = ''
            if config.max_tool_speed and 'max_tool_speed_reached' in tool_values:
                speed = (f", tool speed {tool_values['max_tool_speed_reached']} m/s of "
                         f'{config.max_tool_speed:g}')
            through = (f"{tool_values['tool_waypoints']} tool waypoints "
                       f"({tool_values['inserted_waypoints']} inserted, deviation "
                       f"{tool_values['max_path_deviation_reached']} m{speed})")
        delayed = ''
        if switch_delay > 0.0:
            delayed = (f'; switching {switch_delay:.3f} s after now + replan_lead_time, '
                       'since no plan met the limits from the state there')
        warning = '; '.join(w for w in (start_warning, plan_warnings(traj)) if w) or None
        message = (f'request {request_id}: {traj.method}/{traj.timing} through '
                   f'{through} in {traj.duration:.4f} s{delayed}'
                   + ('' if warning is None else f'; WARNING: {warning}'))
        self._report(True, message, values, warn=warning is not None)
        self._publish_planned_path(traj, config, robot)
        return PlanOutcome(True, message, values, traj, out, config.joint_names,
                           start_ns if job.publish else None)

    def _publish_planned_path(self, traj, config, robot):
        """
        Publish the plan's tool path on ``~/planned_path``.

        Without a tool (or when it cannot be drawn) the markers of an earlier
        plan, if any are shown, are cleared: they are not the latest plan's.
        """
        tool = tool_position_function(config, robot)
        markers = None
        if tool is not None:
            forward, frame_id = tool
            try:
                path, waypoints = tool_path_points(traj, forward)
            except (ValueError, ArithmeticError) as exc:  # the plan stands without them
                self.get_logger().warning(f'planned_path: no markers: {exc}')
            else:
                # Stamped 0, RViz's "latest transform": the markers are latched, and an
                # RViz started later would look the frame up at their publish time, which
                # may have left its transform buffer.  The frame is fixed to the base.
                markers = planned_path_markers(path, waypoints, frame_id)
        if markers is None:
            if self._markers_shown:
                self.planned_path_publisher.publish(cleared_markers())
                self._markers_shown = False
            return
        self.planned_path_publisher.publish(markers)
        self._markers_shown = True

    def _rejected(self, message, values):
        """Report a rejected request on ``~/status``; return its PlanOutcome."""
        self._report(False, message, values)
        return PlanOutcome(False, message, values)

    def _running_at(self, now_ns):
        """Return True while a published trajectory runs at ``now_ns``, or waits to."""
        base, active = self._base(now_ns), self._active
        return ((base is not None and base.runs_at(now_ns))
                or (active is not None and active.start_ns > now_ns))

    def _serve_stop(self, job):
        """
        Stop the running trajectory (a cancelled goal): a PlanOutcome of the stop.

        The stop is planned from the commanded state at now +
        ``replan_lead_time`` (:func:`plan_stop`) and takes over there, so the
        arm brakes within the velocity, acceleration and jerk limits without
        a jump; an arm already (nearly) at rest holds its commanded position.
        When the trajectory waiting for its stamp starts while the stop is
        planned from the one before it, the stop is planned again from it.
        """
        for _ in range(STOP_ATTEMPTS):
            outcome = self._serve_stop_once(job.stopping)
            if outcome is not None:
                return outcome
        return self._rejected('stop rejected: the trajectory on the arm changed while the stop '
                              'was planned, every time; the running trajectory continues', {})

    def _serve_stop_once(self, stopping=None):
        """One attempt of :meth:`_serve_stop`: its PlanOutcome, or None to plan again."""
        lead = self.parameters.config.replan_lead_time
        now_ns = self.get_clock().now().nanoseconds
        if stopping is not None and (self._active is None or self._active.traj is not stopping):
            # A trajectory published since (a topic request planned while the cancel
            # waited for the worker) replaced the goal's: stopping would replace it in
            # turn (helper-77's race, found again by this stop's tests).
            message = 'nothing to stop: a newer trajectory replaced the one cancelled'
            self._report(True, message, {'replaced': 'true'})
            return PlanOutcome(True, message, {'replaced': 'true'})
        base, waiting = self._base(now_ns), self._active
        if waiting is not None and waiting.start_ns <= now_ns:
            waiting = None
        if base is None or not base.runs_at(now_ns):
            if waiting is None:
                return PlanOutcome(True, 'nothing to stop: the trajectory has ended', {})
            # Only a trajectory waiting for its stamp (a goal's start delay): replaced
            # by a hold where it would start, where the arm is.
            out = hold_message(waiting.traj.evaluate([0.0], 0)[0], list(waiting.names),
                               waiting.config.sample_period)
            self.trajectory_publisher.publish(out)
            self._published(None, now_ns, waiting.names, waiting.config, now_ns)
            message = 'stopping: the trajectory had not started; holding where it starts'
            self._report(True, message, {})
            return PlanOutcome(True, message, {}, None, out, list(waiting.names), now_ns)
        running, start_ns = base.traj, base.start_ns
        # The running trajectory's joints and limits (a goal's overrides, the robot's):
        # joint_names or the limits may have changed since, and the arm may run faster
        # than the node's limits now allow a stop to start from.
        names = list(base.names)
        config = replace(base.config, replan_lead_time=lead)
        switch_ns = now_ns + int(config.replan_lead_time * 1e9)
        t = 1e-9 * (switch_ns - start_ns)

        def clock():
            return (self.get_clock().now().nanoseconds - start_ns) * 1e-9
        # The trajectory ends at rest before the stop could take over: a hold of its end
        # is where the arm is then, however late it arrives.
        ends_first = t >= running.duration and ends_at_rest(config, running)
        try:
            stop = (plan_stop(config, running, t, clock)
                    if t < running.duration else None)
            if stop is None:
                traj, used = None, min(t, running.duration)
            else:
                used, traj = stop
            switch = start_ns + int(round(used * 1e9))
            stamp = Time(nanoseconds=switch).to_msg()
            if traj is None:
                out = hold_message(running.evaluate([used], 0)[0], names,
                                   config.sample_period, stamp)
            else:
                out = lasting_at_rest(trajectory_to_msg(output_samples(config, traj), names,
                                                        stamp))
        except ValueError as exc:
            return self._rejected(f'stop rejected: {exc}; the running trajectory continues',
                                  {})
        planned_ns = self.get_clock().now().nanoseconds
        if self._base(planned_ns) is not base:
            return None     # the waiting trajectory started meanwhile: from it
        if planned_ns > switch:
            if not ends_first:
                return self._rejected(f'stop rejected: planning took longer than '
                                      f'replan_lead_time ({config.replan_lead_time} s); the '
                                      'running trajectory continues', {})
            # The hold of the end, stamped now: it lasts its full second from its arrival.
            out.header.stamp = Time(nanoseconds=planned_ns).to_msg()
        self.trajectory_publisher.publish(out)
        self._published(traj, switch, names, config, now_ns)
        if traj is not None:
            message = (f'stopping: braking to rest in {traj.duration:.4f} s, from '
                       f'{1e-9 * (switch - now_ns):.3f} s after the cancel')
        elif ends_first:
            message = (f'stopping: the trajectory ends at rest '
                       f'{max(1e-9 * (switch - now_ns), 0.0):.3f} s after the cancel, '
                       'sooner than replan_lead_time; holding its end')
        else:
            message = 'stopping: holding the commanded position'
        self._report(True, message, {'switch_time_ns': switch})
        return PlanOutcome(True, message, {}, traj, out, names, switch)

    def _replan(self, config, request, switch_ns, torque=None, base=None):
        """
        Plan ``request`` from the state commanded at ``switch_ns``; return (switch_ns, traj).

        While the trajectory the arm runs (:meth:`_base`) runs at ``switch_ns``,
        its state there is the start (a later switch along it when none plans
        there: see plan_from_running); when it ends before then, its end;
        otherwise the latest joint_states are.  ``torque``: the
        TorqueOptions, or None (rest to rest only).  ``base``: :meth:`_base` at
        the request (the caller checks it is still the one before publishing).
        """
        now_ns = self.get_clock().now().nanoseconds
        # The running trajectory in the request's joint order (joint_names may have been
        # reordered since it was published); None: other joints.
        running = (None if base is None
                   else running_in_order(base.traj, base.names, config.joint_names))
        if running is not None:
            start_ns = base.start_ns
            t = (switch_ns - start_ns) * 1e-9
            if t < running.duration:
                def clock():
                    return (self.get_clock().now().nanoseconds - start_ns) * 1e-9
                used, traj = plan_from_running(config, request, running, t, clock, torque)
                return max(switch_ns, start_ns + int(round(used * 1e9))), traj
            if base.runs_at(now_ns):
                # It ends before the switch: the arm is then at its end, which the
                # latest joint_states, taken on the way there, are not.
                return switch_ns, plan_from_state_at(config, request, running,
                                                     running.duration, torque)
        return switch_ns, plan_request(config, start_from_state(
            request, *self._joint_state_start(config), config.waypoint_tolerance), torque)

    def _joint_state_seed(self, config):
        """Return the latest joint_states positions of the planned joints, or None."""
        try:
            return self._joint_state_start(config)[0]
        except ValueError:
            return None

    def _check_goal_start(self, config, request):
        """
        Refuse a goal that starts away from the arm at rest (ValueError), as MoveIt does.

        Nothing runs, so the goal's trajectory starts at its first waypoint:
        one further than ``goal_position_tolerance`` from the latest
        ``joint_states`` would make the arm jump there.  Without
        ``joint_states`` of the planned joints there is nothing to check.
        """
        self._check_start(config, request.waypoints[0], 'the first waypoint is',
                          'start the waypoints where the arm is, or set '
                          'start_from_current_state')

    def _check_tool_start(self, config, traj):
        """
        Refuse a tool path whose first pose's joints are away from the arm at rest (ValueError).

        The inverse kinematics chooses those joints (seeded from
        ``joint_states`` with a model, the elbow's side on the planar arm),
        not the user: where it chose others the arm would jump there
        (helper-66: 0.9 rad on a UR5).  Goals only: on the topics a request
        starts where its first waypoint is, as on joint_trajectory_controller.
        """
        self._check_start(config, traj.evaluate([0.0], 0)[0],
                          "the tool path's first pose solves to joints",
                          'start the tool poses where the tool is')

    def _check_start(self, config, start, what, advice):
        """Raise ValueError when ``start`` is beyond goal_position_tolerance of joint_states."""
        gap = self._start_gap(config, start, what)
        if gap is not None:
            raise ValueError(f'{gap}: the arm would jump; {advice}')

    def _start_gap(self, config, start, what, reference=None,
                   where="the arm's position on joint_states"):
        """
        Say how far ``start`` is from ``reference`` beyond goal_position_tolerance; else None.

        ``reference``: the latest joint_states when None (``where`` says
        which); None too without them for the planned joints (nothing to
        compare).
        """
        if reference is None:
            measured = self.measured_state(config.joint_names)
            if measured is None:
                return None
            reference = measured[0]
        gap = np.abs(np.asarray(start) - reference)
        j = int(np.argmax(gap))
        if gap[j] <= config.goal_position_tolerance:
            return None
        return (f'{what} {gap[j]:.4g} from {where} ({config.joint_names[j]}), more than '
                f'goal_position_tolerance ({config.goal_position_tolerance:g})')

    def _topic_start_warning(self, config, traj, now_ns, at_ns):
        """
        Warn of a topic request whose start is away from where the arm will be; else None.

        Planned and published as sent, as joint_trajectory_controller takes a
        trajectory (a goal is refused instead: :meth:`_check_goal_start`):
        the arm jumps to its first point when it starts, at ``at_ns`` (its
        stamp), and the dynamic arm's torque saturates on the way, which
        was all it said (helper-74: a UR5 swung 1.9 rad).  Where the arm
        will be: on the trajectory it takes over from (running or ended
        by then) while that one runs now, else at rest on ``joint_states``
        (helper-75: a request sent while an earlier one waited or ran was
        not checked).
        """
        start = traj.evaluate([0.0], 0)[0]
        base = self._base(now_ns)
        # One still running (or about to): the arm follows it until this one starts.
        running = (None if base is None or at_ns < base.start_ns or now_ns >= base.end_ns
                   else running_in_order(base.traj, base.names, config.joint_names))
        if running is not None:
            t = min(1e-9 * (at_ns - base.start_ns), running.duration)
            gap = self._start_gap(config, start, 'it starts', running.evaluate([t], 0)[0],
                                  'where the trajectory it replaces has the arm then')
        else:
            gap = self._start_gap(config, start, 'it starts')
        if gap is None:
            return None
        return (f'{gap}: the arm jumps there; start the waypoints where the arm will be, '
                'or set start_from_current_state (a follow_waypoints goal starts from a '
                'running trajectory, and refuses a start away from the arm at rest)')

    def _joint_state_start(self, config):
        """Position, velocity and zero acceleration from the latest joint_states."""
        if self._joint_states.latest() is None:
            raise ValueError('start_from_current_state: no trajectory is running and no '
                             'joint_states have been received yet')
        state = self._joint_states.covering(config.joint_names)
        if state is None:
            raise ValueError(f'start_from_current_state: no joint_states name every joint of '
                             f'{list(config.joint_names)} (joints seen: '
                             f'{self._joint_states.names_seen()})')
        names = list(state.name)
        order = [names.index(n) for n in config.joint_names]
        if len(state.position) != len(names):
            raise ValueError(f'start_from_current_state: the latest joint_states have '
                             f'{len(state.position)} positions for {len(names)} names')
        position = np.array([state.position[i] for i in order], dtype=float)
        velocity = (np.array([state.velocity[i] for i in order], dtype=float)
                    if len(state.velocity) == len(names) else np.zeros(len(order)))
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
            raise ValueError('start_from_current_state: the latest joint_states are not finite')
        return position, velocity, np.zeros(len(order))

    def _on_parameters_rejected(self, reason, names):
        # Already logged by ConfigParameters; monitors see it on ~/status too.
        self.status_publisher.publish(status_message(
            self._status_name, False, f'parameter update {reason}',
            {'parameters': ' '.join(names)}))

    def _report(self, ok, message, values, warn=False):
        if not ok:
            self.get_logger().error(message)
        elif warn:
            self.get_logger().warning(message)
        else:
            self.get_logger().info(message)
        self.status_publisher.publish(status_message(self._status_name, ok, message, values,
                                                     warn))

    def destroy_node(self):
        """Stop the planning worker, then destroy the node."""
        self._follow_waypoints.destroy()
        self._requests.put(_STOP)
        self._worker.join(timeout=10.0)
        return super().destroy_node()


def main(args=None):
    """Run the planner node until Ctrl-C or shutdown."""
    run_node(PlannerNode, args)


if __name__ == '__main__':
    main()
