"""
Tool kinematics of a robot model on inputs that went wrong (issue 22).

* a ``<mimic>`` joint inside the tool chain follows its parent (it was held
  at 0, the tool off by centimetres without an error);
* a reachable Panda pose, the tool turned 180 degrees, is solved (it was
  refused 1e-10 m and rad short of it);
* a Panda pose metres away is "out of reach" (it was called a branch flip).

Expected poses come from forward kinematics written for the tests
(:mod:`urdf_reference`, scipy's Rotation), not from the package.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from splines445_ros.robot.inverse_kinematics import KinematicsError, ModelKinematics
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.tools import vendor_robots as vr
from urdf_reference import BatchedUrdfChain

# A solved pose is accepted within this [m and rad]: far below the planner's
# 1 mm / 1 degree deviation tolerances, far above the solver's rounding.
ACCEPTED = 1e-9

# Three revolute joints; j3 mimics j1 (j3 = 0.5 * j1 + 0.2).
MIMIC_ARM = """<robot name="mimic_arm">
  <link name="base"/>
  <link name="l1"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l3"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01"
    ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-2" upper="2" velocity="1" effort="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0" rpy="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" velocity="1" effort="1"/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.25 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" velocity="1" effort="1"/>
    <mimic joint="j1" multiplier="0.5" offset="0.2"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="l3"/><child link="tip"/>
    <origin xyz="0.15 0 0"/></joint>
</robot>"""


def mimic_reference(path, q):
    """Tip pose (K, 7) of MIMIC_ARM at planned joints q (K, 2), by the test's own FK."""
    q = np.atleast_2d(q)
    full = np.column_stack([q[:, 0], q[:, 1], 0.5 * q[:, 0] + 0.2])
    pos, mat = BatchedUrdfChain(path, 'base', 'tip', ['j1', 'j2', 'j3'])(full)
    return np.column_stack([pos, Rotation.from_matrix(mat).as_quat(scalar_first=True)])


def orientation_error(a, b):
    """Angles [rad] between quaternion rows (scalar first)."""
    ra = Rotation.from_quat(np.atleast_2d(a), scalar_first=True)
    rb = Rotation.from_quat(np.atleast_2d(b), scalar_first=True)
    return (ra.inv() * rb).magnitude()


@pytest.fixture(scope='module')
def mimic_arm(tmp_path_factory):
    path = tmp_path_factory.mktemp('mimic') / 'mimic_arm.urdf'
    path.write_text(MIMIC_ARM)
    return str(path), load_robot_model(str(path))


@pytest.fixture(scope='module')
def panda():
    return load_robot_model(vr.panda_urdf())


# --------------------------------------------------------------- 5: mimic joints

def test_a_mimic_joint_in_the_tool_chain_follows_its_parent(mimic_arm):
    path, robot = mimic_arm
    assert robot.joint_names == ('j1', 'j2')
    kin = ModelKinematics(robot, 'tip', 'base')
    q = np.array([[0.0, 0.0], [0.7, -0.4], [-1.3, 0.9], [1.9, 1.5]])
    got = kin.forward(q)
    expected = mimic_reference(path, q)
    np.testing.assert_allclose(got[:, :3], expected[:, :3], atol=1e-12)
    np.testing.assert_allclose(orientation_error(got[:, 3:], expected[:, 3:]), 0.0, atol=1e-12)


def test_the_inverse_drives_a_mimic_joint_from_its_parent(mimic_arm):
    path, robot = mimic_arm
    kin = ModelKinematics(robot, 'tip', 'base', seed=[0.3, -0.2])
    q = np.array([[0.35, -0.25], [0.5, -0.1], [0.8, 0.2]])
    poses = mimic_reference(path, q)
    # One pose at a time: two joints cannot follow the straight line between
    # two poses.  Only two joints for six pose coordinates: exact poses are met
    # only if the Jacobian folds the mimic joint's column into its parent's.
    solution = np.array([kin.inverse(pose[None, :])[0] for pose in poses])
    np.testing.assert_allclose(solution, q, atol=1e-7)
    got = mimic_reference(path, solution)
    np.testing.assert_allclose(got[:, :3], poses[:, :3], atol=ACCEPTED)
    assert np.all(orientation_error(got[:, 3:], poses[:, 3:]) <= ACCEPTED)


def test_a_mimic_joint_of_an_unplanned_parent_stays_at_its_offset(mimic_arm):
    path, robot = mimic_arm
    # j1 is not planned: held at 0, so j3 stays at 0.5 * 0 + 0.2.
    kin = ModelKinematics(robot, 'tip', 'base', joint_names=['j2'])
    q2 = np.array([[-0.6], [0.0], [1.1]])
    got = kin.forward(q2)
    expected = mimic_reference(path, np.column_stack([np.zeros(3), q2[:, 0]]))
    np.testing.assert_allclose(got[:, :3], expected[:, :3], atol=1e-12)
    np.testing.assert_allclose(orientation_error(got[:, 3:], expected[:, 3:]), 0.0, atol=1e-12)
    solution = kin.inverse(expected[2:])
    np.testing.assert_allclose(solution, q2[2:], atol=1e-7)


# --------------------------------------------------------------- 7: solver precision

def test_a_reachable_panda_pose_turned_half_a_turn_is_solved(panda):
    # Default seed (the URDF has no 'home' keyframe: qpos0 moved into the ranges);
    # the tool 2 cm along x and turned 180 degrees about the base's x axis.  Was
    # refused: "out of reach ... 2.8e-16 m and 6.8e-10 rad short", joint 7 on its
    # lower limit stalling the damped steps.
    kin = ModelKinematics(panda, 'panda_hand_tcp', 'panda_link0', vr.PANDA_ARM_JOINTS)
    fk = BatchedUrdfChain(vr.panda_urdf(), 'panda_link0', 'panda_hand_tcp',
                          list(vr.PANDA_ARM_JOINTS))
    pos, mat = fk(kin.seed)
    start = Rotation.from_matrix(mat[0])
    goal_rotation = Rotation.from_rotvec([np.pi, 0.0, 0.0]) * start
    poses = np.array([
        np.concatenate([pos[0], start.as_quat(scalar_first=True)]),
        np.concatenate([pos[0] + [0.02, 0.0, 0.0], goal_rotation.as_quat(scalar_first=True)])])
    joints = kin.inverse(poses)
    assert np.all(joints >= kin.lower) and np.all(joints <= kin.upper)
    got_pos, got_mat = fk(joints)
    np.testing.assert_allclose(got_pos, poses[:, :3], atol=ACCEPTED)
    angles = (Rotation.from_quat(poses[:, 3:], scalar_first=True).inv()
              * Rotation.from_matrix(got_mat)).magnitude()
    assert np.all(angles <= ACCEPTED), angles


# --------------------------------------------------------------- 8b: out of reach

@pytest.mark.parametrize('first', [False, True])
def test_a_panda_pose_5m_away_is_out_of_reach(panda, first):
    kin = ModelKinematics(panda, 'panda_hand_tcp', 'panda_link0', vr.PANDA_ARM_JOINTS,
                          seed=vr.PANDA_READY)
    start = kin.forward(np.array(vr.PANDA_READY))
    far = start.copy()
    far[0] += 5.0  # was "needs a branch flip or passes near a singularity"
    poses = np.array([far]) if first else np.array([start, far])
    with pytest.raises(KinematicsError) as info:
        kin.inverse(poses)
    index = 0 if first else 1
    assert info.value.pose_index == index
    reason = info.value.reason
    assert 'out of reach' in reason and 'branch flip' not in reason
    # The distance from the first joint (panda_joint1's axis point, 0.333 m up) is said.
    distance = np.linalg.norm(far[:3] - [0.0, 0.0, 0.333])
    assert f'{distance:.3g} m' in reason, reason


def test_a_pose_within_reach_is_still_solved(panda):
    # The reach check refuses nothing the arm reaches.
    kin = ModelKinematics(panda, 'panda_hand_tcp', 'panda_link0', vr.PANDA_ARM_JOINTS,
                          seed=vr.PANDA_READY)
    start = kin.forward(np.array(vr.PANDA_READY))
    near = start.copy()
    near[0] += 0.1
    joints = kin.inverse(np.array([start, near]))
    np.testing.assert_allclose(kin.forward(joints)[:, :3], [start[:3], near[:3]], atol=ACCEPTED)
