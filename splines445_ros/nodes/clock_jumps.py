"""
Jumps of a node's ROS clock, exactly as rcl reports them: one rule for both nodes.

A simulated clock that restarts (a simulator reset), one that starts after
the node did, or ``use_sim_time`` switched on moves the clock by a jump
that is not time passing.  ``arm_sim_node`` moves every time it keeps
(its trajectories' starts, its physics clock) by the jump, so the motion
goes on from where it was; ``planner_node`` must move the starts it keeps
(the running and the waiting trajectory, a goal's) by the same amount, or a
later stop, preemption or replanning plans from the wrong state and the arm
jumps (helper-68: 1.15 rad on a cancel after a reset, 0.5 rad on a
preemption).  Both take the jump from the clock's jump callback
(``Clock.create_jump_callback``): its exact size, the same in both nodes.
"""

from rclpy.clock import JumpThreshold
from rclpy.duration import Duration

# A forward jump above this [s] is a jump (the arm does not simulate across it);
# any backward jump is one.  Forward jumps below it are time passing: the arm's
# physics catches up with them, the planner's stamps stay.
MAX_CATCH_UP = 10.0


def follow_clock_jumps(node, on_jump):
    """
    Call ``on_jump(delta_ns, clock_change)`` on every jump of ``node``'s clock; return its handle.

    Keep the handle as long as the callbacks are wanted (a JumpHandle; the
    callback runs in the thread that sets the time: the executor's, with
    ``use_sim_time``).  Jumps of the system clock (NTP) are not reported by
    rcl, so neither node moves its times for them (the arm watches its own
    readings for jumps on a simulated clock only).
    """
    threshold = JumpThreshold(min_forward=Duration(nanoseconds=int(MAX_CATCH_UP * 1e9)),
                              min_backward=Duration(nanoseconds=-1), on_clock_change=True)
    return node.get_clock().create_jump_callback(
        threshold, post_callback=lambda jump: on_jump(int(jump.delta.nanoseconds),
                                                      jump.clock_change))
