"""
Planning core: 445, 434 and 555 splines with limit-respecting timing (no ROS imports).

Usage::

    from splines445_ros.planning import plan
    traj = plan(waypoints, method='445', timing='uniform',
                max_velocity=[2, 2, 2], max_acceleration=[10, 10, 10])
    traj.evaluate([0.0, 0.5], derivative=1)

May import: numpy and scipy only.  Never rclpy or ROS message packages, and
nothing from the rest of the package (``robot``, ``cartesian``, ``sim``,
``service``, ``nodes``, ``tools``): it is the bottom layer (``test/test_layout.py``
checks this).
"""

from .limits import BindingLimit, JointLimits
from .methods import get_method, Method, METHOD_DEFINITIONS, METHODS
from .plan_options import DEFAULT_WAYPOINT_TOLERANCE, PlanOptions, TIMINGS
from .planner import check_position_limits, merge_duplicates, plan, plan_with_options
from .timing import chord_durations
from .trajectory import Samples, Trajectory

__all__ = [
    'BindingLimit', 'check_position_limits', 'chord_durations', 'DEFAULT_WAYPOINT_TOLERANCE',
    'get_method', 'JointLimits', 'merge_duplicates',
    'Method', 'METHOD_DEFINITIONS', 'METHODS', 'plan', 'plan_with_options', 'PlanOptions',
    'Samples', 'TIMINGS', 'Trajectory',
]
