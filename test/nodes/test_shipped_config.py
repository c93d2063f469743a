"""
config/planar_arm.yaml as shipped: the paper's triangle through tool_waypoints, every method.

In a module of its own: no other in-process system may be alive in the same
domain (another planner would answer the same topics).
"""

import os

from diagnostic_msgs.msg import DiagnosticStatus
from node_status import other_warning
import numpy as np
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.robot import paper_example as pe
from splines445_ros.tools.in_process import InProcessSystem, tool_waypoint_message


def test_the_shipped_config_refines_the_paper_triangle_for_every_method():
    path = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'planar_arm.yaml')
    xy = pe.triangle_points()
    request = tool_waypoint_message(np.column_stack([xy, np.zeros(len(xy))]))
    with InProcessSystem(params_file=path,
                         arm_parameters={'simulation': 'kinematic'}) as system:
        for method in ('445', '434', '555'):
            assert system.set_planner_parameters({'method': method})[0].successful
            status, trajectory = system.request(request)
            # 445 uniform, refined and jerk-limited, lasts 70 s, 37 times the
            # lower bound: a WARN that suggests optimal timing, not an error.
            assert status.level in (DiagnosticStatus.OK, DiagnosticStatus.WARN), status.message
            # (Each starts where the arm is not: a WARN says so; node_status.)
            slow = other_warning(status)
            assert (slow is not None) == (method == '445'), status.message
            assert slow is None or 'optimal' in slow
            values = status_values(status)
            assert float(values['max_path_deviation_reached']) <= 1e-3
            assert int(values['inserted_waypoints']) > 0 and trajectory is not None
        # With the node's default cap (200), 445 stops with an error that says why.
        assert system.set_planner_parameters({'method': '445',
                                              'max_inserted_waypoints': 200})[0].successful
        status, _ = system.request(request)
        assert status.level == DiagnosticStatus.ERROR
        assert 'after inserting 200 waypoints' in status.message and '555' in status.message
