"""
Topic names (relative, so they remap and namespace) and QoS profiles.

* ``waypoints`` (planner input): reliable, volatile, depth 100.  Requests are
  commands: one must never be replayed to a planner that restarts, and a burst
  of requests is queued, each answered by one status.
* ``tool_waypoints`` (planner input, geometry_msgs/PoseArray): the same QoS
  as ``waypoints``, for the same reasons.
* ``joint_trajectory`` (planner output, arm input): reliable, transient-local,
  depth 1.  A subscriber that joins late (an arm started after the planner)
  still receives the latest trajectory, and only the latest one matters: a
  newer trajectory replaces an older one.
* ``~/status``: reliable, transient-local, depth 10, so a monitor that starts
  later sees the most recent outcomes.
* ``~/planned_path`` (planner output, visualization_msgs/MarkerArray, the
  tool path of the latest plan): ``LATCHED`` like ``joint_trajectory``
  (reliable, transient-local, depth 1), so an RViz started later still shows
  the latest plan.
* ``~/plan`` (service): reliable, depth 1000, so a burst of calls is queued, not
  dropped (the services default keeps 10); a client that sends bursts needs a
  deep queue of its own too (``PLAN_QOS``).
* ``joint_states`` and ``tool_pose``: the sensor-style default (reliable,
  volatile, depth 10), as robot_state_publisher and the rest of ROS expect.
"""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

WAYPOINTS = 'waypoints'
TOOL_WAYPOINTS = 'tool_waypoints'
JOINT_TRAJECTORY = 'joint_trajectory'
JOINT_STATES = 'joint_states'
TOOL_POSE = 'tool_pose'
STATUS = '~/status'
PLANNED_PATH = '~/planned_path'


def _reliable(depth, durability):
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=ReliabilityPolicy.RELIABLE, durability=durability)


REQUEST_QOS = _reliable(100, DurabilityPolicy.VOLATILE)
LATCHED = _reliable(1, DurabilityPolicy.TRANSIENT_LOCAL)
STATUS_QOS = _reliable(10, DurabilityPolicy.TRANSIENT_LOCAL)
STATE_QOS = _reliable(10, DurabilityPolicy.VOLATILE)
PLAN_QOS = _reliable(1000, DurabilityPolicy.VOLATILE)
