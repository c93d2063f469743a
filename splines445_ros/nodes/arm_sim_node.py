"""
``arm_sim_node``: the simulated arm, kinematic playback or MuJoCo dynamics.

Subscribes ``joint_trajectory`` (trajectory_msgs/JointTrajectory).  A
trajectory whose ``header.stamp`` is non-zero takes over at that time (zero =
on receipt); until then the running one continues.  A new trajectory replaces
the running one.  Between points the commanded state is interpolated as
ros2_control's joint_trajectory_controller does.

* ``simulation: kinematic``: the arm is the commanded state (exact playback).
* ``simulation: dynamic``: MuJoCo simulates the arm (the paper's planar arm
  built from parameters, or ``model_file``) under a PD + inverse-dynamics
  feed-forward joint controller with torque limits and actuator lag; the
  physics steps at ``physics_rate`` to follow the node's clock
  (``use_sim_time`` works); ``payload_*`` is carried by the tool frame.
  At the end of every trajectory, and 0.5 s later
  for the settling error, the tracking and effort figures go to ``~/status``
  (WARN when the torque saturated).

Publishes ``joint_states`` (sensor_msgs/JointState: positions, velocities,
and the applied torques as ``effort`` when dynamic) and the tool pose
(geometry_msgs/PoseStamped on ``tool_pose``) at ``publish_rate``, also while
idle; reports accepted and rejected trajectories on ``~/status``.
"""

import collections
from dataclasses import replace
import math
import queue
import threading
import time
import traceback

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
import numpy as np
from rclpy.node import Node
from rclpy.time import Time
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory

from . import raw_messages, ros_conversions, topics
from .clock_jumps import follow_clock_jumps, MAX_CATCH_UP
from .diagnostics import format_vector, status_message
from .node_main import run_node
from .parameters import ConfigParameters
from .ros_conversions import sampled_trajectory_from_msg
from ..robot.kinematics import PlanarArm
from ..service.arm_sim_config import ArmSimConfig, PLANAR_FRAME
from ..service.arm_sim_model import add_payload, resolve_model_config
from ..service.planner_config import MAX_LEAD_TIME
from ..sim.dynamic_sim import (
    DynamicArm, rotation_to_quaternion, TrackingMetrics, UnstableSimulation)
from ..sim.mujoco_model import load_arm_model

SETTLING_TIME = 0.5     # s after the end of a trajectory: settling_error
# Physics steps at most per callback (the rest at the next ones): at 20 kHz a
# 9.9 s jump of a simulated clock took 4.5 s in one callback, and joint_states
# stalled (helper-48); 10,000 take about 0.2 s.
MAX_CATCH_UP_STEPS = 10_000
# ... and for at most this long [s], in chunks of at most CATCH_UP_CHUNK steps: the
# steps alone did not bound the time (a UR5 at 20 kHz took 0.35 s a callback,
# helper-70); the physics then lags the clock and catches up at the next callbacks.
CATCH_UP_SECONDS = 0.05
CATCH_UP_CHUNK = 1000
# A trajectory stamped further ahead than this [s] gets a WARN (a clock the publisher
# does not share starts it decades later): the planner's lead times are at most this.
FAR_AHEAD = MAX_LEAD_TIME
# A last point's velocity above this [rad/s or m/s] is a moving end: joint_trajectory_
# controller's own test (a float's epsilon).  A knot time rounded to the nanosecond leaves
# 1e-18 on a plan that ends at rest, which was warned of (helper-78).
END_VELOCITY_EPSILON = float(np.finfo(np.float32).eps)
# A trajectory message larger than this [bytes] is read on the reader thread: about
# 5,000 points of 7 joints, some 60 ms of reading and converting here.
READ_ON_EXECUTOR_BYTES = 1_000_000


class ArmSimNode(Node):
    """The simulated arm: kinematic playback or MuJoCo dynamics."""

    def __init__(self, **kwargs):
        """Declare parameters, build the simulation, topics and the publishing timer."""
        super().__init__('arm_sim_node', **kwargs)
        self.parameters = ConfigParameters(self, ArmSimConfig, on_change=self._on_config,
                                           on_reject=self._on_parameters_rejected)
        config = self.effective = self._effective(self.parameters.config)
        self.arm = PlanarArm(*config.link_lengths)
        n = len(config.joint_names)
        self.position = np.array(config.initial_positions, dtype=float)
        self.velocity = np.zeros(n)
        self.acceleration = np.zeros(n)
        self.effort = None
        self._active = None      # (SampledTrajectory, start time in ns)
        self._pending = None     # (SampledTrajectory, start time in ns)
        self._hold = self.position.copy()
        self._metrics = None     # TrackingMetrics of the active trajectory (dynamic)
        self._info = None        # its points, duration and start
        self._settling = None    # (metrics, info, end position, report time in ns)
        self.dynamic = None      # DynamicArm when simulation is dynamic
        self._sim_ns = self._now_ns()
        self._last_ns = self._sim_ns   # the clock at the last callback: jumps (_follow_clock)
        self._clock_jumps = follow_clock_jumps(self, self._on_clock_jump)
        self._frozen = False     # the physics went unstable: no steps until a new config
        if config.dynamic:
            self.dynamic = self._build_dynamic(config, self.position, self.velocity)
        self._status_name = self.get_fully_qualified_name()
        self.joint_state_publisher = self.create_publisher(
            JointState, topics.JOINT_STATES, topics.STATE_QOS)
        self.pose_publisher = self.create_publisher(PoseStamped, topics.TOOL_POSE,
                                                    topics.STATE_QOS)
        self.status_publisher = self.create_publisher(DiagnosticStatus, topics.STATUS,
                                                      topics.STATUS_QOS)
        # Raw: a message larger than any accepted one is refused before it is read, and a
        # large one is read on the reader thread (200,000 points of 7 joints: 3.6 s).
        self._reads = queue.SimpleQueue()
        self._read_done = collections.deque()
        self._reads_pending = 0     # queued for the reader and not yet taken (executor's)
        self._generation = 0        # counts the configs applied (a read belongs to one)
        self._read_ready = self.create_guard_condition(self._on_reads_done)
        self._reader = threading.Thread(target=self._read_trajectories,
                                        name='trajectory reader', daemon=True)
        self._reader.start()
        self.create_subscription(JointTrajectory, topics.JOINT_TRAJECTORY,
                                 self._on_raw_trajectory, topics.LATCHED, raw=True)
        self._timer = self.create_timer(1.0 / config.publish_rate, self._on_timer)

    def _effective(self, config):
        """Return the config with model_file's own values filled in (ValueError)."""
        if not config.model_file:
            return replace(config, frame_id=config.frame_id or PLANAR_FRAME)
        effective, sources = resolve_model_config(config)
        for name, text in sources.items():
            self.get_logger().info(f'{config.model_file}: {name} from {text}')
        return effective

    @staticmethod
    def _build_dynamic(config, position, velocity):
        """Compile the MuJoCo arm and its controller at a state (ValueError with the reason)."""
        model = load_arm_model(config.joint_names, config.torque_limits,
                               config.actuator_time_constant, config.timestep,
                               planar=config.planar_model(), model_file=config.model_file,
                               tool_site=config.tool_site, tool_frame=config.tool_frame)
        add_payload(model, config)
        arm = DynamicArm(model, config.kp, config.kd, config.torque_limits,
                         design_pose=config.initial_positions)
        arm.set_state(position, velocity)
        return arm

    def _on_parameters_rejected(self, reason, names):
        # Already logged by ConfigParameters; monitors see it on ~/status too.
        self.status_publisher.publish(status_message(
            self._status_name, False, f'parameter update {reason}',
            {'parameters': ' '.join(names)}))

    def _on_config(self, config):
        """Apply a validated config; ValueError (model does not load) rejects it."""
        old = self.effective
        config = self._effective(config)
        n = len(config.joint_names)
        same_joints = tuple(config.joint_names) == tuple(old.joint_names)
        if same_joints and tuple(config.initial_positions) != tuple(old.initial_positions):
            raise ValueError('initial_positions take effect at start-up, or with new '
                             'joint_names in the same set_parameters_atomically call (a '
                             'plain set_parameters applies one parameter at a time): the arm '
                             'stays where it is')
        if old.dynamic and not config.dynamic and self._active is not None:
            raise ValueError('simulation cannot switch to kinematic while a trajectory runs '
                             '(its playback would jump to the commanded state): wait for '
                             'its end')
        if not same_joints and (self._active is not None or self._pending is not None):
            # It would be dropped, unreported, and the arm jump to initial_positions
            # (helper-90: accepted, ~/status silent, a goal left waiting).
            raise ValueError(f"the arm's joints cannot change (to {list(config.joint_names)}) "
                             'while a trajectory runs or waits for its start: it would be '
                             'dropped and the arm jump to initial_positions; wait for its end')
        state_ns = None
        if config.dynamic and self.dynamic is None and same_joints and hasattr(self, '_timer'):
            # The physics starts from the kinematic state now (its last tick's may be
            # seconds old at a low publish_rate, helper-91), at that time; it catches up
            # with the time the model takes to build (80 ms: started at the clock's time
            # after it, it lagged the command by that and saturated, helper-90).
            state_ns = self._now_ns()
            self._advance(state_ns)
        position = self.position if same_joints and len(self.position) == n else np.array(
            config.initial_positions, dtype=float)
        velocity = self.velocity if same_joints and len(self.velocity) == n else np.zeros(n)
        dynamic = self._build_dynamic(config, position, velocity) if config.dynamic else None
        if hasattr(self, '_timer') and config.publish_rate != old.publish_rate:
            # The new timer first: if it cannot be made, the old one keeps running.
            timer = self.create_timer(1.0 / config.publish_rate, self._on_timer)
            self._timer.cancel()
            self.destroy_timer(self._timer)
            self._timer = timer
        # Everything below cannot fail.
        self.arm = PlanarArm(*config.link_lengths)
        if not same_joints:
            self._active = self._pending = self._settling = self._metrics = None
            self._hold = position.copy()
        self.position, self.velocity = position.copy(), velocity.copy()
        self.acceleration = np.zeros(n)
        if dynamic is not None and self.dynamic is None:
            self._sim_ns = self._now_ns() if state_ns is None else state_ns
            if self._active is None:
                self._hold = position.copy()
        if dynamic is None:
            self._settling = self._metrics = None  # kinematic playback reports no tracking
        self.dynamic = dynamic
        self._frozen = False
        self.effective = config
        self._generation += 1
        self.effort = None if dynamic is None else dynamic.efforts()
        if dynamic is not None and self._active is not None and self._metrics is None:
            self._start_metrics()

    def _now_ns(self):
        return self.get_clock().now().nanoseconds

    def _on_raw_trajectory(self, data):
        """
        Bound a received trajectory's size before reading it, then take it.

        A small one is read here; a larger one (more than :data:`READ_ON_EXECUTOR_BYTES`)
        is read and converted on the reader thread, and so is every one received while
        a read is pending, so they are taken in the order they came.
        """
        joints = self.effective.joint_names
        limit = raw_messages.joint_trajectory_bytes(ros_conversions.MAX_TRAJECTORY_POINTS,
                                                    len(joints))
        reason = raw_messages.too_large(data, limit)
        if reason is not None:
            reason = f'trajectory rejected unread: {reason}'
        if not self._reads_pending:
            if reason is not None:
                self._error(reason)
                return
            if len(data) <= READ_ON_EXECUTOR_BYTES:
                try:
                    msg = raw_messages.read(data, JointTrajectory)
                except ValueError as exc:
                    self._error(f'trajectory rejected: {exc}')
                    return
                self._on_trajectory(msg)
                return
        # Behind the reads pending (a refusal too: said after them), or a large one.
        self._reads_pending += 1
        self._reads.put((b'' if reason else data, joints, self._generation, reason))

    def _read_trajectories(self):
        """Read and convert the queued messages (the reader thread); hand them to the executor."""
        while True:
            job = self._reads.get()
            if job is None:
                return
            data, joints, generation, refused = job
            if refused is not None:
                self._read_done.append((None, None, generation, refused))
                self._trigger_read_ready()
                continue
            try:
                msg = raw_messages.read(data, JointTrajectory)
                try:
                    parsed = sampled_trajectory_from_msg(msg, joints)
                except ValueError as exc:
                    parsed = exc
                result = (msg, parsed, generation, None)
            except ValueError as exc:
                result = (None, None, generation, f'trajectory rejected: {exc}')
            except Exception as exc:  # noqa: B902 - reported on the executor
                result = (None, None, generation, f'trajectory rejected: internal error: '
                                                  f'{type(exc).__name__}: {exc}')
            self._read_done.append(result)
            if not self._trigger_read_ready():
                return

    def _trigger_read_ready(self):
        """Wake the executor for the reads done; False once the node is destroyed."""
        try:
            self._read_ready.trigger()
        except Exception:  # noqa: B902 - the node is being destroyed
            return False
        return True

    def _on_reads_done(self):
        """Take the trajectories the reader thread has read, in the order they came."""
        while self._read_done:
            msg, parsed, generation, error = self._read_done.popleft()
            self._reads_pending -= 1
            if error is None and generation != self._generation:
                # Received under the parameters before: not taken under others.
                error = ('trajectory rejected: the parameters changed while it was being '
                         'read (it came before the change): send it again')
            if error is not None:
                self._error(error)
            else:
                self._on_trajectory(msg, parsed)

    def _on_trajectory(self, msg, parsed=None):
        """
        Take a trajectory; ``parsed``: its conversion (or the ValueError) by the reader.

        The reader converted it for the joints of the config it came under, which is
        still the one in force (:meth:`_on_reads_done` refuses it otherwise).
        """
        config = self.effective
        try:
            if isinstance(parsed, ValueError):
                raise parsed
            trajectory = (parsed if parsed is not None
                          else sampled_trajectory_from_msg(msg, config.joint_names))
            # A negative stamp is refused by rclpy's Time (ValueError) as well.
            stamp = Time.from_msg(msg.header.stamp).nanoseconds
        except ValueError as exc:
            message = f'trajectory rejected: {exc}'
            if config.built_in and 'this node controls' in str(exc):
                # Joints it does not have: the planner given a robot and the arm not
                # (helper-74).  (Not a joint of its own left out.)
                message += ("; this is the built-in planar arm: set model_file (the robot's "
                            'URDF or MJCF) to simulate a robot')
            self._error(message)
            return
        if self._frozen:
            # It would be accepted and never run: refused, with what brings the arm back.
            message = ('trajectory rejected: the physics went unstable and the arm holds its '
                       'last sane state until its parameters change (set_parameters, with '
                       'gains or a physics step it can follow)')
            self._error(message)
            return
        now = self._now_ns()
        self._follow_clock(now)
        start = stamp if stamp > 0 else now
        # The time the motion has reached (the physics' own, which may lag the clock).
        reached = now if self.dynamic is None else self._sim_ns
        late = max(0, reached - stamp) if stamp > 0 else 0
        if late and late >= int(round(trajectory.duration * 1e9)):
            # As joint_trajectory_controller does: it would only jump to its end (a
            # latched one from before a restart, or a clock the publisher does not share).
            message = (f'trajectory rejected: it ended {(late * 1e-9 - trajectory.duration):.6g} '
                       f"s ago (header.stamp {stamp * 1e-9:.3f} s, this node's time "
                       f'{reached * 1e-9:.3f} s: do both nodes use the same clock, '
                       'use_sim_time?); the arm keeps its state')
            self._error(message)
            return
        # Accepted all the same, with a WARN on ~/status: a monitor sees what the log says.
        warnings = []
        if stamp - reached > FAR_AHEAD * 1e9:
            warnings.append(f'it starts in {(stamp - reached) * 1e-9:.6g} s (header.stamp '
                            f'{stamp * 1e-9:.3f} s): do both nodes use the same clock, '
                            'use_sim_time?')
        if late:
            where = ('from where the arm is towards its first point'
                     if trajectory.times[0] > late * 1e-9 else
                     'part-way along its points: the arm jumps there')
            warnings.append(f'it arrived {late * 1e-9:.3f} s after its header.stamp and starts '
                            f'that far along, {where} (its publisher must stamp it further '
                            "ahead, as the planner's start_delay does)")
        if trajectory.velocities is not None and np.any(
                np.abs(trajectory.velocities[-1]) > END_VELOCITY_EPSILON):
            warnings.append('its last point has a non-zero velocity: the arm stops there at '
                            'once (joint_trajectory_controller rejects such a trajectory '
                            'unless allow_nonzero_velocity_at_trajectory_end is set)')
        warning = '; '.join(warnings) if warnings else None
        if self._pending is not None:
            replaced = 'trajectory replaced before it started'
            self.get_logger().warning(replaced)
            self.status_publisher.publish(status_message(
                self._status_name, True, replaced, {'start_ns': self._pending[1]}, warn=True))
        self._pending = (trajectory, start)
        message = (f'trajectory accepted: {len(msg.points)} points, '
                   f'{trajectory.duration:.4f} s')
        if warning is None:
            self.get_logger().info(message)
        else:
            message += f'; {warning}'
            self.get_logger().warning(message)
        self.status_publisher.publish(status_message(
            self._status_name, True, message,
            {'points': len(msg.points), 'duration': f'{trajectory.duration:.9g}',
             'start_ns': start, **({'started_late_by': f'{late * 1e-9:.9g}'} if late else {})},
            warn=warning is not None))
        self._on_timer()

    # -- kinematic playback ---------------------------------------------------------------

    def _advance(self, now):
        if self._pending is not None and now >= self._pending[1]:
            if self._active is not None:
                self._set_state(now)  # the state at the switch, from the old trajectory
            trajectory, start = self._pending
            self._pending = None
            self._active = (trajectory.with_start_state(
                self.position, self.velocity, self.acceleration, (now - start) * 1e-9), start)
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
            self.velocity = np.zeros(len(self.position))
            self.acceleration = np.zeros(len(self.position))

    # -- dynamic simulation ---------------------------------------------------------------

    def _reference(self, times_ns):
        """Commanded positions, velocities, accelerations (K, n) at node times (K,)."""
        if self._active is None:
            K = len(times_ns)
            zero = np.zeros((K, len(self._hold)))
            return np.tile(self._hold, (K, 1)), zero, zero.copy()
        trajectory, start = self._active
        return trajectory.states_at((times_ns - start) * 1e-9)

    def _start_metrics(self):
        trajectory, start = self._active
        self._metrics = TrackingMetrics(len(self._hold), self.dynamic.timestep)
        self._info = {'points': trajectory.times.size, 'duration': trajectory.duration,
                      'start_ns': start}

    def _follow_clock(self, now):
        """
        Keep the motion continuous across a jump of the clock (back, or ahead too far).

        A clock that goes back (a simulated one restarting, ``use_sim_time``
        switched on) or jumps ahead by more than the physics catches up with
        would start a trajectory mid-way or at its end: the arm would jump
        (and so would one received before a simulated clock started).
        Every time the node keeps (the running and pending trajectories'
        starts, the settling report, the physics clock) moves with the clock,
        so the motion goes on from where it was; a warning says so.  Only
        on a simulated clock (``use_sim_time``), whose jumps rcl reports to
        the planner too: on the system clock a gap between two readings is
        this process stalling (or an NTP step), which the planner does not
        see, so the arm plays its trajectory at the clock's time as
        joint_trajectory_controller does; shifted, it was 1.3 rad behind
        the planner's record of it after an 11 s stall, and the next
        replanned trajectory jumped it 0.49 rad (helper-90).
        """
        last, self._last_ns = self._last_ns, now
        jump = now - last
        if 0 <= jump <= MAX_CATCH_UP * 1e9 or not self.get_clock().ros_time_is_active:
            return
        self._shift_times(jump, warn=last > 0)

    def _on_clock_jump(self, jump, _change):
        """
        Move the kept times by a jump the clock reports (:mod:`clock_jumps`), exactly.

        The planner moves its own by the same amount; the reading of the last
        callback moves too, so :meth:`_follow_clock` does not count it again.
        """
        self._shift_times(jump, warn=self._last_ns > 0)
        self._last_ns += jump

    def _shift_times(self, jump, warn):
        """Move every time the node keeps by ``jump`` [ns] (see :meth:`_follow_clock`)."""
        if self._active is not None:
            self._active = (self._active[0], self._active[1] + jump)
        if self._pending is not None:
            self._pending = (self._pending[0], self._pending[1] + jump)
        if self._settling is not None:
            self._settling = self._settling[:3] + (self._settling[3] + jump,)
        if self.dynamic is not None:
            self._sim_ns += jump
        if warn:    # (not when a simulated clock starts: what came before starts with it)
            direction = 'back' if jump < 0 else 'ahead'
            self.get_logger().warning(
                f'the clock jumped {direction} by {abs(jump) * 1e-9:.6g} s: the motion goes on '
                'from where it was')

    def _advance_dynamic(self, now):
        if self._frozen:
            self._sim_ns = now  # held where the physics was sane, until a new config
            return
        dt_ns = int(round(self.dynamic.timestep * 1e9))
        if now < self._sim_ns or now - self._sim_ns > MAX_CATCH_UP * 1e9:
            if now > self._sim_ns > 0:  # (0: a simulated clock that had not started)
                self.get_logger().warning(
                    f'the clock jumped ahead by {(now - self._sim_ns) * 1e-9:.3g} s: the '
                    f'physics is not stepped across more than {MAX_CATCH_UP:g} s')
            self._sim_ns = now  # a clock reset or jump: carry the state over
        budget = MAX_CATCH_UP_STEPS
        deadline = time.perf_counter() + CATCH_UP_SECONDS
        while now - self._sim_ns >= dt_ns and budget > 0 and time.perf_counter() < deadline:
            self._handle_events()  # every event up to now is handled: the others are later
            steps = min((now - self._sim_ns) // dt_ns, budget, CATCH_UP_CHUNK)
            events = [event for event in self._event_times() if event > self._sim_ns]
            if events:
                steps = min(steps, -(-(min(events) - self._sim_ns) // dt_ns))
            times = self._sim_ns + dt_ns * np.arange(steps, dtype=np.int64)
            q_d, v_d, a_d = self._reference(times)
            try:
                log = self.dynamic.run(q_d, v_d, a_d)
            except UnstableSimulation as exc:
                self._unstable(exc, now)
                break
            if self._metrics is not None:
                self._metrics.update(q_d, log, self.dynamic.timestep)
            self._sim_ns += int(steps) * dt_ns
            budget -= int(steps)
        self._handle_events()
        arm = self.dynamic
        self.position, self.velocity, self.effort = (arm.positions(), arm.velocities(),
                                                     arm.efforts())

    def _error(self, message):
        """Log ``message`` as an error and publish it on ``~/status`` (ERROR)."""
        self.get_logger().error(message)
        self.status_publisher.publish(status_message(self._status_name, False, message))

    def _drop_trajectories(self):
        """Drop every trajectory; the dynamic arm holds its present pose, at rest."""
        self._active = self._pending = self._settling = self._metrics = self._info = None
        if self.dynamic is not None:
            self._hold = self.dynamic.positions()
            self.dynamic.set_state(self._hold, np.zeros(len(self._hold)))

    def _drop_after(self, exc):
        """Drop the trajectories after an unexpected error; the arm holds still where it is."""
        self.get_logger().error(traceback.format_exc())
        self._drop_trajectories()
        self.velocity = np.zeros(len(self.position))
        self.acceleration = np.zeros(len(self.position))
        message = (f'internal error: {type(exc).__name__}: {exc}; the trajectory is dropped '
                   'and the arm holds its position')
        self.status_publisher.publish(status_message(self._status_name, False, message))

    def _unstable(self, exc, now):
        """Hold the state before the physics went unstable, drop the trajectories, say so."""
        self._drop_trajectories()
        self._sim_ns = now
        self._frozen = True
        self._error(f'{exc}; the arm holds its last sane state until its parameters change, '
                    'the trajectory is dropped')

    def _event_times(self):
        """Node times [ns] of the next switch, trajectory end and settling report."""
        if self._pending is not None:
            yield self._pending[1]
        if self._active is not None:
            yield self._active[1] + int(round(self._active[0].duration * 1e9))
        if self._settling is not None:
            yield self._settling[3]

    def _handle_events(self):
        now = self._sim_ns
        if self._settling is not None and now >= self._settling[3]:
            self._report(*self._settling[:3], settled=True)
            self._settling = None
        if self._active is not None:
            trajectory, start = self._active
            if now >= start + int(round(trajectory.duration * 1e9)):
                self._hold = trajectory.positions[-1].copy()
                self._settling = (self._metrics, self._info, self._hold.copy(),
                                  now + int(round(SETTLING_TIME * 1e9)))
                self._active = self._metrics = self._info = None
        if self._pending is not None and now >= self._pending[1]:
            if self._settling is not None:
                self._report(*self._settling[:3], settled=False)
                self._settling = None
            q, v, a = self._reference(np.array([now], dtype=np.int64))
            if self._active is not None:
                self._report(self._metrics, self._info, None, settled=False)
            trajectory, start = self._pending
            self._pending = None
            self._active = (trajectory.with_start_state(q[0], v[0], a[0], (now - start) * 1e-9),
                            start)
            self._start_metrics()

    def _report(self, metrics, info, end_position, settled):
        """Publish the tracking figures of a finished (or replaced) trajectory."""
        if metrics is None:
            return
        figures = metrics.summary()
        values = {'duration': f"{info['duration']:.9g}", 'start_ns': info['start_ns'],
                  'points': info['points']}
        for key in ('tracking_rms_error', 'tracking_max_error', 'peak_effort',
                    'peak_effort_rate'):
            values[key] = format_vector(figures[key])
        if 'tool_max_error' in figures:
            values['tool_max_error'] = f"{figures['tool_max_error']:.6g}"
        if end_position is None:
            message = 'trajectory replaced before its end'
        else:
            error = np.abs(end_position - self.dynamic.positions())
            values['settling_error'] = format_vector(error)
            message = 'trajectory finished'
            if not settled:
                message += f' (settling_error at the next trajectory, before {SETTLING_TIME} s)'
        values['saturated_steps'] = figures['saturated_steps']
        saturated = figures['saturated_steps'] > 0
        if saturated:
            message += (f': torque saturated on {figures["saturated_steps"]} of '
                        f'{metrics.steps} physics steps')
            self.get_logger().warning(message)
        else:
            self.get_logger().info(message)
        self.status_publisher.publish(status_message(self._status_name, True, message,
                                                     values, warn=saturated))

    # -- publishing -----------------------------------------------------------------------

    def _on_timer(self):
        now = self._now_ns()
        self._follow_clock(now)
        try:
            if self.dynamic is not None:
                self._advance_dynamic(now)
                now = self._sim_ns  # the physics time of the state (at most one step earlier)
            else:
                self._advance(now)
        except Exception as exc:  # noqa: B902 - a trajectory must never kill the node
            self._drop_after(exc)
            now = self._sim_ns if self.dynamic is not None else now
        stamp = Time(nanoseconds=now).to_msg()
        config = self.effective
        state = JointState()
        state.header.stamp = stamp
        state.name = list(config.joint_names)
        state.position = self.position.tolist()
        state.velocity = self.velocity.tolist()
        if self.dynamic is not None:
            state.effort = self.effort.tolist()
        self.joint_state_publisher.publish(state)
        pose = PoseStamped()
        pose.header.stamp = stamp
        pose.header.frame_id = config.frame_id
        if self.dynamic is not None:
            tool = self.dynamic.tool_pose()
            if tool is None:
                return
            position, rotation = tool
            pose.pose.position.x, pose.pose.position.y, pose.pose.position.z = (
                float(v) for v in position)
            w, x, y, z = rotation_to_quaternion(rotation)
            pose.pose.orientation.w, pose.pose.orientation.x = w, x
            pose.pose.orientation.y, pose.pose.orientation.z = y, z
        elif config.model_file:
            return  # kinematic playback of a model file's joints: no planar kinematics
        else:
            x, y, yaw = self.arm.forward(self.position)
            pose.pose.position.x = float(x)
            pose.pose.position.y = float(y)
            pose.pose.orientation.z = math.sin(0.5 * yaw)
            pose.pose.orientation.w = math.cos(0.5 * yaw)
        self.pose_publisher.publish(pose)

    def destroy_node(self):
        """Stop the trajectory reader (dropping the reads not begun), then destroy the node."""
        try:
            while True:
                self._reads.get_nowait()
        except queue.Empty:
            pass
        self._reads.put(None)
        self._reader.join(timeout=10.0)
        return super().destroy_node()


def main(args=None):
    """Run the arm simulation until Ctrl-C or shutdown."""
    run_node(ArmSimNode, args)


if __name__ == '__main__':
    main()
