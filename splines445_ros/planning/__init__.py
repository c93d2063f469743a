"""
Planning core: 445, 434 and 555 splines with limit-respecting timing (no ROS imports).

Usage::

    from splines445_ros.planning import plan
    traj = plan(waypoints, method='445', timing='uniform',
                max_velocity=[2, 2, 2], max_acceleration=[10, 10, 10])
    traj.evaluate([0.0, 0.5], derivative=1)

One room (folder) per concept, each importing only the rooms above it in
this list (its ``__init__`` says which; ``test/test_layout.py`` checks)::

    spline          the 445/434/555 pieces, their banded system, peaks, Trajectory
    durations       segment durations with knots at the waypoints (paper, optimal)
    constraints     the limits along a path, one class per limit; torque
    speed_profile   speed profiles s(t) along a path that hold the constraints
    path_following  C4 splines with inner knots that follow a speed profile

and three modules at the top: ``validation`` (array checks, which every
room may import), ``plan_options`` (the validated request: it imports
``spline`` and ``constraints``, and ``path_following`` imports it) and
``planner`` (``plan()``: which timing, and the other plans where one
fails; it imports them all).

May import: numpy and scipy only (and highspy where it is installed:
``speed_profile.smooth_profile`` calls it directly, else scipy's HiGHS).
Never rclpy or ROS message packages, and nothing from the rest of the
package (``robot``, ``cartesian``, ``sim``, ``service``, ``nodes``,
``tools``): it is the bottom layer (``test/test_layout.py`` checks this).
"""

from .durations.timing import chord_durations
from .plan_options import DEFAULT_WAYPOINT_TOLERANCE, PlanOptions, TIMINGS
from .planner import check_position_limits, merge_duplicates, plan, plan_with_options
from .spline.limits import BindingLimit, JointLimits
from .spline.methods import get_method, Method, METHOD_DEFINITIONS, METHODS
from .spline.trajectory import Samples, Trajectory

__all__ = [
    'BindingLimit', 'check_position_limits', 'chord_durations', 'DEFAULT_WAYPOINT_TOLERANCE',
    'get_method', 'JointLimits', 'merge_duplicates',
    'Method', 'METHOD_DEFINITIONS', 'METHODS', 'plan', 'plan_with_options', 'PlanOptions',
    'Samples', 'TIMINGS', 'Trajectory',
]
