"""Status reports of the nodes as ``diagnostic_msgs/DiagnosticStatus``."""

from diagnostic_msgs.msg import DiagnosticStatus, KeyValue

from ..robot.user_text import format_vector  # noqa: F401 - the nodes' status formatting


def status_message(name, ok, message, values=None, warn=False):
    """Build a status: level OK, WARN (``ok`` and ``warn``) or ERROR, a message and details."""
    status = DiagnosticStatus()
    if not ok:
        status.level = DiagnosticStatus.ERROR
    else:
        status.level = DiagnosticStatus.WARN if warn else DiagnosticStatus.OK
    status.name = name
    status.message = message
    status.values = [KeyValue(key=str(k), value=str(v)) for k, v in (values or {}).items()]
    return status


def status_values(status):
    """Key/value details of a status as a dict (for clients and tests)."""
    return {kv.key: kv.value for kv in status.values}
