"""
The planned path as RViz markers: ``~/planned_path`` (visualization_msgs/MarkerArray).

After every plan the planner publishes the tool's path through forward
kinematics: a line strip along the trajectory and a sphere at every
waypoint, in the frame of the tool poses (the model's ``base_frame``, or
``world`` when it is empty; ``base_link`` for the planar arm, the frame of
``arm_sim_node``'s ``tool_pose``), after a DELETEALL marker that clears the
previous plan's.  A joint-space planner (``kinematics: ""``) has no tool, so
it publishes none.  Message building only: the node decides when to publish.
"""

from geometry_msgs.msg import Point
import numpy as np
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from ..service.arm_sim_config import PLANAR_FRAME

# The line is sampled this often [s], with at most MAX_PATH_POINTS points.
PATH_PERIOD = 0.01
MAX_PATH_POINTS = 2000
LINE_WIDTH = 0.005        # m
WAYPOINT_DIAMETER = 0.02  # m
# kinematics "model" with base_frame "": the model's world, by its URDF root
# link's name (RobotModel.root_link), or this where it has none (MJCF).
WORLD_FRAME = 'world'
PATH_NS, PATH_ID = 'tool_path', 0
WAYPOINTS_NS, WAYPOINTS_ID = 'waypoints', 1
PATH_COLOUR = (0.1, 0.6, 1.0, 1.0)      # r, g, b, a
WAYPOINT_COLOUR = (1.0, 0.5, 0.0, 1.0)


def path_times(trajectory, samples=None):
    """
    Return the times (M,) at which the tool path of ``trajectory`` is drawn.

    ``samples``: how many, evenly from 0 to the end (both included, at
    least 2); None = one every :data:`PATH_PERIOD`, at most
    :data:`MAX_PATH_POINTS`.
    """
    duration = float(trajectory.duration)
    if samples is None:
        samples = min(MAX_PATH_POINTS, int(np.ceil(duration / PATH_PERIOD)) + 1)
    return np.linspace(0.0, duration, max(2, int(samples)))


def tool_path_points(trajectory, forward, samples=None):
    """
    Return (path (M, 3), waypoints (N, 3)): tool positions of ``trajectory`` [m].

    ``forward`` maps joint positions (K, n) to tool positions (K, 3), as
    the functions of :func:`tool_position_function` do (they take one
    (n,) row to (3,) too).  The path is the trajectory at
    :func:`path_times` (``samples``), its start and end included; the
    waypoints are the trajectory's, where it passes them
    (``waypoint_times``).
    """
    path = forward(trajectory.evaluate(path_times(trajectory, samples), 0))
    passed = forward(trajectory.evaluate(np.asarray(trajectory.waypoint_times, dtype=float), 0))
    return _xyz(path, 'path'), _xyz(passed, 'waypoints')


def _xyz(points, what):
    """Return ``points`` as a float (K, 3) array (ValueError for another shape)."""
    array = np.asarray(points, dtype=float)
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f'forward kinematics gave {what} of shape {array.shape}, '
                         'not (K, 3)')
    return array


def tool_position_function(config, robot=None):
    """
    Return (forward, frame id) of a planner config, or None without a tool.

    ``forward`` maps joint positions (..., n) to tool positions (..., 3)
    [m]: with ``kinematics: planar_3dof`` the planar arm's (``link_lengths``;
    z = 0) in :data:`PLANAR_FRAME`; with ``kinematics: model`` the tool
    frame of ``robot`` (the planner's RobotSetup) in its ``base_frame``
    (when empty the URDF's root link, which TF knows, else
    :data:`WORLD_FRAME`).  None for ``kinematics: ""`` (joint space only)
    and for a model without a robot or tool frame yet.
    """
    if config.kinematics == 'planar_3dof':
        arm = config.tool_kinematics()

        def planar(joints):
            pose = arm.forward(joints)
            return np.stack([pose[..., 0], pose[..., 1], np.zeros_like(pose[..., 0])],
                            axis=-1)
        return planar, PLANAR_FRAME
    if config.kinematics == 'model' and robot is not None and robot.kinematics is not None:
        kinematics = robot.kinematics

        def model(joints):
            return kinematics.forward(np.asarray(joints, dtype=float))[..., :3]
        return model, kinematics.base_frame or robot.robot.root_link or WORLD_FRAME
    return None


def planned_path_markers(path, waypoints, frame_id, stamp=None):
    """
    Return the MarkerArray of a plan: DELETEALL, the line strip, the waypoint spheres.

    ``path`` (M, 3) and ``waypoints`` (N, 3) in metres in ``frame_id``;
    ``stamp`` (builtin_interfaces/Time) on every marker, zero (the latest
    transform, for RViz) when None.  The line strip (ns ``tool_path``, id 0)
    is :data:`LINE_WIDTH` wide, the spheres (ns ``waypoints``, id 1)
    :data:`WAYPOINT_DIAMETER` across.
    """
    clear = _marker(frame_id, stamp, action=Marker.DELETEALL)
    line = _marker(frame_id, stamp, type=Marker.LINE_STRIP, ns=PATH_NS, id=PATH_ID)
    line.scale.x = LINE_WIDTH
    line.color = ColorRGBA(r=PATH_COLOUR[0], g=PATH_COLOUR[1], b=PATH_COLOUR[2],
                           a=PATH_COLOUR[3])
    line.points = _points(path)
    spheres = _marker(frame_id, stamp, type=Marker.SPHERE_LIST, ns=WAYPOINTS_NS,
                      id=WAYPOINTS_ID)
    spheres.scale.x = spheres.scale.y = spheres.scale.z = WAYPOINT_DIAMETER
    spheres.color = ColorRGBA(r=WAYPOINT_COLOUR[0], g=WAYPOINT_COLOUR[1],
                              b=WAYPOINT_COLOUR[2], a=WAYPOINT_COLOUR[3])
    spheres.points = _points(waypoints)
    return MarkerArray(markers=[clear, line, spheres])


def cleared_markers():
    """
    Return the MarkerArray of a plan with no tool path: a DELETEALL alone.

    The latched markers of an earlier plan would otherwise stay in RViz,
    and be handed to any RViz started later, after ``kinematics`` became
    "" or a plan's markers could not be drawn (helper-72).
    """
    return MarkerArray(markers=[_marker('', None, action=Marker.DELETEALL)])


def _marker(frame_id, stamp, **fields):
    """Return a Marker with ``fields``, the header and an identity orientation."""
    marker = Marker(**fields)
    marker.header.frame_id = frame_id
    if stamp is not None:
        marker.header.stamp = stamp
    marker.pose.orientation.w = 1.0
    return marker


def _points(xyz):
    """Return geometry_msgs/Point of (K, 3) rows."""
    return [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in _xyz(xyz, 'points')]
