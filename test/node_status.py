"""The planner's status of a published request, as the node tests read it."""

from diagnostic_msgs.msg import DiagnosticStatus

# How the planner's WARN of a topic request away from the arm begins and ends.
STARTS = 'it starts '
STARTS_AWAY = 'refuses a start away from the arm at rest)'


def other_warning(status):
    """Return the status's warning without the one of a start away from the arm, or None."""
    if '; WARNING: ' not in status.message:
        return None
    text = status.message.split('; WARNING: ', 1)[1]
    begin = text.find(STARTS)
    end = text.find(STARTS_AWAY, begin) if begin >= 0 else -1
    if end >= 0:
        text = (text[:begin] + text[end + len(STARTS_AWAY):]).strip('; ')
    return text or None


def is_planned(status):
    """
    Return True for a request planned: OK, or a WARN saying only that it starts away from the arm.

    Topic requests start at their first waypoint (a tool request's at the
    joints its first pose solves to) wherever the arm is, with that WARN;
    tests of other things need not start where the arm is.
    """
    if status.level == DiagnosticStatus.WARN:
        return STARTS_AWAY in status.message and other_warning(status) is None
    return status.level == DiagnosticStatus.OK


def assert_planned(status):
    """Assert :func:`is_planned`."""
    assert is_planned(status), status.message
