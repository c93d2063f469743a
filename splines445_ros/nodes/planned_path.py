"""
The planned path as RViz markers: ``~/planned_path`` (visualization_msgs/MarkerArray).

After every plan the planner publishes the tool's path through forward
kinematics: a line strip along the trajectory and a sphere at every
waypoint, in the frame of the tool poses (the model's ``base_frame``, or
``world``; ``base_link`` for the planar arm), after a DELETEALL marker that
clears the previous plan's.  A joint-space planner (``kinematics: ""``) has no
tool, so it publishes none.
"""

from geometry_msgs.msg import Point
import numpy as np
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

# The line is sampled this often [s], with at most MAX_PATH_POINTS points.
PATH_PERIOD = 0.01
MAX_PATH_POINTS = 2000
LINE_WIDTH = 0.005       # m
WAYPOINT_DIAMETER = 0.02  # m
PLANAR_FRAME = 'base_link'
PATH_COLOUR = ColorRGBA(r=0.1, g=0.6, b=1.0, a=1.0)
WAYPOINT_COLOUR = ColorRGBA(r=1.0, g=0.5, b=0.0, a=1.0)


def tool_path_points(trajectory, forward):
    """
    Return (path (M, 3), waypoints (N, 3)): tool positions along ``trajectory`` [m].

    ``forward`` maps joint positions (K, n) to tool positions (K, 3).  The
    path is sampled every :data:`PATH_PERIOD` (fewer points on long plans, at
    most :data:`MAX_PATH_POINTS`), its end included.
    """
    count = int(min(MAX_PATH_POINTS, max(2, trajectory.duration / PATH_PERIOD + 1)))
    times = np.linspace(0.0, trajectory.duration, count)
    path = forward(trajectory.evaluate(times, 0))
    waypoints = forward(trajectory.evaluate(np.asarray(trajectory.waypoint_times), 0))
    return np.asarray(path, dtype=float), np.asarray(waypoints, dtype=float)


def tool_position_function(config, robot=None):
    """
    Return (forward, frame id) for a planner config, or None without a tool.

    ``forward`` maps joint positions (K, n) to tool positions (K, 3): the
    planar arm's (z = 0) with ``kinematics: planar_3dof``, the robot's tool
    frame in its ``base_frame`` with ``kinematics: model`` (``robot``, the
    RobotSetup, with a tool frame).
    """
    if config.kinematics == 'planar_3dof':
        arm = config.tool_kinematics()

        def planar(q):
            pose = arm.forward(q)
            return np.column_stack([pose[..., 0], pose[..., 1], np.zeros(len(pose))])
        return planar, PLANAR_FRAME
    if config.kinematics == 'model' and robot is not None and robot.kinematics is not None:
        kinematics = robot.kinematics

        def model(q):
            return kinematics.forward(q)[..., :3]
        return model, config.base_frame or 'world'
    return None


def planned_path_markers(path, waypoints, frame_id, stamp=None):
    """
    Return the MarkerArray of a plan: DELETEALL, the line strip, the waypoint spheres.

    ``path`` (M, 3) and ``waypoints`` (N, 3) in metres in ``frame_id``;
    ``stamp`` (builtin_interfaces/Time) on every marker, zero when None.
    """
    def marker(kind, marker_id, ns):
        m = Marker(type=kind, id=marker_id, ns=ns, action=Marker.ADD)
        m.header.frame_id = frame_id
        if stamp is not None:
            m.header.stamp = stamp
        m.pose.orientation.w = 1.0
        return m
    clear = Marker(action=Marker.DELETEALL)
    clear.header.frame_id = frame_id
    if stamp is not None:
        clear.header.stamp = stamp
    line = marker(Marker.LINE_STRIP, 0, 'tool_path')
    line.scale.x = LINE_WIDTH
    line.color = PATH_COLOUR
    line.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in path]
    spheres = marker(Marker.SPHERE_LIST, 1, 'waypoints')
    spheres.scale.x = spheres.scale.y = spheres.scale.z = WAYPOINT_DIAMETER
    spheres.color = WAYPOINT_COLOUR
    spheres.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in waypoints]
    return MarkerArray(markers=[clear, line, spheres])
