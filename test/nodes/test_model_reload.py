"""
planner_node plans on the robot its ``model_file`` names, and reads it again when asked.

A: switching ``model_file`` to another robot and straight back while the
worker compiled the other one left that model as the node's compiled model,
and a request whose overrides set up a robot of its own (here
``max_velocity``) was set up on it: a Panda for the UR5's request.
B: setting ``model_file`` again to the same path after the file changed on
disk kept the robot compiled from the old file.  The compiles are counted
(and held, for A) by wrapping ``load_robot_model``, as in
test_robot_loading_node.
"""

import os
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticStatus
import pytest
from rclpy.node import Node
from splines445_interfaces.srv import Plan
from splines445_ros.nodes import topics
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.service import model_planning
from splines445_ros.tools import vendor_robots as vr
from splines445_ros.tools.in_process import LocalRos, overrides, waypoint_message
from test_model_planner_node import LIMITS_YAML
from test_robot_loading_node import HeldCompiles

CONFIG = os.path.join(os.path.dirname(__file__), '..', '..', 'config')
NAMESPACE = 'model_reload'
# The UR5's shoulder pan joint turns 3 rad: fast enough to reach far beyond 1 rad/s.
FAR = [vr.UR5_READY, (3.0,) + vr.UR5_READY[1:]]


def ur5_parameters(limits_file, model_file):
    """Return planner parameters of the UR5 (``model_file``) with its acceleration limits."""
    return {'kinematics': 'model', 'model_file': model_file, 'tool_frame': 'tool0',
            'joint_limits_file': limits_file, 'joint_names': [''], 'max_velocity': [0.0],
            'max_acceleration': [0.0], 'max_jerk': [0.0]}


PANDA = {'model_file': vr.panda_urdf(), 'tool_frame': 'panda_leftfinger',
         'joint_limits_file': os.path.join(CONFIG, 'panda_joint_limits.yaml')}


class Reloading(LocalRos):
    """A planner node, and a client that calls ``~/plan`` and records ``~/status``."""

    def __init__(self, parameters):
        """Start the planner with ``parameters`` and wait for its plan service."""
        super().__init__()
        try:
            self.node = self.add(PlannerNode(context=self.context, namespace=NAMESPACE,
                                             parameter_overrides=overrides(parameters)))
            self.client = self.add(Node('reload_client', namespace=NAMESPACE,
                                        context=self.context))
            self.status = []
            self.client.create_subscription(DiagnosticStatus, 'planner_node/status',
                                            self.status.append, topics.STATUS_QOS)
            self.plan_client = self.client.create_client(Plan, 'planner_node/plan',
                                                         qos_profile=topics.PLAN_QOS)
            assert self.spin_until(self.plan_client.service_is_ready, 10.0)
            self.spin_for(0.2)
        except BaseException:
            self.close()
            raise

    def plan(self, waypoints=FAR, **request_overrides):
        """Call ``~/plan`` with UR5 joint waypoints (and overrides); return the response."""
        request = Plan.Request()
        request.waypoints = waypoint_message(vr.UR5_JOINTS, waypoints)
        for name, value in request_overrides.items():
            setattr(request.overrides, name, value)
        future = self.plan_client.call_async(request)
        assert self.spin_until(future.done, 60.0), 'no answer from ~/plan'
        return future.result()

    def set_parameters(self, values):
        """Set planner parameters at once; assert they were accepted."""
        result = self.node.set_parameters_atomically(overrides(values))
        assert result.successful, result.reason

    def reports(self, first, key):
        """Return the ``~/status`` reports since number ``first`` that carry value ``key``."""
        return [s for s in self.status[first:] if key in status_values(s)]


def ur5_copy(tmp_path):
    """Return (the path of a copy of the UR5's URDF in ``tmp_path``, its text)."""
    model = tmp_path / 'ur5.urdf'
    text = Path(vr.ur5_urdf()).read_text()
    model.write_text(text)
    return model, text


@pytest.fixture
def limits_file(tmp_path):
    path = tmp_path / 'limits.yaml'
    path.write_text(LIMITS_YAML)
    return str(path)


def test_a_request_after_switching_to_a_robot_and_back_plans_on_the_first(compiles,
                                                                          limits_file):
    ur5 = ur5_parameters(limits_file, vr.ur5_urdf())
    with Reloading(ur5) as ros:
        assert compiles.count == 1
        # To the Panda: compiled on the worker, held there; straight back to the UR5.
        compiles.hold.set()
        ros.set_parameters(PANDA)
        assert ros.spin_until(compiles.held.is_set, 10.0)
        ros.set_parameters({name: ur5[name] for name in PANDA})
        compiles.hold.clear()
        compiles.release.set()
        # Queued behind the Panda's compile: served once it is done.
        response = ros.plan(max_velocity=[1.0] * 6)
        assert response.success, response.message
        assert tuple(response.joint_names) == vr.UR5_JOINTS
        assert tuple(response.trajectory.joint_names) == vr.UR5_JOINTS
        assert max(response.peak_velocity) <= 1.0 + 1e-6
        assert compiles.count == 2  # the UR5 was not compiled again
        # Without overrides too, and a robot field of the UR5 set up again.
        response = ros.plan()
        assert response.success, response.message
        assert tuple(response.joint_names) == vr.UR5_JOINTS
        ros.set_parameters({'tool_frame': 'ee_link'})
        response = ros.plan(max_velocity=[1.0] * 6)
        assert response.success, response.message
        assert tuple(response.joint_names) == vr.UR5_JOINTS
        # And the Panda is the Panda when it is asked for.
        first = len(ros.status)
        ros.set_parameters(PANDA)

        def panda():
            return [s for s in ros.reports(first, 'robot')
                    if 'panda_joint1' in status_values(s)['joint_names']]
        assert ros.spin_until(panda, 60.0), ros.reports(first, 'robot')


def test_setting_model_file_again_reloads_the_file_when_it_changed(
        compiles, limits_file, tmp_path):
    model, text = ur5_copy(tmp_path)
    with Reloading(ur5_parameters(limits_file, str(model))) as ros:
        assert compiles.count == 1
        response = ros.plan()
        assert response.success, response.message
        assert response.peak_velocity[0] > 1.5  # the URDF's 3.15 rad/s
        # The same path again, the file unchanged: nothing is compiled.
        ros.set_parameters({'model_file': str(model)})
        assert ros.plan().success
        assert compiles.count == 1
        # The file changes: the shoulder pan joint's velocity limit is now 1 rad/s.
        model.write_text(text.replace('velocity="3.15"', 'velocity="1.0"', 1))
        # A parameter the robot does not depend on never reads it again ...
        ros.set_parameters({'sample_period': 0.02})
        response = ros.plan()
        assert response.success, response.message
        assert response.peak_velocity[0] > 1.5 and compiles.count == 1
        # ... setting model_file again does, in order with the requests.
        first = len(ros.status)
        ros.set_parameters({'model_file': str(model)})
        response = ros.plan()
        assert response.success, response.message
        assert response.peak_velocity[0] <= 1.0 + 1e-6
        assert compiles.count == 2
        loaded = ros.reports(first, 'robot')
        assert loaded and loaded[0].level == DiagnosticStatus.OK, loaded
        # A limit set up again comes from the file as it is now, too.
        ros.set_parameters({'tool_frame': 'ee_link'})
        response = ros.plan(max_acceleration=[4.0] * 6)
        assert response.success, response.message
        assert response.peak_velocity[0] <= 1.0 + 1e-6
        assert compiles.count == 2


def test_setting_model_file_again_after_it_was_removed_keeps_the_robot(
        compiles, limits_file, tmp_path):
    model, _ = ur5_copy(tmp_path)
    with Reloading(ur5_parameters(limits_file, str(model))) as ros:
        model.unlink()
        first = len(ros.status)
        # Accepted, as it names the robot in use; reading it again fails on the worker.
        ros.set_parameters({'model_file': str(model)})
        response = ros.plan()
        assert response.success, response.message  # the last good robot plans
        assert tuple(response.joint_names) == vr.UR5_JOINTS
        refused = ros.reports(first, 'model_file')
        assert refused and refused[0].level == DiagnosticStatus.ERROR, refused
        assert 'keeping the last good robot' in refused[0].message
        assert 'ur5.urdf' in refused[0].message
        # Back on disk, changed or not: setting it again reads it.
        model.write_text(Path(vr.ur5_urdf()).read_text())
        first = len(ros.status)
        ros.set_parameters({'model_file': str(model)})
        assert ros.plan().success
        loaded = ros.reports(first, 'robot')
        assert loaded and loaded[0].level == DiagnosticStatus.OK, loaded


def test_a_tool_frame_the_changed_file_adds_is_set_up_from_it(compiles, limits_file, tmp_path):
    model, text = ur5_copy(tmp_path)
    with Reloading(ur5_parameters(limits_file, str(model))) as ros:
        # Not a link of the file: refused at once, from the compiled model.
        result = ros.node.set_parameters_atomically(overrides({'tool_frame': 'tcp'}))
        assert not result.successful and 'tcp' in result.reason, result.reason
        # The file gains a "tcp" link, 10 cm beyond tool0.
        model.write_text(text.replace('<link name="world"/>', (
            '<link name="tcp"/><joint name="tool0-tcp" type="fixed"><parent link="tool0"/>'
            '<child link="tcp"/><origin xyz="0 0 0.1" rpy="0 0 0"/></joint>'
            '<link name="world"/>'), 1))
        first = len(ros.status)
        ros.set_parameters({'model_file': str(model), 'tool_frame': 'tcp'})
        assert ros.plan().success

        def loaded():
            return [s for s in ros.reports(first, 'robot')
                    if status_values(s).get('tool_frame') == 'tcp']
        assert ros.spin_until(loaded, 60.0), ros.reports(first, 'robot')
        assert loaded()[0].level == DiagnosticStatus.OK
        assert compiles.count == 2


def test_values_are_checked_against_the_compiled_file_while_its_bytes_are_the_same(
        compiles, limits_file, tmp_path):
    # A touch (or a copy of the same bytes) is no change: a bad value is still
    # refused at once, and nothing is compiled again.
    model, _ = ur5_copy(tmp_path)
    with Reloading(ur5_parameters(limits_file, str(model))) as ros:
        for touch in (False, True):
            if touch:
                os.utime(model, ns=(1, 1))
            result = ros.node.set_parameters_atomically(overrides({'tool_frame': 'no_link'}))
            assert not result.successful and 'no_link' in result.reason, result.reason
            assert ros.node.get_parameter('tool_frame').value == 'tool0'
        ros.set_parameters({'model_file': str(model)})
        assert ros.plan().success and compiles.count == 1


def test_a_removed_file_leaves_the_robot_it_was_compiled_into_usable(
        compiles, limits_file, tmp_path):
    model, _ = ur5_copy(tmp_path)
    with Reloading(ur5_parameters(limits_file, str(model))) as ros:
        model.unlink()
        ros.set_parameters({'max_velocity': [1.0] * 6})  # set up on the compiled robot
        response = ros.plan()
        assert response.success, response.message
        assert max(response.peak_velocity) <= 1.0 + 1e-6 and compiles.count == 1


class HeldAfterRead(HeldCompiles):
    """Like HeldCompiles, but holds a compile once it has read the file."""

    def __call__(self, *args, **kwargs):
        self.count += 1
        robot = self.real(*args, **kwargs)
        if self.hold.is_set():
            self.held.set()
            self.release.wait(10.0)
        self.done += 1
        return robot


def test_a_file_edited_while_it_compiles_is_read_again(monkeypatch, limits_file, tmp_path):
    compiles = HeldAfterRead(model_planning.load_robot_model)
    monkeypatch.setattr(model_planning, 'load_robot_model', compiles)
    model, text = ur5_copy(tmp_path)
    with Reloading(ur5_parameters(limits_file, str(model))) as ros:
        model.write_text(text.replace('velocity="3.15"', 'velocity="2.0"', 1))
        compiles.hold.set()
        ros.set_parameters({'model_file': str(model)})
        assert ros.spin_until(compiles.held.is_set, 20.0)     # the 2 rad/s file read
        # Edited again and set again while the worker holds the first edit's compile.
        model.write_text(text.replace('velocity="3.15"', 'velocity="1.0"', 1))
        ros.set_parameters({'model_file': str(model)})
        compiles.hold.clear()
        compiles.release.set()
        ros.plan()                      # queued behind the compiles
        response = ros.plan()
        assert response.success, response.message
        assert response.peak_velocity[0] <= 1.0 + 1e-6, response.peak_velocity
        assert compiles.count == 3


def test_setting_joint_limits_file_again_reads_the_edited_file(compiles, limits_file):
    """
    The same path set again reads the file again (helper-92: its old limits stayed).

    Nothing is compiled for it; a file edited into one that does not parse is
    reported on ``~/status`` with the reason, and the robot keeps the limits
    it had.
    """
    with Reloading(ur5_parameters(limits_file, vr.ur5_urdf())) as ros:
        response = ros.plan()
        assert response.success, response.message
        assert max(response.peak_acceleration) > 2.0      # the file's 6-9 rad/s^2
        with open(limits_file, 'w', encoding='utf-8') as stream:
            stream.write(LIMITS_YAML.replace('max_acceleration: 6.0', 'max_acceleration: 1.0')
                         .replace('max_acceleration: 7.0', 'max_acceleration: 1.0')
                         .replace('max_acceleration: 9.0', 'max_acceleration: 1.0'))
        # A parameter the robot does not depend on does not read it ...
        ros.set_parameters({'sample_period': 0.02})
        assert max(ros.plan().peak_acceleration) > 2.0
        # ... setting the same path again does.
        ros.set_parameters({'joint_limits_file': limits_file})
        response = ros.plan()
        assert response.success, response.message
        assert max(response.peak_acceleration) <= 1.0 + 1e-6
        assert compiles.count == 1
        first = len(ros.status)
        with open(limits_file, 'w', encoding='utf-8') as stream:
            stream.write('joint_limits: [')
        ros.set_parameters({'joint_limits_file': limits_file})
        assert ros.spin_until(lambda: any('joint_limits_file rejected' in s.message
                                          for s in ros.status[first:]), 5.0)
        assert max(ros.plan().peak_acceleration) <= 1.0 + 1e-6
