"""
arm_sim_node with a user's model file alone: torque limits and gains from the model.

A vendor URDF (UR5) and a 2-joint MJCF with motors whose ``ctrlrange`` says
what the drives can do (the issue's example).  Expected torque limits are
the values written in the models; expected gains come from the test's own
inertia of the MJCF's point masses; the tool pose from the test's own FK of
the URDF.
"""

import math

from arm_client import ArmClient
from diagnostic_msgs.msg import DiagnosticStatus
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.nodes.ros_conversions import trajectory_to_msg
from splines445_ros.planning import plan
from splines445_ros.sim.model_drives import DEFAULT_BANDWIDTH
from splines445_ros.tools import vendor_robots as vr
from splines445_ros.tools.in_process import LocalRos, overrides
from urdf_reference import BatchedUrdfChain

# Point masses (tiny own inertia) so that the test can compute the inertia itself.
M1, M2, L1, C1, C2, ARM1, ARM2 = 3.0, 1.5, 0.5, 0.25, 0.2, 0.05, 0.02
TWO_MOTORS = f"""<mujoco model="two_motors">
  <option gravity="0 0 -9.81"/>
  <worldbody>
    <body name="upper">
      <joint name="shoulder" type="hinge" axis="0 0 1" armature="{ARM1}" damping="0.5"/>
      <inertial pos="{C1} 0 0" mass="{M1}" diaginertia="1e-6 1e-6 1e-6"/>
      <body name="lower" pos="{L1} 0 0">
        <joint name="elbow" type="hinge" axis="0 0 1" armature="{ARM2}" damping="0.2"/>
        <inertial pos="{C2} 0 0" mass="{M2}" diaginertia="1e-6 1e-6 1e-6"/>
        <site name="tip" pos="0.4 0 0"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor joint="shoulder" ctrlrange="-80 80"/>
    <motor joint="elbow" ctrlrange="-20 20" gear="2"/>
  </actuator>
</mujoco>
"""


class Arm(ArmClient):
    """One arm node with a user's model and a client recording its outputs."""

    def __init__(self, ros, parameters):
        super().__init__(ros, parameters, 'model_arm_client', discovery_timeout=10.0)

    def play(self, trajectory, names):
        first = len(self.status)
        self.publisher.publish(trajectory_to_msg(trajectory.sample(0.01), names))
        accepted, = self.trajectory_status(first, 1, 10.0)
        assert accepted.level == DiagnosticStatus.OK, accepted.message
        return self.trajectory_status(first, 2, trajectory.duration + 10.0)[1]


def test_the_issue_example_a_2_joint_mjcf_alone(tmp_path):
    path = tmp_path / 'two_motors.xml'
    path.write_text(TWO_MOTORS)
    with LocalRos() as ros:
        arm = Arm(ros, {'simulation': 'dynamic', 'model_file': str(path),
                        'joint_names': ['']})
        effective = arm.node.effective
        assert effective.joint_names == ('shoulder', 'elbow')
        # ctrlrange x gear: 80 and 20 * 2.
        assert effective.torque_limits == pytest.approx((80.0, 40.0))
        # Inertia at the initial pose (0, 0), armature included, written here.
        i1 = M1 * C1 ** 2 + M2 * (L1 + C2) ** 2 + ARM1
        i2 = M2 * C2 ** 2 + ARM2
        omega = 2 * math.pi * DEFAULT_BANDWIDTH
        assert effective.kp == pytest.approx((i1 * omega ** 2, i2 * omega ** 2), rel=1e-4)
        assert effective.kd == pytest.approx((2 * i1 * omega, 2 * i2 * omega), rel=1e-4)
        goal = np.array([0.8, -0.6])
        traj = plan(np.array([[0.0, 0.0], [0.4, -0.2], goal]), '445', 'uniform',
                    max_velocity=[1.0, 1.0], max_acceleration=[4.0, 4.0])
        done = arm.play(traj, ['shoulder', 'elbow'])
        assert done.level == DiagnosticStatus.OK, done.message
        arm.ros.spin_for(0.6)
        np.testing.assert_allclose(arm.states[-1].position, goal, atol=2e-3)
        effort = np.abs(np.array([s.effort for s in arm.states]))
        assert np.all(effort <= np.array([80.0, 40.0]) * (1 + 1e-9))


def test_a_joint_without_any_torque_limit_is_named(tmp_path):
    path = tmp_path / 'bare.xml'
    path.write_text(TWO_MOTORS.replace('<motor joint="elbow" ctrlrange="-20 20" gear="2"/>',
                                       ''))
    with LocalRos() as ros:
        with pytest.raises(ValueError, match="joint 'elbow' has no torque limit in the model"):
            ArmSimNode(context=ros.context, parameter_overrides=overrides(
                {'simulation': 'dynamic', 'model_file': str(path), 'joint_names': ['']}))
        # An explicit value for that joint is enough.
        node = ros.add(ArmSimNode(context=ros.context, parameter_overrides=overrides(
            {'simulation': 'dynamic', 'model_file': str(path), 'joint_names': [''],
             'torque_limits': [0.0, 15.0]})))
        assert node.effective.torque_limits == pytest.approx((80.0, 15.0))


def test_a_vendor_urdf_alone_settles_at_the_goal_with_its_tool_frame():
    with LocalRos() as ros:
        arm = Arm(ros, {'simulation': 'dynamic', 'model_file': vr.ur5_urdf(),
                        'joint_names': [''], 'tool_frame': 'tool0',
                        'initial_positions': list(vr.UR5_READY)})
        effective = arm.node.effective
        assert effective.joint_names == vr.UR5_JOINTS
        # The URDF's <limit effort>.
        assert effective.torque_limits == pytest.approx((150.0,) * 3 + (28.0,) * 3)
        goal = np.array(vr.UR5_READY) + [0.4, -0.3, 0.3, 0.2, 0.3, -0.5]
        traj = plan(np.array([vr.UR5_READY, goal]), '445', 'uniform',
                    max_velocity=[1.0] * 6, max_acceleration=[3.0] * 6)
        done = arm.play(traj, list(vr.UR5_JOINTS))
        assert done.level == DiagnosticStatus.OK, done.message
        arm.ros.spin_for(0.6)
        state = arm.states[-1]
        np.testing.assert_allclose(state.position, goal, atol=5e-3)
        effort = np.abs(np.array([s.effort for s in arm.states]))
        assert np.all(effort <= np.array(effective.torque_limits) * (1 + 1e-9))
        # tool_pose is tool0 of the URDF at the published joints.
        n = len(arm.poses)
        assert ros.spin_until(lambda: len(arm.poses) > n + 2, 5.0)
        pose = arm.poses[-2]
        state = next(s for s in reversed(arm.states) if s.header.stamp == pose.header.stamp)
        q = np.array(state.position)
        fk = BatchedUrdfChain(vr.ur5_urdf(), 'base_link', 'tool0', list(vr.UR5_JOINTS))
        pos, mat = fk(q)
        p, o = pose.pose.position, pose.pose.orientation
        np.testing.assert_allclose([p.x, p.y, p.z], pos[0], atol=1e-6)
        angle = (Rotation.from_quat([o.x, o.y, o.z, o.w]).inv()
                 * Rotation.from_matrix(mat[0])).magnitude()
        assert angle < 1e-6


def test_the_shipped_ur5_config_is_valid():
    """config/ur5.yaml builds both nodes' configs (model_file given as on the command line)."""
    import os
    import yaml
    from splines445_ros.service.arm_sim_config import ArmSimConfig
    from splines445_ros.service.model_planning import build_robot_setup
    from splines445_ros.service.planner_config import PlannerConfig
    path = os.path.join(os.path.dirname(__file__), '..', '..', 'config', 'ur5.yaml')
    with open(path, encoding='utf-8') as stream:
        data = yaml.safe_load(stream)
    planner = {**data['planner_node']['ros__parameters'], 'model_file': vr.ur5_urdf()}
    planner['joint_limits_file'] = os.path.join(os.path.dirname(path), 'ur5_joint_limits.yaml')
    config = PlannerConfig.from_values(planner)
    setup = build_robot_setup(config)
    assert setup.config.joint_names == vr.UR5_JOINTS
    assert setup.limits.sources['acceleration'] == ('joint_limits_file',) * 6
    arm = {**data['arm_sim_node']['ros__parameters'], 'model_file': vr.ur5_urdf()}
    with LocalRos() as ros:
        node = ros.add(ArmSimNode(context=ros.context,
                                  parameter_overrides=overrides(arm)))
        assert node.effective.joint_names == vr.UR5_JOINTS
        assert ArmSimConfig.from_values(arm).all_model_joints
    # Without the model_file it asks for, it is refused, not played on the planar arm.
    with pytest.raises(ValueError, match='tool_frame .tool0. needs model_file'):
        ArmSimConfig.from_values(data['arm_sim_node']['ros__parameters'])
    built_in = {'control_bandwidth': 5.0}
    with pytest.raises(ValueError, match='control_bandwidth = 5.0 needs model_file'):
        ArmSimConfig.from_values(built_in)
