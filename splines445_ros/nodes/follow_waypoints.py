"""
planner_node's ``~/follow_waypoints`` action: plan, send to the arm, follow until settled.

A goal (``splines445_interfaces/action/FollowWaypoints``) carries what a
``Plan`` request carries.  The planner's worker plans it, publishes the
trajectory on ``joint_trajectory``, and this server then publishes feedback
every :data:`FEEDBACK_PERIOD`: the time from the start, the time left, and the
tracking error (measured ``joint_states`` position less the planned one at
that time).  The goal succeeds once the planned end has passed and the arm
has settled there (``goal_position_tolerance``, ``goal_velocity_tolerance``);
it is aborted when it has not settled ``goal_time_tolerance`` after the end.

* **Preemption.**  A new goal preempts the running one, as
  joint_trajectory_controller's ``FollowJointTrajectory`` does: the new plan
  starts from the running trajectory's state at now + ``replan_lead_time``,
  so the arm does not jump, and once it is on the arm the old goal is
  aborted ("preempted").  A new goal whose plan fails is aborted, and the
  running one goes on (it can still be cancelled).
  A tool-pose goal plans from rest and is rejected while a trajectory runs
  (a goal's, or one sent on the ``waypoints`` topic).
* **Cancel** stops the arm: a stop planned from the commanded state (the
  worker's ``plan_stop``, within the velocity, acceleration and jerk limits)
  takes over at now + ``replan_lead_time``; the goal ends canceled once the
  arm has settled.
* **Bad goals** (no or both kinds of waypoints, a malformed override, joints
  the node does not plan) are rejected at once with the reason logged and on
  ``~/status``; a goal whose plan fails is aborted with the planner's error.
  A trajectory sent meanwhile on the ``waypoints`` topic replaces the goal's
  on the arm: the goal is aborted, saying so.

Nothing here blocks the executor: the execute callback is a coroutine that
waits on futures completed by the worker and by a timer.
"""

import array
import math

import numpy as np
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from splines445_interfaces.action import FollowWaypoints

from .ros_conversions import check_finite_poses, joint_order, seconds_to_duration
from ..robot.user_text import show_names
from ..service.interface_requests import ARRAY_FIELDS, override_values, request_message
from ..service.model_planning import NO_ROBOT_YET

ACTION = '~/follow_waypoints'
# [s]: joint_states stamped further than this from the node's clock come from another clock.
CLOCK_GAP = 10.0
# Period of the feedback and of the checks for cancel, preemption and the end [s].
FEEDBACK_PERIOD = 0.05
INTERFACE = 'follow_waypoints'
# [s]: feedback compares joint_states with the plan at their stamp when it is at most this
# far from the clock (either way), else with the plan now.
MAX_STATE_AGE = 0.5


class _Run:
    """The state of one accepted goal."""

    def __init__(self, handle, previous=None):
        self.handle = handle
        self.preempted = False
        self.ended = False      # its execution has returned
        # The goal this one preempts once its plan is on the arm, and the one that
        # will preempt this one (accepted, still planning).
        self.previous, self.successor = previous, None


class FollowWaypointsServer:
    """The action server of a :class:`~.planner_node.PlannerNode` (see the module)."""

    def __init__(self, node):
        """Create the action server and its feedback timer on ``node``."""
        self._node = node
        self._run = None        # the _Run of the latest accepted goal, while it runs
        self._runs = {}         # id of a goal handle -> its _Run, until its execution starts
        self._ticks = []        # futures awaiting the next timer tick
        self._server = ActionServer(
            node, FollowWaypoints, ACTION, execute_callback=self._execute,
            goal_callback=self._on_goal, handle_accepted_callback=self._on_accepted,
            cancel_callback=self._on_cancel)
        # On the steady clock: a cancel is acted on (its stop planned and sent) while a
        # simulated clock is paused, not only once it resumes (helper-68).
        self._timer = node.create_timer(FEEDBACK_PERIOD, self._on_tick,
                                        clock=Clock(clock_type=ClockType.STEADY_TIME))

    def destroy(self):
        """Destroy the action server and its timer."""
        self._node.destroy_timer(self._timer)
        self._server.destroy()

    def _on_goal(self, goal):
        try:
            msg = request_message(goal.waypoints, goal.tool_waypoints)
            if self._node.waiting_for_robot():
                # Not "this node controls 0 joints" (helper-88): the plan service's reason.
                raise ValueError(NO_ROBOT_YET)
            values = override_values(goal.overrides, msg is goal.waypoints)
            if values:
                # Refused at once, as a set_parameters of them would be, not accepted and
                # then aborted (the worker validates them again with the parameters then).
                self._node.parameters.overridden(values)
                _check_per_joint(values, self._node.planned_joint_names())
            if msg is goal.waypoints:
                joint_order(msg.joint_names, self._node.planned_joint_names())
                _check_finite(msg)
            else:
                # At once, as joint goals are (_check_finite): it was accepted, then
                # aborted (helper-88).  The planner checks the rest when it plans.
                check_finite_poses(msg.poses)
            if msg is not goal.waypoints and (self._run is not None
                                              or self._node.trajectory_running()):
                raise ValueError('a tool_waypoints goal plans from rest, and a trajectory is '
                                 'running: cancel it (or wait for its end) first, or send '
                                 'joint waypoints')
        except ValueError as exc:
            self._node.report(False, f'{INTERFACE} goal rejected: {exc}',
                              {'interface': INTERFACE})
            return GoalResponse.REJECT
        return GoalResponse.ACCEPT

    def _on_accepted(self, handle):
        # The running goal is preempted once this one's plan is on the arm: if it
        # fails to plan, the running one goes on (and can still be cancelled).
        run = _Run(handle, self._run)
        if self._run is not None:
            self._run.successor = run
        self._run = self._runs[id(handle)] = run
        handle.execute()

    def _on_cancel(self, _handle):
        return CancelResponse.ACCEPT

    def _on_tick(self):
        ticks, self._ticks = self._ticks, []
        for tick in ticks:
            tick.set_result(None)

    async def _tick(self):
        tick = Future(executor=self._node.executor)
        self._ticks.append(tick)
        await tick

    async def _execute(self, handle):
        run = self._runs.pop(id(handle), None) or _Run(handle)
        goal = handle.request
        try:
            msg = request_message(goal.waypoints, goal.tool_waypoints)
            job = self._node.plan_job(msg, override_values(goal.overrides,
                                                           msg is goal.waypoints), publish=True,
                                      from_running=True, interface=INTERFACE)
            outcome = await self._node.submit(job)
            if not outcome.ok:
                self._failed(run)
                return self._end(run, handle.abort, outcome.message)
            earlier = run.previous
            while earlier is not None:      # on the arm now: the goals before it end
                earlier.preempted = True
                earlier = earlier.previous
            run.previous = None
            if run.preempted:
                return self._end(run, handle.abort, 'preempted by a newer goal')
            return await self._follow(run, outcome)
        finally:
            run.ended = True
            if self._run is run:
                self._run = None

    def _failed(self, run):
        """
        Take ``run`` (no plan found) out of the chain of goals: the one it was to preempt runs on.

        A goal accepted after it preempts that one instead, as the latest
        (goals A, B, C back to back with B failing: A's end was reported as
        replaced by a topic request, helper-72).
        """
        previous, successor = run.previous, run.successor
        if previous is not None and previous.successor is run:
            previous.successor = successor
        if successor is not None and successor.previous is run:
            successor.previous = previous
        if self._run is run:
            # The latest goal again, if it still runs (it may have ended while this one
            # planned: then none runs, and a tool goal is not refused as if one did).
            self._run = previous if previous is not None and not previous.ended else None
        run.previous = run.successor = None

    async def _follow(self, run, outcome):
        """Publish feedback until the arm settles at the end; return the result."""
        handle, node = run.handle, self._node
        config = node.parameters.config
        traj, names = outcome.trajectory, outcome.joint_names
        start_ns, end = outcome.start_ns, outcome.trajectory.duration
        shift = node.clock_shift_ns     # the clock's jumps so far (_now_then)
        final = traj.evaluate([traj.duration], 0)[0]
        while True:
            await self._tick()
            replaced = node.active_trajectory() is not traj
            if run.preempted or (replaced and run.successor is not None):
                # (A successor's plan can reach the arm a tick before it says so.)
                if handle.is_cancel_requested:
                    return self._end(run, handle.canceled, 'canceled: a newer goal took '
                                     'over', names, final)
                return self._end(run, handle.abort, 'preempted by a newer goal', names,
                                 final)
            if replaced:
                # Cancelled too: canceled, as when the stop finds it replaced (helper-79).
                mark = handle.canceled if handle.is_cancel_requested else handle.abort
                return self._end(run, mark, 'the trajectory on the arm was replaced (a '
                                 'request on the waypoints topic)', names, final)
            if handle.is_cancel_requested and run.successor is None:
                # With a newer goal still planning, its plan takes over (above), or it
                # fails and leaves none: a stop queued now would be planned after it, from
                # its trajectory, and brake the newer goal (helper-73).
                return await self._stop(run, names, final, traj)
            t = 1e-9 * (_now_then(node, shift) - start_ns)
            measured = node.measured_state(names)
            # The plan at the joint_states' stamp: at 50 Hz they are up to 20 ms old, and
            # against the plan now the error was 20 times the arm's (helper-76); a stamp a
            # little ahead is an arm's clock skew (helper-77).  States further off are
            # stale (a stream that stopped) or from another clock: against the plan now,
            # the error grows as it should (at their stamp it read 0: helper-79).
            age = -node.joint_state_clock_gap(names)
            taken = t - age if abs(age) <= MAX_STATE_AGE else t
            planned = traj.evaluate([min(max(taken, 0.0), end)], 0)[0]
            handle.publish_feedback(_feedback(t, end, names, measured, planned))
            if t < end:
                continue
            if _settled(measured, final, config):
                return self._end(run, handle.succeed, f'reached the end of the '
                                 f'{end:.4f} s trajectory and settled', names, final,
                                 success=True, duration=end)
            if t > end + config.goal_time_tolerance:
                why = _not_settled(measured, final, config, node.joint_state_clock_gap(names))
                return self._end(run, handle.abort, why, names, final, duration=end)

    async def _stop(self, run, names, final, traj):
        """Stop the arm for a cancel of the goal's ``traj``; return the result once it settled."""
        node = self._node
        stop = await node.submit(node.plan_job(None, {}, kind='stop', interface=INTERFACE,
                                               stopping=traj))
        if not stop.ok:
            # The running trajectory continues: the goal cannot end canceled.
            return self._end(run, run.handle.abort, f'cancel failed: {stop.message}', names,
                             final)
        if stop.values.get('replaced'):
            # A newer trajectory runs: nothing of this goal's is left to stop or settle.
            return self._end(run, run.handle.canceled, f'canceled: {stop.message}', names,
                             final)
        config = node.parameters.config
        shift = node.clock_shift_ns     # the clock's jumps so far (_now_then)
        end_ns = stop.start_ns or 0
        rest = final
        if stop.trajectory is not None:
            end_ns += int(stop.trajectory.duration * 1e9)
            rest = stop.trajectory.evaluate([stop.trajectory.duration], 0)[0]
        elif stop.msg is not None:
            rest = np.asarray(stop.msg.points[-1].positions, dtype=float)
        while True:
            await self._tick()
            if run.preempted:
                # A newer goal's plan took over from the stop: the arm follows it, not
                # the stop's end (it was compared with that end, and WARNed of).
                return self._end(run, run.handle.canceled, f'canceled: {stop.message}; a '
                                 'newer goal took over before the stop ended', names, rest)
            if (stop.msg is not None and run.successor is None
                    and node.active_trajectory() is not stop.trajectory):
                # A topic request replaced the stop (or its hold): the arm follows it, not
                # the stop's end (it waited for it and WARNed "did not settle"; helper-79).
                return self._end(run, run.handle.canceled, f'canceled: {stop.message}; the '
                                 'stop was replaced by a request on the waypoints topic',
                                 names, rest)
            now_ns = _now_then(node, shift)
            if now_ns < end_ns:
                continue
            measured = node.measured_state(names)
            settled = _settled(measured, rest, config)
            if settled or now_ns > end_ns + int(config.goal_time_tolerance * 1e9):
                # Canceled all the same (the client asked for it), but not quietly: an
                # arm still away from the stop's end did not stop as planned.
                message = f'canceled: {stop.message}'
                if not settled:
                    message += '; ' + _not_settled(measured, rest, config,
                                                   node.joint_state_clock_gap(names))
                return self._end(run, run.handle.canceled, message, names, rest,
                                 warn=not settled)

    def _end(self, run, mark, message, names=(), final=None, success=False, duration=0.0,
             warn=False):
        """
        Mark the goal (succeed, abort or canceled), report, and return its result.

        An aborted goal is an ERROR on ``~/status``; success and cancel are OK
        (WARN with ``warn``).
        """
        mark()
        result = FollowWaypoints.Result(success=success, message=message,
                                        duration=float(duration), joint_names=list(names))
        measured = self._node.measured_state(names) if names else None
        if measured is not None and final is not None:
            result.final_error = [float(v) for v in measured[0] - final]
        self._node.report(mark != run.handle.abort, f'{INTERFACE} goal: {message}',
                          {'interface': INTERFACE}, warn=warn)
        return result


def _now_then(node, shift):
    """
    Return the clock now [ns] on the timeline of when ``node.clock_shift_ns`` was ``shift``.

    A jump of the clock since then (a simulator reset) moved the planner's
    and the arm's trajectory starts by the jump (:mod:`clock_jumps`): the
    times a goal kept from then are compared with this.
    """
    return node.get_clock().now().nanoseconds - (node.clock_shift_ns - shift)


def _check_per_joint(values, names):
    """
    Refuse a per-joint override with another count than the planned joints (ValueError).

    The parameters check it against ``joint_names``; with ``kinematics:
    model`` and ``joint_names`` unset the planned joints are the robot's.
    """
    for name in ARRAY_FIELDS:
        if name in values and len(values[name]) != len(names):
            raise ValueError(f'overrides.{name} has {len(values[name])} values: it needs one '
                             f'per planned joint ({len(names)}: {show_names(names)})')


def _check_finite(msg):
    """
    Refuse a goal's joint waypoints with a value that is not finite (ValueError).

    All of a field's values at once (the messages' arrays are ``array('d')``,
    read without a copy): one array per point took 65 ms for 10,000
    waypoints in the goal callback (helper-70); the waypoint is looked up
    only when one is not finite.
    """
    for field in ('positions', 'velocities', 'accelerations'):
        values = np.frombuffer(b''.join(_buffer(getattr(p, field)) for p in msg.points))
        if np.all(np.isfinite(values)):
            continue
        for k, point in enumerate(msg.points):
            row = np.asarray(getattr(point, field), dtype=float)
            if not np.all(np.isfinite(row)):
                j = int(np.flatnonzero(~np.isfinite(row))[0])
                raise ValueError(f'waypoint {k}: {field}[{j}] is {row[j]}: values must be '
                                 'finite')


def _buffer(values):
    """Return the bytes of float64 ``values`` (an ``array('d')``, or a sequence of numbers)."""
    if isinstance(values, array.array) and values.typecode == 'd':
        return values.tobytes()
    return np.asarray(values, dtype=float).tobytes()


def _feedback(t, end, names, measured, planned):
    feedback = FollowWaypoints.Feedback()
    feedback.time_from_start = seconds_to_duration(max(t, 0.0))
    feedback.time_left = seconds_to_duration(max(end - max(t, 0.0), 0.0))  # of the motion
    feedback.joint_names = list(names)
    if measured is not None:
        error = measured[0] - planned
        feedback.tracking_error = [float(v) for v in error]
        feedback.max_tracking_error = float(np.max(np.abs(error)))
    else:
        feedback.max_tracking_error = math.nan  # no joint_states of these joints yet
    return feedback


def _settled(measured, final, config):
    """Return True when joint_states are within the goal tolerances of rest at ``final``."""
    if measured is None:
        return False
    position, velocity = measured
    return bool(np.max(np.abs(position - final)) <= config.goal_position_tolerance
                and (velocity is None
                     or np.max(np.abs(velocity)) <= config.goal_velocity_tolerance))


def _not_settled(measured, final, config, clock_gap=0.0):
    """
    Say why the arm is not where the goal ends (``clock_gap`` [s]: joint_states' stamp - now).

    A gap beyond :data:`CLOCK_GAP` is named too: the arm then runs on
    another clock (``use_sim_time`` on one node only), and its errors say so
    only on its own ``~/status`` (helper-68).
    """
    if measured is None:
        text = (f'no joint_states of the planned joints within goal_time_tolerance '
                f'({config.goal_time_tolerance:g} s) after the end: it cannot be confirmed')
    else:
        error = float(np.max(np.abs(measured[0] - final)))
        text = (f'the arm did not settle within goal_time_tolerance '
                f'({config.goal_time_tolerance:g} s) after the end: position error '
                f'{error:.4g} (goal_position_tolerance {config.goal_position_tolerance:g})')
    if abs(clock_gap) > CLOCK_GAP:
        text += (f"; the arm's joint_states are stamped {clock_gap:.6g} s from this node's "
                 'clock: do both nodes use the same clock (use_sim_time)?')
    return text
