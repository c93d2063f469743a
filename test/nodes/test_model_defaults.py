"""
Any arm from its description alone: the defaults follow the model (issue 22, part 1).

* The tip of the chain (the default tool frame) against the test's own walk of
  the URDF's link tree (``xml.etree``, not MuJoCo), on three vendor arms.
* ``PlannerConfig`` resolves "not set" joint names and limits: the planar arm's
  defaults without a model, the description's with one, and errors that name
  the fix.
* The README's short form, with exactly those parameters, on the UR5 and the
  Panda: both nodes in one process, every actuated joint planned and driven,
  tool requests needing ``tool_frame`` only where the tip is ambiguous.
"""

import os
import re
import xml.etree.ElementTree as ET

from diagnostic_msgs.msg import DiagnosticStatus
from node_status import assert_planned
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.robot.chain_tip import chain_tips
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.service.parameter_table import declared_values
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.tools import vendor_robots as vr
from splines445_ros.tools.in_process import InProcessSystem, LocalRos, overrides, \
    waypoint_message
from test_model_planner_node import CORNERS, pose_array
from urdf_reference import BatchedUrdfChain

CONFIG = os.path.join(os.path.dirname(__file__), '..', '..', 'config')
XARM7 = 'xarm_description/urdf/xarm7.urdf'


def urdf_tips(path, planned):
    """
    Return the test's own tip: links rigid with the child link of the last planned joint.

    Walks the URDF's ``<joint>`` elements: parent and child links, joint types.
    """
    root = ET.parse(path).getroot()
    joints = {j.get('name'): (j.find('parent').get('link'), j.find('child').get('link'),
                              j.get('type')) for j in root.findall('joint')}
    parent_of = {child: (parent, name) for name, (parent, child, _) in joints.items()}

    def path_joints(link):
        names = []
        while link in parent_of:
            link, joint = parent_of[link]
            names.append(joint)
        return set(names)

    ends = [joints[j][1] for j in planned]
    last = [link for link in ends if set(planned) <= path_joints(link)]
    assert len(last) == 1
    tips, stack = [], [last[0]]
    while stack:
        link = stack.pop()
        fixed = [c for (p, c, kind) in joints.values() if p == link and kind == 'fixed']
        stack.extend(fixed)
        if not fixed:
            tips.append(link)
    return sorted(tips)


@pytest.mark.parametrize('relative, planned, expected', [
    (vr.UR5_URDF, vr.UR5_JOINTS, ['ee_link', 'tool0']),
    (vr.PANDA_URDF, vr.PANDA_ARM_JOINTS, ['panda_hand_tcp']),
    (vr.PANDA_URDF, vr.PANDA_ARM_JOINTS + ('panda_finger_joint1',), ['panda_leftfinger']),
    (XARM7, tuple(f'joint{i}' for i in range(1, 8)), ['link_eef']),
    (XARM7, ('joint1', 'joint2', 'joint3'), ['link3']),
])
def test_the_tip_of_the_chain_is_the_urdfs(relative, planned, expected):
    path = vr.robot_file(relative)
    robot = load_robot_model(path)
    tips, reason = chain_tips(robot, robot.select(planned))
    assert sorted(tips) == urdf_tips(path, planned) == expected, reason


def test_joints_on_two_branches_have_no_tip():
    robot = load_robot_model(vr.panda_urdf())
    # Both fingers hang on panda_hand: neither lies on the way to the other.
    tips, reason = chain_tips(robot, robot.select(('panda_joint7', 'panda_finger_joint1')))
    assert tips == ('panda_leftfinger',)  # joint7 is on the way to the left finger
    two = load_robot_model(urdf_string=TWO_BRANCHES)
    tips, reason = chain_tips(two, two.joints)
    assert tips == () and 'not on one chain' in reason


TWO_BRANCHES = """<robot name="two">
  <link name="base"/><link name="a"/><link name="b"/>
  <joint name="ja" type="revolute"><parent link="base"/><child link="a"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="jb" type="revolute"><parent link="base"/><child link="b"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>"""


def parameters_as_declared(**values):
    """Return the planner's parameters as declared, overlaid with ``values``."""
    declared = declared_values(PlannerConfig)
    declared.update(values)
    return declared


def test_not_set_means_the_planar_arm_without_a_model():
    config = PlannerConfig.from_values(parameters_as_declared())
    assert config.joint_names == ('joint1', 'joint2', 'joint3')
    assert config.max_velocity == (2.0,) * 3 and config.max_acceleration == (10.0,) * 3
    assert config.jerk_limits() is None


def test_other_joints_without_a_model_need_their_limits_named():
    with pytest.raises(ValueError, match=r"max_velocity is not set for joint_names \['a', 'b'\]: "
                                         r'give one value per joint, e\.g\. -p max_velocity'):
        PlannerConfig.from_values(parameters_as_declared(joint_names=('a', 'b')))
    config = PlannerConfig.from_values(parameters_as_declared(
        joint_names=('a', 'b'), max_velocity=(1.0, 2.0), max_acceleration=(3.0, 4.0)))
    assert config.max_velocity == (1.0, 2.0) and config.max_jerk == ()


def test_not_set_with_a_model_is_left_to_the_description():
    config = PlannerConfig.from_values(parameters_as_declared(kinematics='model'))
    assert config.joint_names == () and not any(config.max_velocity)
    assert config.tool_frame == ''
    with pytest.raises(ValueError, match=r'max_acceleration needs one value per joint \(6\) '
                                         r'of joint_names .*-p max_acceleration:=\[0\.0\]'):
        PlannerConfig.from_values(parameters_as_declared(
            kinematics='model', joint_names=vr.UR5_JOINTS, max_acceleration=(1.0, 2.0, 3.0)))


def test_a_model_without_acceleration_limits_says_where_to_put_them():
    with LocalRos() as ros:
        with pytest.raises(ValueError, match=r"joint 'joint1' has no acceleration limit: give "
                                             r'it in the joint_limits_file or max_acceleration'):
            ros.add(PlannerNode(context=ros.context, parameter_overrides=overrides(
                {'kinematics': 'model', 'model_file': vr.robot_file(XARM7)})))


def short_form(urdf, limits_file):
    """Return the parameters of the README's two commands, exactly."""
    planner = {'kinematics': 'model', 'model_file': urdf,
               'joint_limits_file': os.path.join(CONFIG, limits_file)}
    arm = {'simulation': 'dynamic', 'model_file': urdf}
    return planner, arm


@pytest.mark.parametrize('urdf, limits_file, joints', [
    (vr.ur5_urdf, 'ur5_joint_limits.yaml', vr.UR5_JOINTS),
    (vr.panda_urdf, 'panda_joint_limits.yaml', vr.PANDA_ARM_JOINTS + ('panda_finger_joint1',)),
])
def test_the_short_form_plans_and_drives_every_actuated_joint(urdf, limits_file, joints):
    planner, arm = short_form(urdf(), limits_file)
    with InProcessSystem(planner, arm) as system:
        assert system.spin_until(lambda: system.joint_states, 10.0)
        assert tuple(system.joint_states[-1].name) == joints
        start = np.array(system.joint_states[-1].position)
        rng = np.random.default_rng(len(joints))
        lower, upper = (np.array(v) for v in zip(
            *[(j.lower, j.upper) for j in load_robot_model(urdf()).select(joints)]))
        span = np.minimum(upper - lower, 2.0)
        # The simulated finger may rest a few micrometres outside its range: start inside.
        start = np.clip(start, lower, upper)
        goal = np.clip(start + rng.uniform(-0.15, 0.15, len(joints)) * span,
                       lower + 0.2 * span, upper - 0.2 * span)
        n_arm = len(system.arm_status)
        status, msg = system.request(waypoint_message(joints, [start, goal]))
        assert_planned(status)
        assert tuple(msg.joint_names) == joints
        values = status_values(status)
        # Limits from the URDF (velocity) and the limits file (acceleration).
        assert 'urdf' in values['limit_velocity_sources']
        assert 'joint_limits_file' in values['limit_acceleration_sources']
        played, after = system.wait_until_played(n_arm, float(msg.points[-1].time_from_start.sec
                                                 + 1e-9 * msg.points[-1].time_from_start.nanosec))
        assert tuple(after.name) == joints
        # Every joint moved: none is left undriven at its reference pose.
        moved = np.abs(np.array(after.position) - start)
        assert np.all(moved > 0.5 * np.abs(goal - start)), moved


def test_tool_requests_need_tool_frame_only_where_the_tip_is_ambiguous():
    planner, _ = short_form(vr.ur5_urdf(), 'ur5_joint_limits.yaml')
    with InProcessSystem(planner, {'simulation': 'kinematic', 'model_file': vr.ur5_urdf(),
                                   'initial_positions': list(vr.UR5_READY)}) as system:
        status, _ = system.request(pose_array(CORNERS[:2], frame_id=''))
        assert status.level == DiagnosticStatus.ERROR
        assert "the chain ends in 2 links: ['ee_link', 'tool0']" in status.message
        assert '-p tool_frame:=' in status.message
        result, = system.set_planner_parameters({'tool_frame': 'tool0'})
        assert result.successful, result.reason
        status, _ = system.request(pose_array(CORNERS[:2], frame_id=''))
        assert_planned(status)
    # The Panda's arm joints end in one link: no tool_frame needed.
    planner, _ = short_form(vr.panda_urdf(), 'panda_joint_limits.yaml')
    planner['joint_names'] = list(vr.PANDA_ARM_JOINTS)
    with InProcessSystem(planner, {'simulation': 'kinematic', 'model_file': vr.panda_urdf(),
                                   'joint_names': list(vr.PANDA_ARM_JOINTS),
                                   'initial_positions': list(vr.PANDA_READY)}) as system:
        assert system.spin_until(lambda: system.joint_states, 10.0)
        fk = BatchedUrdfChain(vr.panda_urdf(), 'panda_link0', 'panda_hand_tcp',
                              list(vr.PANDA_ARM_JOINTS))
        position, matrix = fk(np.array([vr.PANDA_READY]))
        quaternion = Rotation.from_matrix(matrix[0]).as_quat(scalar_first=True)
        goal = position[0] + [0.05, 0.0, -0.05]
        msg = pose_array([position[0], goal], tuple(quaternion), frame_id='')
        status, trajectory = system.request(msg)
        assert_planned(status)
        assert tuple(trajectory.joint_names) == vr.PANDA_ARM_JOINTS
        reached, _ = fk(np.array([trajectory.points[-1].positions]))
        np.testing.assert_allclose(reached[0], goal, atol=1e-6)


def test_a_typo_in_the_limits_file_and_absurd_limits_are_refused_when_set(tmp_path):
    # Issue 22, findings 3 and 6: a limit for an unknown joint was ignored (the URDF's
    # 3.15 rad/s applied), and 1e-300 was accepted, then every request failed.
    typo = tmp_path / 'typo.yaml'
    typo.write_text('joint_limits:\n  shoulder_pan:\n    has_velocity_limits: true\n'
                    '    max_velocity: 0.1\n')
    planner, _ = short_form(vr.ur5_urdf(), 'ur5_joint_limits.yaml')
    with LocalRos() as ros:
        node = ros.add(PlannerNode(context=ros.context,
                                   parameter_overrides=overrides(planner)))
        for values, reason in (
                ({'joint_limits_file': str(typo)},
                 r"no joint of that name \(did you mean 'shoulder_pan_joint'\?\)"),
                ({'max_velocity': [1e-300] + [0.0] * 5},
                 r'max_velocity\[0\] = 1e-300 is outside the usable range \[1e-06, 10000\]'),
                ({'max_jerk': [1e300]},
                 r'max_jerk\[0\] = 1e\+300 is outside the usable range')):
            result, = node.set_parameters(overrides(values))
            assert not result.successful
            assert re.search(reason, result.reason), result.reason
        assert node.parameters.config.joint_limits_file.endswith('ur5_joint_limits.yaml')


def test_the_start_up_log_names_the_models_joints(capfd):
    """joint_names not set: the log showed [] after the model's joints were loaded (helper-78)."""
    with LocalRos() as ros:
        planner, _ = short_form(vr.ur5_urdf(), 'ur5_joint_limits.yaml')
        ros.add(PlannerNode(context=ros.context, parameter_overrides=overrides(planner)))
    err = capfd.readouterr().err
    assert f'planning 445/uniform for {list(vr.UR5_JOINTS)}' in err, err
