"""The planner's status of a published request, as the node tests read it."""

from diagnostic_msgs.msg import DiagnosticStatus

# How the planner's WARN of a topic request away from the arm at rest ends.
STARTS_AWAY = 'send a follow_waypoints goal, which refuses this'


def assert_planned(status):
    """
    Assert a request was planned: OK, or a WARN saying only that it starts away from the arm.

    Topic requests start at their first waypoint (a tool request's at the
    joints its first pose solves to) wherever the arm is, with that WARN;
    tests of other things need not start where the arm is.
    """
    if status.level == DiagnosticStatus.WARN:
        warning = status.message.split('; WARNING: ', 1)[-1]
        assert warning.startswith('it starts ') and warning.endswith(STARTS_AWAY), (
            status.message)
        return
    assert status.level == DiagnosticStatus.OK, status.message
