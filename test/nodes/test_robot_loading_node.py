"""
planner_node never waits for MuJoCo on its executor, and compiles a robot only when needed.

Issue 22: a 6.7 MB description compiled for minutes inside the parameter
callback, so every ``set_parameters`` waited, and any later parameter change
(even ``method``) compiled the robot again.  Here the compile is held on an
event the test controls: a parameter update must be answered while it is
held, and the counts of compiles say what was rebuilt.
"""

import os
import threading

from diagnostic_msgs.msg import DiagnosticStatus
from node_status import assert_planned
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.tools import vendor_robots as vr
from splines445_ros.tools.in_process import InProcessSystem, overrides, waypoint_message
from test_model_planner_node import LIMITS_YAML

CONFIG = os.path.join(os.path.dirname(__file__), '..', '..', 'config')
# What the defaults are since issue 22, spelled out (as before it).
ALL_FROM_MODEL = {'joint_names': [''], 'max_velocity': [0.0], 'max_acceleration': [0.0],
                  'max_jerk': [0.0]}


class HeldCompiles:
    """Wraps load_robot_model: counts compiles, and holds them while ``hold`` is set."""

    def __init__(self, real):
        self.real = real
        self.count = 0
        self.done = 0                   # compiles finished
        self.hold = threading.Event()
        self.release = threading.Event()
        self.held = threading.Event()   # a compile is waiting for release

    def __call__(self, *args, **kwargs):
        self.count += 1
        if self.hold.is_set():
            self.held.set()
            self.release.wait(10.0)
        robot = self.real(*args, **kwargs)
        self.done += 1
        return robot


def ur5_system(tmp_path):
    """Return both nodes on the UR5 (the parameters spelled out, valid before issue 22 too)."""
    limits = tmp_path / 'limits.yaml'
    limits.write_text(LIMITS_YAML)
    planner = {'kinematics': 'model', 'model_file': vr.ur5_urdf(),
               'joint_limits_file': str(limits), 'tool_frame': 'tool0', **ALL_FROM_MODEL}
    return InProcessSystem(planner, {'model_file': vr.ur5_urdf(), 'joint_names': ['']})


def test_parameters_are_answered_while_a_model_compiles(compiles, tmp_path):
    with ur5_system(tmp_path) as system:
        assert compiles.count == 1
        # Parameters the robot does not depend on: nothing is compiled or set up again.
        robot = system.planner._robot
        for values in ({'method': '555'}, {'timing': 'optimal'}, {'sample_period': 0.02}):
            result, = system.set_planner_parameters(values)
            assert result.successful, result.reason
        assert compiles.count == 1 and system.planner._robot is robot
        # A new tool frame is set up from the compiled model, without compiling it.
        result, = system.set_planner_parameters({'tool_frame': 'ee_link'})
        assert result.successful, result.reason
        assert compiles.count == 1 and system.planner._robot is not robot
        assert system.planner._robot.tool_frame == 'ee_link'
        # A new model file compiles on the worker: the executor answers meanwhile.
        compiles.hold.set()
        first = len(system.planner_status)
        result = system.planner.set_parameters_atomically(overrides(
            {'model_file': vr.panda_urdf(), 'tool_frame': 'panda_leftfinger',
             'joint_limits_file': os.path.join(CONFIG, 'panda_joint_limits.yaml')}))
        assert result.successful, result.reason
        assert system.spin_until(compiles.held.is_set, 10.0)
        result, = system.set_planner_parameters({'method': '434'})
        assert result.successful, result.reason
        assert compiles.done == 1  # both answered while the compile was held
        compiles.hold.clear()
        compiles.release.set()

        def loaded():
            return next((s for s in system.planner_status[first:]
                         if 'panda' in status_values(s).get('robot', '')), None)
        assert system.spin_until(lambda: loaded() is not None, 30.0)
        status = loaded()
        assert status.level == DiagnosticStatus.OK, status.message
        assert status_values(status)['tool_frame'] == 'panda_leftfinger'
        assert compiles.count == 2


def test_a_model_file_that_does_not_compile_keeps_the_last_good_robot(tmp_path):
    bad = tmp_path / 'bad.urdf'
    bad.write_text('<robot name="bad"><link name="a"/><joint name="j" type="revolute">'
                   '<parent link="a"/><child link="nowhere"/></joint></robot>')
    with ur5_system(tmp_path) as system:
        first = len(system.planner_status)
        for path, reason in ((str(tmp_path), 'is a directory'), ('/dev/zero', 'not a regular')):
            result, = system.set_planner_parameters({'model_file': path})
            assert not result.successful and reason in result.reason, result.reason
        result, = system.set_planner_parameters({'model_file': str(bad)})
        assert result.successful, result.reason  # checked cheaply; compiled on the worker

        def reported():
            return next((s for s in system.planner_status[first:]
                         if 'model_file' in status_values(s)), None)
        assert system.spin_until(lambda: reported() is not None, 30.0)
        assert reported().level == DiagnosticStatus.ERROR
        assert 'keeping the last good robot' in reported().message
        status, _ = system.request(waypoint_message(vr.UR5_JOINTS, [vr.UR5_READY,
                                                                    [0.1] * 6]))
        assert_planned(status)
