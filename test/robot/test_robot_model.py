"""
The robot model from a vendor's URDF (UR5, Franka Panda) and the planar arm's MJCF.

Every expected value comes from outside the implementation: forward
kinematics written here from the URDF's joint origins and axes (numpy, no
MuJoCo), the planar arm's analytic kinematics, and the limits as the
vendors' URDFs state them.
"""

import logging
import math
import xml.etree.ElementTree as ET

from example_counts import examples
from hypothesis import assume, given, settings, strategies as st
import numpy as np
import pytest
from splines445_ros.robot import robot_model
from splines445_ros.robot.inverse_kinematics import KinematicsError, ModelKinematics
from splines445_ros.robot.kinematics import PlanarArm
from splines445_ros.robot.robot_model import load_robot_model, MAX_DESCRIPTION_CHARS
from splines445_ros.sim.mujoco_model import load_arm_model, planar_arm_mjcf, PlanarArmModel
from splines445_ros.tools import vendor_robots as vr


# --------------------------------------------------------------- reference FK

def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def axis_matrix(axis, angle):
    """Rodrigues' formula."""
    k = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def homogeneous(rotation, translation):
    t = np.eye(4)
    t[:3, :3] = rotation
    t[:3, 3] = translation
    return t


class UrdfChain:
    """FK from a URDF's joint origins and axes, written for the test from the URDF spec."""

    def __init__(self, path, base, tool):
        root = ET.parse(path).getroot()
        by_child = {j.find('child').get('link'): j for j in root.findall('joint')}
        chain = []
        link = tool
        while link != base:
            joint = by_child[link]
            chain.append(joint)
            link = joint.find('parent').get('link')
        self.chain = list(reversed(chain))

    def pose(self, q_by_name):
        t = np.eye(4)
        for joint in self.chain:
            origin = joint.find('origin')
            xyz = [float(v) for v in origin.get('xyz', '0 0 0').split()]
            rpy = [float(v) for v in origin.get('rpy', '0 0 0').split()]
            t = t @ homogeneous(rpy_matrix(*rpy), xyz)
            if joint.get('type') in ('revolute', 'continuous'):
                axis = [float(v) for v in joint.find('axis').get('xyz').split()]
                t = t @ homogeneous(axis_matrix(axis, q_by_name[joint.get('name')]), [0, 0, 0])
        return t


def quaternion_matrix(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]])


def smallest_singular_value(chain, q, h=1e-6):
    """Of the finite-difference Jacobian (position, rotation) of the reference FK."""
    names = vr.UR5_JOINTS
    t0 = chain.pose(dict(zip(names, q)))
    columns = []
    for i in range(len(q)):
        dq = np.array(q, dtype=float)
        dq[i] += h
        t1 = chain.pose(dict(zip(names, dq)))
        w = (t1[:3, :3] @ t0[:3, :3].T - np.eye(3)) / h
        columns.append(np.concatenate([(t1[:3, 3] - t0[:3, 3]) / h,
                                       [w[2, 1], w[0, 2], w[1, 0]]]))
    return float(np.linalg.svd(np.array(columns).T, compute_uv=False)[-1])


@pytest.fixture(scope='module')
def ur5():
    return load_robot_model(vr.ur5_urdf())


@pytest.fixture(scope='module')
def panda():
    return load_robot_model(vr.panda_urdf())


@pytest.fixture(scope='module')
def ur5_kinematics(ur5):
    return ModelKinematics(ur5, 'tool0', 'base_link', seed=vr.UR5_READY)


@pytest.fixture(scope='module')
def panda_kinematics(panda):
    return ModelKinematics(panda, 'panda_hand_tcp', 'panda_link0', vr.PANDA_ARM_JOINTS,
                           seed=vr.PANDA_READY)


# --------------------------------------------------------------- joints and limits

def test_ur5_joints_in_order_with_the_vendor_limits(ur5):
    assert ur5.kind == 'urdf'
    assert ur5.joint_names == vr.UR5_JOINTS
    # ur5_robot.urdf: 3.15 rad/s and 150 N m on the big joints, 3.2 rad/s and 28 N m wrist.
    assert [j.velocity for j in ur5.joints] == [3.15, 3.15, 3.15, 3.2, 3.2, 3.2]
    assert [j.effort for j in ur5.joints] == [150.0, 150.0, 150.0, 28.0, 28.0, 28.0]
    assert ur5.joints[2].lower == pytest.approx(-math.pi)
    assert ur5.joints[0].upper == pytest.approx(2 * math.pi)


def test_panda_fingers_mimic_is_not_actuated_and_ranges_are_the_vendors(panda):
    assert panda.joint_names == vr.PANDA_ARM_JOINTS + ('panda_finger_joint1',)
    j4 = panda.joint('panda_joint4')
    assert (j4.lower, j4.upper) == (pytest.approx(-3.0718), pytest.approx(-0.0698))
    assert j4.velocity == 2.175 and j4.effort == 87.0
    assert panda.joint('panda_joint7').velocity == 2.61
    assert panda.joint('panda_finger_joint1').kind == 'slide'
    with pytest.raises(ValueError, match='panda_finger_joint2'):
        panda.joint('panda_finger_joint2')


# --------------------------------------------------------------- forward kinematics

angles = st.floats(-math.pi, math.pi, allow_nan=False)


@settings(max_examples=examples(40))
@given(st.lists(angles, min_size=6, max_size=6))
def test_ur5_forward_kinematics_matches_the_urdf(ur5_kinematics, q):
    chain = UrdfChain(vr.ur5_urdf(), 'base_link', 'tool0')
    expected = chain.pose(dict(zip(vr.UR5_JOINTS, q)))
    pose = ur5_kinematics.forward(np.array(q))
    np.testing.assert_allclose(pose[:3], expected[:3, 3], atol=1e-9)
    np.testing.assert_allclose(quaternion_matrix(pose[3:]), expected[:3, :3], atol=1e-9)


@settings(max_examples=examples(40))
@given(st.lists(st.floats(0.0, 1.0), min_size=7, max_size=7))
def test_panda_forward_kinematics_through_fixed_joints(panda, panda_kinematics, u):
    lower = np.array([panda.joint(n).lower for n in vr.PANDA_ARM_JOINTS])
    upper = np.array([panda.joint(n).upper for n in vr.PANDA_ARM_JOINTS])
    q = lower + np.array(u) * (upper - lower)
    # panda_hand_tcp hangs on three fixed joints below panda_link7: they must survive.
    expected = UrdfChain(vr.panda_urdf(), 'panda_link0', 'panda_hand_tcp').pose(
        dict(zip(vr.PANDA_ARM_JOINTS, q)))
    pose = panda_kinematics.forward(q)
    np.testing.assert_allclose(pose[:3], expected[:3, 3], atol=1e-9)
    np.testing.assert_allclose(quaternion_matrix(pose[3:]), expected[:3, :3], atol=1e-9)


def test_forward_kinematics_is_vectorised(ur5_kinematics):
    q = np.random.default_rng(3).uniform(-3, 3, (4, 5, 6))
    poses = ur5_kinematics.forward(q)
    assert poses.shape == (4, 5, 7)
    np.testing.assert_allclose(poses[2, 3], ur5_kinematics.forward(q[2, 3]), atol=1e-15)


@pytest.fixture(scope='module')
def planar_model(tmp_path_factory):
    path = tmp_path_factory.mktemp('planar') / 'planar_arm.xml'
    path.write_text(planar_arm_mjcf(PlanarArmModel(), ('joint1', 'joint2', 'joint3')))
    return load_robot_model(str(path))


@settings(max_examples=examples(40))
@given(st.lists(angles, min_size=3, max_size=3))
def test_generic_kinematics_agree_with_the_planar_arm(planar_model, q):
    kin = ModelKinematics(planar_model, 'tool')
    arm = PlanarArm(1.1, 0.9)
    x, y, yaw = arm.forward(np.array(q))
    pose = kin.forward(np.array(q))
    np.testing.assert_allclose(pose[:3], [x, y, 0.0], atol=1e-12)
    expected = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    assert abs(abs(np.dot(pose[3:], expected)) - 1.0) < 1e-12


def test_generic_inverse_agrees_with_the_planar_arm(planar_model):
    kin = ModelKinematics(planar_model, 'tool', seed=[0.3, 1.2, -0.5])
    arm = PlanarArm(1.1, 0.9)
    xyo = np.array([[1.2, 0.4, 0.2], [1.0, 0.8, 0.5], [0.5, 1.1, -0.3]])
    rows = np.column_stack([xyo[:, 0], xyo[:, 1], np.zeros(3), np.cos(xyo[:, 2] / 2),
                            np.zeros(3), np.zeros(3), np.sin(xyo[:, 2] / 2)])
    # The seed has q2 > 0: the analytic elbow +1 branch.
    np.testing.assert_allclose(kin.inverse(rows), arm.inverse(xyo, elbow=1.0), atol=1e-8)


# --------------------------------------------------------------- inverse kinematics

@settings(max_examples=examples(25))
@given(st.lists(angles, min_size=6, max_size=6), st.lists(st.floats(-0.1, 0.1), min_size=6,
                                                          max_size=6))
def test_ur5_inverse_returns_the_pose_on_the_seeds_branch(ur5_kinematics, q, nudge):
    q = np.array(q)
    # Away from singular poses (where the solutions are not isolated).
    assume(smallest_singular_value(UrdfChain(vr.ur5_urdf(), 'base_link', 'tool0'), q) > 0.02)
    pose = ur5_kinematics.forward(q)
    ur5_kinematics.seed = q + np.array(nudge)
    try:
        solution = ur5_kinematics.inverse(pose[None, :])[0]
    except KinematicsError as exc:
        # Only near a singularity (wrist, elbow or shoulder), and the error says so.
        assert exc.pose_index == 0 and 'tool pose 0' in str(exc)
        return
    finally:
        ur5_kinematics.seed = np.array(vr.UR5_READY)
    np.testing.assert_allclose(ur5_kinematics.forward(solution), pose, atol=1e-8)
    # A 6-axis arm has isolated solutions: the seed's neighbour is q itself.
    np.testing.assert_allclose(solution, q, atol=1e-6)


@settings(max_examples=examples(25))
@given(st.lists(st.floats(0.05, 0.95), min_size=7, max_size=7), st.integers(0, 2**32 - 1))
def test_panda_inverse_reaches_random_poses_within_the_ranges(panda, panda_kinematics, u, seed):
    lower, upper = panda_kinematics.lower, panda_kinematics.upper
    q = lower + np.array(u) * (upper - lower)
    pose = panda_kinematics.forward(q)
    panda_kinematics.seed = np.clip(q + np.random.default_rng(seed).uniform(-0.2, 0.2, 7),
                                    lower, upper)
    try:
        solution = panda_kinematics.inverse(pose[None, :])[0]
    finally:
        panda_kinematics.seed = np.array(vr.PANDA_READY)
    assert np.all(solution >= lower) and np.all(solution <= upper)
    got = panda_kinematics.forward(solution)
    np.testing.assert_allclose(got[:3], pose[:3], atol=1e-8)
    assert abs(abs(np.dot(got[3:], pose[3:])) - 1.0) < 1e-12


def test_a_straight_line_keeps_the_branch(ur5_kinematics):
    start = ur5_kinematics.forward(np.array(vr.UR5_READY))
    line = np.repeat(start[None, :], 11, axis=0)
    line[:, 0] += np.linspace(0.0, 0.2, 11)
    line[:, 1] -= np.linspace(0.0, 0.3, 11)
    joints = ur5_kinematics.inverse(line)
    np.testing.assert_allclose(ur5_kinematics.forward(joints), line, atol=1e-8)
    assert np.max(np.abs(np.diff(joints, axis=0))) < 0.2
    # Elbow up all the way, as in the seed.
    assert np.all(joints[:, 2] > 0.5)


def test_an_unreachable_pose_is_named(ur5_kinematics):
    start = ur5_kinematics.forward(np.array(vr.UR5_READY))
    far = start.copy()
    far[0] = 3.0  # the UR5 reaches 0.85 m
    with pytest.raises(KinematicsError, match=r'tool pose 1 at \(x, y, z\) = \(3,') as info:
        ur5_kinematics.inverse(np.array([start, far]))
    assert info.value.pose_index == 1 and 'out of reach' in str(info.value)


def test_a_joint_range_stops_a_2pi_wrap(ur5):
    # Wrist 3 at +6.0 of its +-2 pi range: turning the tool 0.5 rad further about its
    # axis needs wrist 3 beyond the range (or a 2 pi jump back): refused, pose named.
    kin = ModelKinematics(ur5, 'tool0', 'base_link', seed=vr.UR5_READY[:5] + (6.0,))
    start = kin.forward(kin.seed)
    turned = kin.forward(np.array(vr.UR5_READY[:5] + (6.5,)))
    with pytest.raises(KinematicsError, match='tool pose 1') as info:
        kin.inverse(np.array([start, turned]))
    assert 'joint ranges' in info.value.reason


def test_a_pose_at_1e300_m_is_a_value_error(ur5_kinematics):
    # Review: it overflowed the walk's step count (OverflowError).
    start = ur5_kinematics.forward(np.array(vr.UR5_READY))
    far = start.copy()
    far[0] += 1e300
    with pytest.raises(ValueError, match='tool pose 1 is 1e[+]300 m from the base frame'):
        ur5_kinematics.inverse(np.array([start, far]))


def test_a_line_through_the_wrist_singularity_is_refused_naming_the_pose(ur5):
    # Wrist 2 from +0.3 to -0.3 rad, the other joints kept: the straight line
    # and slerp between the two tool poses pass the wrist singularity
    # (wrist 2 = 0), where wrists 1 and 3 would have to spin round.
    start, end = np.array(vr.UR5_READY), np.array(vr.UR5_READY)
    start[4], end[4] = 0.3, -0.3
    kin = ModelKinematics(ur5, 'tool0', 'base_link', seed=tuple(start))
    with pytest.raises(KinematicsError, match=r'tool pose 1 at \(x, y, z\)') as info:
        kin.inverse(np.array([kin.forward(start), kin.forward(end)]))
    assert info.value.pose_index == 1
    assert 'branch flip or passes near a singularity' in info.value.reason


# --------------------------------------------------------------- bad input

MINIMAL = """<robot name="two">
  <link name="base"/>
  <link name="arm"><inertial><mass value="1"/><origin xyz="0.5 0 0"/>
    <inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><mesh filename="package://nowhere/meshes/arm.dae"/></geometry></visual>
    <collision><geometry><mesh filename="package://nowhere/meshes/arm.stl"/></geometry>
    </collision>
  </link>
  <link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-2" upper="2" velocity="{velocity}" effort="9"/></joint>
  <joint name="tip_joint" type="fixed"><parent link="arm"/><child link="tip"/>
    <origin xyz="1 0 0"/></joint>
</robot>"""


def test_missing_meshes_are_dropped_and_said_once(caplog):
    # Said once per process: another test may have said it already.
    getattr(robot_model, '_LOGGED_NOTES', set()).clear()
    with caplog.at_level(logging.WARNING):
        robot = load_robot_model(urdf_string=MINIMAL.format(velocity=1.5))
    assert robot.joint_names == ('j1',) and robot.joints[0].velocity == 1.5
    assert len(robot.notes) == 1 and 'arm.stl' in robot.notes[0]
    assert sum('dropped' in r.getMessage() for r in caplog.records) == 1
    kin = ModelKinematics(robot, 'tip')
    np.testing.assert_allclose(kin.forward(np.array([math.pi / 2]))[:3], [0, 1, 0], atol=1e-12)


def test_a_file_read_again_is_not_noted_again(tmp_path, caplog):
    """The arm reads a file three times (planner, simulation, controller): one note on the log."""
    getattr(robot_model, '_LOGGED_NOTES', set()).clear()
    path = tmp_path / 'two.urdf'
    path.write_text(MINIMAL.format(velocity=1.5))
    with caplog.at_level(logging.WARNING):
        for _ in range(2):
            assert len(load_robot_model(str(path)).notes) == 1
        load_arm_model(('j1',), (9.0,), 0.002, model_file=str(path))
    dropped = [r.getMessage() for r in caplog.records if 'dropped' in r.getMessage()]
    assert len(dropped) == 1 and 'arm.stl' in dropped[0]
    # Another file's note is its own.
    other = tmp_path / 'other.urdf'
    other.write_text(MINIMAL.format(velocity=2.5))
    with caplog.at_level(logging.WARNING):
        load_robot_model(str(other))
    assert sum('other.urdf' in r.getMessage() for r in caplog.records) == 1


@pytest.mark.parametrize('text, match', [
    ('<robot name="x"><link name="a"></robot>', 'not well-formed XML'),
    ('<mujoco/>', 'not a URDF'),
    ('<!DOCTYPE r [<!ENTITY a "aaaa">]><robot name="x"/>', 'entities'),
    (MINIMAL.format(velocity='fast'), 'joint \'j1\': <limit velocity="fast">'),
    ('', 'empty'),
    ('<robot name="x"><joint name="j" type="revolute"><parent link="nope"/>'
     '<child link="nada"/></joint></robot>', 'MuJoCo cannot load robot_description'),
])
def test_bad_descriptions_are_refused_with_the_reason(text, match):
    with pytest.raises(ValueError, match=match):
        load_robot_model(urdf_string=text)


def test_a_huge_description_is_refused():
    with pytest.raises(ValueError, match='more than'):
        load_robot_model(urdf_string='<robot>' + ' ' * MAX_DESCRIPTION_CHARS + '</robot>')


def test_missing_file_and_unknown_frames(ur5, tmp_path):
    with pytest.raises(ValueError, match='no such file'):
        load_robot_model(str(tmp_path / 'none.urdf'))
    with pytest.raises(ValueError, match=r"tool_frame 'flange' is not a link.*tool0"):
        ModelKinematics(ur5, 'flange', 'base_link')
    with pytest.raises(ValueError, match="base_frame 'wrist_1_link' moves with the joints"):
        ModelKinematics(ur5, 'tool0', 'wrist_1_link')
    with pytest.raises(ValueError, match="no actuated joint 'joint7'"):
        ModelKinematics(ur5, 'tool0', 'base_link', ('shoulder_pan_joint', 'joint7'))
    with pytest.raises(ValueError, match='moves with none of the joints'):
        ModelKinematics(ur5, 'shoulder_link', 'base_link', ('wrist_1_joint',))


@pytest.mark.parametrize('path', [vr.ur5_urdf(), vr.panda_urdf()])
def test_the_root_link_is_the_urdfs_link_no_joint_moves(path):
    """
    RobotModel.root_link against the URDF read here: the link that is no joint's child.

    A root link named ``world`` is MuJoCo's world itself: the link fixed to
    it at its origin names the same frame (the UR5's ``base_link``).
    """
    tree = ET.parse(path).getroot()
    joints = tree.findall('joint')
    children = {j.find('child').get('link') for j in joints}
    roots = [link.get('name') for link in tree.findall('link') if link.get('name') not in children]
    assert len(roots) == 1
    expected = roots[0]
    if expected == 'world':
        fixed, = [j for j in joints if j.find('parent').get('link') == 'world']
        origin = fixed.find('origin')
        assert fixed.get('type') == 'fixed'
        assert origin is None or all(float(v) == 0.0 for key in ('xyz', 'rpy')
                                     for v in (origin.get(key) or '0 0 0').split())
        expected = fixed.find('child').get('link')
    assert load_robot_model(path).root_link == expected


def test_an_mjcf_model_has_no_root_link(tmp_path):
    """Its poses are in MuJoCo's own world frame, ``world``: no URDF link names it."""
    path = tmp_path / 'arm.xml'
    path.write_text(planar_arm_mjcf(PlanarArmModel(), ('joint1', 'joint2', 'joint3'), 0.001))
    assert load_robot_model(str(path)).root_link is None


@pytest.mark.parametrize('root, first, expected', [
    ('base', 'revolute', 'base'),       # the root link is fixed to the world
    ('world', 'revolute', None),        # the first body moves: no link names the world
    ('world', 'prismatic', None),
    ('world', 'fixed', 'link1')])       # fixed at the origin: link1 is the world's frame
def test_the_root_link_is_never_a_link_that_moves(tmp_path, root, first, expected):
    """A URDF bolted to ``world`` by a joint: its first link moves (helper-91: it was named)."""
    inertial = ('<inertial><mass value="1"/><origin xyz="0 0 0.1"/><inertia ixx="0.01" '
                'iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>')
    limit = '<limit lower="-3" upper="3" effort="10" velocity="1"/>'
    links = ''.join(f'<link name="{name}">{"" if name == "world" else inertial}</link>'
                    for name in (root, 'link1', 'link2'))
    text = (f'<robot name="r">{links}'
            f'<joint name="j0" type="{first}"><parent link="{root}"/><child link="link1"/>'
            f'<axis xyz="1 0 0"/>{"" if first == "fixed" else limit}</joint>'
            '<joint name="j1" type="revolute"><parent link="link1"/><child link="link2"/>'
            f'<origin xyz="0 0 0.3"/><axis xyz="0 1 0"/>{limit}</joint></robot>')
    path = tmp_path / 'arm.urdf'
    path.write_text(text)
    assert load_robot_model(str(path)).root_link == expected
