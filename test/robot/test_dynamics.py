"""
Inverse dynamics with a payload (splines445_ros.robot.dynamics) against formulations written here.

Every expected value comes from outside the implementation:

* a recursive Newton-Euler written in this file (numpy, world frame, no
  MuJoCo) on the link tree parsed here from the URDF (``<origin xyz rpy>``,
  ``<axis>``, ``<inertial>``, ``<mimic>``), the payload a separate rigid
  body fixed to the tool link at the pose the test chose;
* the gradient, by central differences, of the potential energy
  ``sum m g z`` of every centre of mass (the same hand-written forward
  kinematics, no dynamics), payload included;
* the URDF's ``<limit effort>`` and ``<dynamics damping>`` read here, and
  the actuator ranges and joint properties the test itself sets.

The loader gives a massless URDF link 1e-6 kg and 1e-9 kg m^2 (MuJoCo's
``boundmass``/``boundinertia`` set by robot_model); the reference does the
same so the tolerances can stay at 1e-9 relative (1e-7 where the expected
value is a difference of torques or a finite difference).
"""

import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from splines445_ros.robot.dynamics import ArmDynamics, effort_limits
from splines445_ros.robot.robot_model import load_robot_model, RobotModel
from splines445_ros.robot.torque_limits import joint_torque_limit, model_torque_limits
from splines445_ros.tools import vendor_robots as vr

GRAVITY = 9.81
BOUND_MASS = 1e-6      # robot_model's compiler boundmass / boundinertia
BOUND_INERTIA = 1e-9
RTOL = 1e-9


# ------------------------------------------------------ reference, from the URDF text

def _vector(text, default='0 0 0'):
    return np.array([float(v) for v in (text or default).split()])


def _origin(element):
    origin = element.find('origin') if element is not None else None
    if origin is None:
        return np.eye(3), np.zeros(3)
    rpy = _vector(origin.get('rpy'))
    # URDF rpy: fixed-axis roll, pitch, yaw = intrinsic 'xyz' in scipy's lower case.
    return Rotation.from_euler('xyz', rpy).as_matrix(), _vector(origin.get('xyz'))


def _cross(a, b):
    return np.cross(a, b)


def _rotate(mat, vec):
    """Return mat (K, 3, 3) applied to vec (3,) or (K, 3)."""
    if vec.ndim == 1:
        return mat @ vec
    return np.einsum('kij,kj->ki', mat, vec)


class UrdfTree:
    """A URDF's link tree with its inertias, written for the test from the URDF spec."""

    def __init__(self, text):
        root = ET.fromstring(text)
        self.bodies = {}  # link -> list of (mass, com (3,), inertia about com (3, 3)), link frame
        for link in root.findall('link'):
            inertial = link.find('inertial')
            mass, com, inertia = 0.0, np.zeros(3), np.zeros((3, 3))
            if inertial is not None:
                turn, com = _origin(inertial)
                mass = float(inertial.find('mass').get('value'))
                i = {k: float(v) for k, v in inertial.find('inertia').attrib.items()}
                local = np.array([[i['ixx'], i['ixy'], i['ixz']],
                                  [i['ixy'], i['iyy'], i['iyz']],
                                  [i['ixz'], i['iyz'], i['izz']]])
                inertia = turn @ local @ turn.T
            if mass < BOUND_MASS:
                mass, com, inertia = BOUND_MASS, np.zeros(3), BOUND_INERTIA * np.eye(3)
            self.bodies[link.get('name')] = [(mass, com, inertia)]
        self.joints = {}
        children = {}
        for joint in root.findall('joint'):
            turn, xyz = _origin(joint)
            axis = _vector(joint.find('axis').get('xyz') if joint.find('axis') is not None
                           else None, '1 0 0')
            mimic = joint.find('mimic')
            dynamics = joint.find('dynamics')
            limit = joint.find('limit')
            info = {
                'name': joint.get('name'), 'type': joint.get('type'),
                'parent': joint.find('parent').get('link'),
                'child': joint.find('child').get('link'),
                'turn': turn, 'xyz': xyz, 'axis': axis / np.linalg.norm(axis),
                'mimic': None if mimic is None else (mimic.get('joint'),
                                                     float(mimic.get('multiplier', '1')),
                                                     float(mimic.get('offset', '0'))),
                'damping': float(dynamics.get('damping', '0')) if dynamics is not None else 0.0,
                'effort': float(limit.get('effort', 'nan')) if limit is not None else None}
            self.joints[info['name']] = info
            children.setdefault(info['parent'], []).append(info['name'])
        child_links = {j['child'] for j in self.joints.values()}
        self.root = next(n for n in self.bodies if n not in child_links)
        self.order = []  # joints, parents before children
        stack = [self.root]
        while stack:
            link = stack.pop()
            for name in children.get(link, []):
                self.order.append(name)
                stack.append(self.joints[name]['child'])

    def add_body(self, link, mass, com, inertia):
        """Fix a rigid body to ``link`` (com and inertia in the link's frame)."""
        self.bodies[link].append((mass, np.asarray(com, float), np.asarray(inertia, float)))

    def state(self, planned, q, qd, qdd, mimic=None):
        """
        Return {joint: (q, qd, qdd)} (K,) of every moving joint; the unplanned ones at rest.

        ``mimic``: {joint: polynomial coefficients (c0, c1, c2)} overriding the
        URDF's (``q = c0 + c1 p + c2 p^2`` of the parent's position ``p``).
        """
        k = len(q)
        values = {}
        for i, name in enumerate(planned):
            values[name] = (q[:, i], qd[:, i], qdd[:, i])
        for name in self.order:
            joint = self.joints[name]
            if joint['type'] == 'fixed' or name in values:
                continue
            if joint['mimic'] is None:
                values[name] = (np.zeros(k), np.zeros(k), np.zeros(k))
        for name in self.order:  # mimic joints follow their parents (parents first)
            joint = self.joints[name]
            if joint['mimic'] is None or name in values:
                continue
            parent, multiplier, offset = joint['mimic']
            c0, c1, c2 = (mimic or {}).get(name, (offset, multiplier, 0.0))
            p, pd, pdd = values[parent]
            values[name] = (c0 + c1 * p + c2 * p * p, (c1 + 2 * c2 * p) * pd,
                            2 * c2 * pd * pd + (c1 + 2 * c2 * p) * pdd)
        return values

    def forward(self, values, k):
        """Return {link: (R, p, w, dw, a)} (K, ...) in the world; a includes -gravity."""
        eye = np.broadcast_to(np.eye(3), (k, 3, 3))
        up = np.tile([0.0, 0.0, GRAVITY], (k, 1))  # base acceleration -g: gravity for free
        frames = {self.root: (eye, np.zeros((k, 3)), np.zeros((k, 3)), np.zeros((k, 3)), up)}
        self.axes = {}
        for name in self.order:
            joint = self.joints[name]
            rp, pp, wp, dwp, ap = frames[joint['parent']]
            rj = rp @ joint['turn']
            p = pp + _rotate(rp, joint['xyz'])
            z = _rotate(rj, joint['axis'])
            w, dw, rot = wp, dwp, rj
            extra = np.zeros((k, 3))
            if joint['type'] in ('revolute', 'continuous'):
                q, qd, qdd = values[name]
                turn = Rotation.from_rotvec(q[:, None] * joint['axis']).as_matrix()
                rot = rj @ turn
                w = wp + z * qd[:, None]
                dw = dwp + z * qdd[:, None] + _cross(wp, z * qd[:, None])
            elif joint['type'] == 'prismatic':
                q, qd, qdd = values[name]
                p = p + z * q[:, None]
                extra = 2.0 * _cross(wp, z * qd[:, None]) + z * qdd[:, None]
            r = p - pp
            a = ap + _cross(dwp, r) + _cross(wp, _cross(wp, r)) + extra
            frames[joint['child']] = (rot, p, w, dw, a)
            self.axes[name] = z
        return frames

    def inverse_dynamics(self, values, k):
        """Return {joint: torque (K,)} of every moving joint (Newton-Euler, world frame)."""
        frames = self.forward(values, k)
        force, moment = {}, {}  # on each link from its parent, moment about the link origin
        for link, (rot, p, w, dw, a) in frames.items():
            f, n = np.zeros((k, 3)), np.zeros((k, 3))
            for mass, com, inertia in self.bodies[link]:
                rc = _rotate(rot, com)
                ac = a + _cross(dw, rc) + _cross(w, _cross(w, rc))
                world = rot @ inertia @ np.swapaxes(rot, 1, 2)
                big_f = mass * ac
                big_n = _rotate(world, dw) + _cross(w, _rotate(world, w))
                f += big_f
                n += big_n + _cross(rc, big_f)
            force[link], moment[link] = f, n
        torque = {}
        for name in reversed(self.order):
            joint = self.joints[name]
            child, parent = joint['child'], joint['parent']
            f, n = force[child], moment[child]
            z = self.axes[name]
            if joint['type'] in ('revolute', 'continuous'):
                torque[name] = np.sum(z * n, axis=1)
            elif joint['type'] == 'prismatic':
                torque[name] = np.sum(z * f, axis=1)
            r = frames[child][1] - frames[parent][1]
            force[parent] = force[parent] + f
            moment[parent] = moment[parent] + n + _cross(r, f)
        return torque

    def potential(self, values, k):
        """Return the potential energy sum m g z (K,) of every body."""
        frames = self.forward(values, k)
        energy = np.zeros(k)
        for link, (rot, p, *_) in frames.items():
            for mass, com, _ in self.bodies[link]:
                energy += mass * GRAVITY * (p + _rotate(rot, com))[:, 2]
        return energy

    def torques(self, planned, q, qd, qdd, mimic=None):
        """Return the planned joints' torque (K, n), the mimic joints' carried to their parents."""
        q, qd, qdd = (np.atleast_2d(np.asarray(v, float)) for v in (q, qd, qdd))
        values = self.state(planned, q, qd, qdd, mimic)
        torque = self.inverse_dynamics(values, len(q))
        out = np.stack([torque[n] for n in planned], axis=1)
        for name, joint in self.joints.items():
            if joint['mimic'] is not None and joint['mimic'][0] in planned:
                parent = joint['mimic'][0]
                c0, c1, c2 = (mimic or {}).get(name, (0.0, joint['mimic'][1], 0.0))
                p = values[parent][0]
                out[:, planned.index(parent)] += (c1 + 2 * c2 * p) * torque[name]
        return out


# ------------------------------------------------------------------------ models

def read(path):
    with open(path, encoding='utf-8') as handle:
        return handle.read()


MIMIC_URDF = """<robot name="mimic_arm">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="0.02 0.01 0.15" rpy="0.1 0.2 0.3"/><mass value="3.0"/>
    <inertia ixx="0.05" iyy="0.04" izz="0.02" ixy="0.001" ixz="-0.002" iyz="0.003"/>
  </inertial></link>
  <link name="l2"><inertial><origin xyz="0.2 0.0 0.03"/><mass value="2.0"/>
    <inertia ixx="0.01" iyy="0.03" izz="0.03" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="l3"><inertial><origin xyz="0.1 0.02 0.0"/><mass value="1.0"/>
    <inertia ixx="0.004" iyy="0.006" izz="0.005" ixy="0.0003" ixz="0" iyz="0"/></inertial></link>
  <link name="l4"><inertial><origin xyz="0.0 0.05 0.01"/><mass value="0.5"/>
    <inertia ixx="0.001" iyy="0.001" izz="0.0015" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tool"><inertial><origin xyz="0.01 0 0.02"/><mass value="0.2"/>
    <inertia ixx="0.0002" iyy="0.0002" izz="0.0001" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="h1"><inertial><origin xyz="0.1 0 0"/><mass value="1.5"/>
    <inertia ixx="0.002" iyy="0.006" izz="0.006" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="h2"><inertial><origin xyz="0 0.12 0.02"/><mass value="0.8"/>
    <inertia ixx="0.003" iyy="0.001" izz="0.003" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="a" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="40" velocity="2"/></joint>
  <joint name="b" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0.05 0.3" rpy="0.3 -0.2 0.1"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" effort="30" velocity="2"/><dynamics damping="0.5"/></joint>
  <joint name="c" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.4 0 0"/><axis xyz="0.6 0 0.8"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/>
    <mimic joint="b" multiplier="-0.7" offset="0.3"/></joint>
  <joint name="s" type="prismatic"><parent link="l3"/><child link="l4"/>
    <origin xyz="0.2 0 0" rpy="0 0.4 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.1" upper="0.2" velocity="0.5"/></joint>
  <joint name="t" type="fixed"><parent link="l4"/><child link="tool"/>
    <origin xyz="0 0.1 0.05" rpy="0.5 0 -0.4"/></joint>
  <joint name="h" type="revolute"><parent link="l2"/><child link="h1"/>
    <origin xyz="0.1 0.05 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/></joint>
  <joint name="h_follow" type="revolute"><parent link="h1"/><child link="h2"/>
    <origin xyz="0.2 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="5" velocity="1"/>
    <mimic joint="h" multiplier="2.0" offset="0.5"/></joint>
</robot>
"""
MIMIC_PLANNED = ['a', 'b', 's']


def strip_meshes(text):
    """Return a URDF text without visuals and collisions, with robot_model's compiler options."""
    root = ET.fromstring(text)
    for link in root.findall('link'):
        for tag in ('visual', 'collision'):
            for element in link.findall(tag):
                link.remove(element)
    extension = ET.SubElement(root, 'mujoco')
    ET.SubElement(extension, 'compiler', fusestatic='false', boundmass=str(BOUND_MASS),
                  boundinertia=str(BOUND_INERTIA), discardvisual='true')
    return ET.tostring(root, encoding='unicode')


SITE_POS = np.array([0.01, 0.02, 0.09])
SITE_QUAT = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])
UR5_DAMPING = {'shoulder_lift_joint': 3.0, 'elbow_joint': 2.0}
UR5_ARMATURE = {'elbow_joint': 0.3, 'wrist_1_joint': 0.05}


def ur5_with_site():
    """Return the UR5 as an MJCF model with a turned site, drive properties and actuators."""
    spec = mujoco.MjSpec.from_string(strip_meshes(read(vr.ur5_urdf())))
    spec.body('wrist_3_link').add_site(name='grip', pos=SITE_POS, quat=SITE_QUAT)
    for name, value in UR5_DAMPING.items():
        spec.joint(name).damping = [value, 0.0, 0.0]
    for name, value in UR5_ARMATURE.items():
        spec.joint(name).armature = value
    spec.joint('wrist_2_joint').frictionloss = 1.5
    spec.joint('wrist_1_joint').stiffness = [20.0, 0.0, 0.0]
    spec.joint('wrist_1_joint').springref = 0.4
    forced = spec.add_actuator(name='pan_motor', target='shoulder_pan_joint',
                               trntype=mujoco.mjtTrn.mjTRN_JOINT)
    forced.forcelimited = 1
    forced.forcerange = [-77.0, 77.0]
    geared = spec.add_actuator(name='elbow_motor', target='elbow_joint',
                               trntype=mujoco.mjtTrn.mjTRN_JOINT)
    geared.ctrllimited = 1
    geared.ctrlrange = [-2.0, 2.5]
    geared.gear[0] = -40.0
    return RobotModel(spec.compile(), 'mjcf', 'ur5 with a site')


def mimic_quadratic():
    """Return the mimic arm with joint c = 0.3 - 0.7 b + 0.25 b^2 (an MJCF equality)."""
    spec = mujoco.MjSpec.from_string(strip_meshes(MIMIC_URDF))
    model = spec.compile()
    for equality in spec.equalities:
        if mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT,
                             model.eq_obj1id[equality.id]) == 'c':
            equality.data[2] = 0.25
    return RobotModel(spec.compile(), 'mjcf', 'mimic arm, quadratic')


def random_states(rng, count, lower, upper):
    """Return q within [lower, upper], qd and qdd (count, n)."""
    lower, upper = np.maximum(lower, -math.pi), np.minimum(upper, math.pi)
    q = rng.uniform(lower, upper, (count, len(lower)))
    qd = rng.uniform(-2.0, 2.0, q.shape)
    qdd = rng.uniform(-6.0, 6.0, q.shape)
    return q, qd, qdd


def bounds(robot, names):
    joints = robot.select(names)
    return np.array([j.lower for j in joints]), np.array([j.upper for j in joints])


def check_close(actual, expected, rtol=RTOL):
    """Compare torques with a relative tolerance, against the largest torque for tiny ones."""
    scale = np.max(np.abs(expected))
    np.testing.assert_allclose(actual, expected, rtol=rtol, atol=rtol * scale)


def rotation(quat):
    """Return the matrix of a (w, x, y, z) quaternion (scipy wants x, y, z, w)."""
    return Rotation.from_quat(np.roll(quat, -1)).as_matrix()


def inertia_matrix(values):
    ixx, iyy, izz, ixy, ixz, iyz = values
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


PAYLOAD_MASS = 2.5
PAYLOAD_COM = np.array([0.03, -0.05, 0.12])
PAYLOAD_INERTIA = np.array([0.02, 0.03, 0.025, 0.004, -0.003, 0.002])

# name: (URDF path function, planned joints, tool frame, the URDF link holding it)
ROBOTS = {
    'ur5': (vr.ur5_urdf, vr.UR5_JOINTS, 'tool0', 'tool0'),
    'panda': (vr.panda_urdf, vr.PANDA_ARM_JOINTS, 'panda_hand_tcp', 'panda_hand_tcp'),
}


@pytest.fixture(scope='module')
def vendor():
    """Load each vendor robot once: {name: (RobotModel, UrdfTree)}."""
    return {name: (load_robot_model(path()), UrdfTree(read(path())))
            for name, (path, *_) in ROBOTS.items()}


def payload_tree(tree, link, mass, com, inertia, pos=np.zeros(3), turn=np.eye(3)):
    """Fix the payload to ``link`` of ``tree`` at the tool frame (pos, turn) in the link."""
    tree.add_body(link, mass, pos + turn @ com, turn @ inertia @ turn.T)


# ------------------------------------------------------------------- the tests

@pytest.mark.parametrize('robot_name', sorted(ROBOTS))
@pytest.mark.parametrize('payload', ['none', 'point', 'inertia'])
def test_matches_newton_euler_on_the_urdf(vendor, robot_name, payload):
    robot, _ = vendor[robot_name]
    path, names, tool, link = ROBOTS[robot_name]
    tree = UrdfTree(read(path()))
    kwargs = {}
    if payload != 'none':
        inertia = PAYLOAD_INERTIA if payload == 'inertia' else None
        kwargs = {'payload_mass': PAYLOAD_MASS, 'payload_center_of_mass': PAYLOAD_COM,
                  'payload_inertia': inertia}
        payload_tree(tree, link, PAYLOAD_MASS, PAYLOAD_COM,
                     inertia_matrix(inertia) if inertia is not None else np.zeros((3, 3)))
    dynamics = ArmDynamics(robot, names, tool, **kwargs)
    rng = np.random.default_rng(len(robot_name) + len(payload))
    q, qd, qdd = random_states(rng, 300, *bounds(robot, names))
    check_close(dynamics.torques(q, qd, qdd), tree.torques(list(names), q, qd, qdd))


def test_some_joints_in_another_order(vendor):
    # Columns follow joint_names; the joints left out stay at their reference position, 0.
    robot, tree = vendor['ur5']
    names = ['wrist_2_joint', 'shoulder_pan_joint', 'elbow_joint']
    dynamics = ArmDynamics(robot, names, 'tool0', PAYLOAD_MASS, PAYLOAD_COM)
    reference = UrdfTree(read(vr.ur5_urdf()))
    payload_tree(reference, 'tool0', PAYLOAD_MASS, PAYLOAD_COM, np.zeros((3, 3)))
    rng = np.random.default_rng(19)
    q, qd, qdd = random_states(rng, 100, *bounds(robot, names))
    check_close(dynamics.torques(q, qd, qdd), reference.torques(names, q, qd, qdd))


def test_payload_changes_the_torques_as_its_own_newton_euler(vendor):
    # The payload's share alone, so a wrong payload cannot hide behind the arm's torques.
    robot, _ = vendor['panda']
    path, names, tool, link = ROBOTS['panda']
    bare, loaded = UrdfTree(read(path())), UrdfTree(read(path()))
    payload_tree(loaded, link, PAYLOAD_MASS, PAYLOAD_COM, inertia_matrix(PAYLOAD_INERTIA))
    rng = np.random.default_rng(3)
    q, qd, qdd = random_states(rng, 100, *bounds(robot, names))
    share = (ArmDynamics(robot, names, tool, PAYLOAD_MASS, PAYLOAD_COM, PAYLOAD_INERTIA)
             .torques(q, qd, qdd) - ArmDynamics(robot, names, tool).torques(q, qd, qdd))
    expected = (loaded.torques(list(names), q, qd, qdd)
                - bare.torques(list(names), q, qd, qdd))
    check_close(share, expected, 1e-7)


@pytest.mark.parametrize('inertia', [None, (0.01, 0.02, 0.015), tuple(PAYLOAD_INERTIA)])
def test_payload_at_a_turned_site(inertia):
    robot = ur5_with_site()
    names = list(vr.UR5_JOINTS)
    tree = UrdfTree(read(vr.ur5_urdf()))
    matrix = np.zeros((3, 3)) if inertia is None else (
        np.diag(inertia) if len(inertia) == 3 else inertia_matrix(inertia))
    payload_tree(tree, 'wrist_3_link', PAYLOAD_MASS, PAYLOAD_COM, matrix, SITE_POS,
                 rotation(SITE_QUAT))
    dynamics = ArmDynamics(robot, names, 'grip', PAYLOAD_MASS, PAYLOAD_COM, inertia)
    rng = np.random.default_rng(7)
    q, qd, qdd = random_states(rng, 200, *bounds(robot, names))
    # Damping, armature, friction and the spring of the model are not counted.
    check_close(dynamics.torques(q, qd, qdd), tree.torques(names, q, qd, qdd))


def test_damping_and_armature_only_on_request():
    robot = ur5_with_site()
    names = list(vr.UR5_JOINTS)
    rng = np.random.default_rng(11)
    q, qd, qdd = random_states(rng, 50, *bounds(robot, names))
    plain = ArmDynamics(robot, names, 'grip', 1.0).torques(q, qd, qdd)
    damped = ArmDynamics(robot, names, 'grip', 1.0, include_damping=True).torques(q, qd, qdd)
    damping = np.array([UR5_DAMPING.get(n, 0.0) for n in names])
    armature = np.array([UR5_ARMATURE.get(n, 0.0) for n in names])
    check_close(damped - plain, damping * qd + armature * qdd)


def test_panda_damping_from_the_urdf(vendor):
    robot, tree = vendor['panda']
    names = list(vr.PANDA_ARM_JOINTS)
    rng = np.random.default_rng(5)
    q, qd, qdd = random_states(rng, 50, *bounds(robot, names))
    damping = np.array([tree.joints[n]['damping'] for n in names])
    assert np.all(damping > 0.0)
    plain = ArmDynamics(robot, names).torques(q, qd, qdd)
    damped = ArmDynamics(robot, names, include_damping=True).torques(q, qd, qdd)
    check_close(damped - plain, damping * qd)
    check_close(plain, tree.torques(names, q, qd, qdd))


@pytest.mark.parametrize('quadratic', [False, True])
def test_mimic_joints_follow_and_are_carried(quadratic):
    robot = mimic_quadratic() if quadratic else load_robot_model(urdf_string=MIMIC_URDF)
    assert set(robot.joint_names) == {'a', 'b', 's', 'h'}
    tree = UrdfTree(MIMIC_URDF)
    mimic = {'c': (0.3, -0.7, 0.25)} if quadratic else None
    # Fixed to l4 at the tool's pose there (the fixed joint t), as a separate body.
    payload_tree(tree, 'l4', 1.2, PAYLOAD_COM, inertia_matrix(PAYLOAD_INERTIA),
                 tree.joints['t']['xyz'], tree.joints['t']['turn'])
    dynamics = ArmDynamics(robot, MIMIC_PLANNED, 'tool', 1.2, PAYLOAD_COM, PAYLOAD_INERTIA)
    rng = np.random.default_rng(13)
    q, qd, qdd = random_states(rng, 200, *bounds(robot, MIMIC_PLANNED))
    check_close(dynamics.torques(q, qd, qdd), tree.torques(MIMIC_PLANNED, q, qd, qdd, mimic))


def _potential_gradient(tree, names, q, mimic=None, step=1e-5):
    zeros = np.zeros_like(q)
    gradient = np.empty_like(q)
    for i in range(q.shape[1]):
        shift = np.zeros_like(q)
        shift[:, i] = step
        up = tree.potential(tree.state(names, q + shift, zeros, zeros, mimic), len(q))
        down = tree.potential(tree.state(names, q - shift, zeros, zeros, mimic), len(q))
        gradient[:, i] = (up - down) / (2.0 * step)
    return gradient


@pytest.mark.parametrize('case', ['ur5', 'panda', 'site', 'mimic'])
def test_holding_still_needs_the_potential_energy_gradient(vendor, case):
    # With qd = qdd = 0, the torque that holds the arm is dV/dq, V = sum m g z.
    if case in ROBOTS:
        robot, _ = vendor[case]
        path, names, tool, link = ROBOTS[case]
        tree = UrdfTree(read(path()))
        payload_tree(tree, link, PAYLOAD_MASS, PAYLOAD_COM, np.zeros((3, 3)))
        mimic = None
    elif case == 'site':
        robot, names, tool = ur5_with_site(), vr.UR5_JOINTS, 'grip'
        tree = UrdfTree(read(vr.ur5_urdf()))
        payload_tree(tree, 'wrist_3_link', PAYLOAD_MASS, PAYLOAD_COM, np.zeros((3, 3)),
                     SITE_POS, rotation(SITE_QUAT))
        mimic = None
    else:
        robot, names, tool = mimic_quadratic(), MIMIC_PLANNED, 'tool'
        tree = UrdfTree(MIMIC_URDF)
        payload_tree(tree, 'l4', PAYLOAD_MASS, PAYLOAD_COM, np.zeros((3, 3)),
                     tree.joints['t']['xyz'], tree.joints['t']['turn'])
        mimic = {'c': (0.3, -0.7, 0.25)}
    names = list(names)
    rng = np.random.default_rng(17)
    q, _, _ = random_states(rng, 40, *bounds(robot, names))
    zeros = np.zeros_like(q)
    tau = ArmDynamics(robot, names, tool, PAYLOAD_MASS, PAYLOAD_COM).torques(q, zeros, zeros)
    expected = _potential_gradient(tree, names, q, mimic)
    check_close(tau, expected, 1e-7)
    # The payload alone is a noticeable share of the holding torque.
    bare = ArmDynamics(robot, names, tool).torques(q, zeros, zeros)
    assert np.max(np.abs(tau - bare)) > 1.0


def test_one_sample_and_an_empty_batch(vendor):
    robot, tree = vendor['ur5']
    names = list(vr.UR5_JOINTS)
    dynamics = ArmDynamics(robot, names, 'tool0', 1.0)
    q, qd, qdd = np.full(6, 0.3), np.full(6, -0.5), np.full(6, 1.0)
    tau = dynamics.torques(q, qd, qdd)
    assert tau.shape == (6,)
    np.testing.assert_allclose(tau, dynamics.torques(q[None], qd[None], qdd[None])[0])
    assert dynamics.torques(np.zeros((0, 6)), np.zeros((0, 6)), np.zeros((0, 6))).shape == (0, 6)


# Against MuJoCo's own Newton-Euler, sample by sample (the small batches' path): the
# vectorised one must give the same numbers, up to round-off, on every sample.

TREE_MJCF = """<mujoco><option gravity="0.3 -1.2 -9.6"/><worldbody>
  <body name="b1" pos="0.1 0.2 0.3" quat="0.9 0.1 0.2 0.3">
    <inertial pos="0.05 0.02 0.1" quat="0.8 0.3 -0.1 0.2" mass="2" diaginertia="0.03 0.02 0.015"/>
    <joint name="j1" axis="0.3 0.4 1" pos="0.02 -0.03 0.01" ref="0.4" range="-2 2"/>
    <body name="b2" pos="0.3 0 0.1" euler="0.3 0.2 -0.5">
      <inertial pos="0.1 0.0 0.02" mass="1.5" diaginertia="0.01 0.02 0.02"/>
      <joint name="j2a" axis="0 1 0.2" pos="0.01 0.02 0.03" range="-2 2"/>
      <joint name="j2b" type="slide" axis="1 0.1 0" pos="0.05 0 0" ref="0.05" range="-0.2 0.3"/>
      <body name="b3" pos="0.2 0.05 0" euler="0.1 -0.4 0.2">
        <inertial pos="0.03 0.01 0.02" mass="0.7" diaginertia="0.003 0.002 0.004"/>
        <joint name="j3" axis="1 0 0" pos="0 0.01 0" range="-3 3"/>
        <body name="b4" pos="0.1 0 0.05" quat="0.7 0.7 0 0">
          <inertial pos="0.02 0 0" mass="0.4" diaginertia="0.001 0.001 0.002"/>
          <site name="grip" pos="0.01 0.02 0.03" quat="0.9 0.1 0.3 0.2"/>
        </body>
      </body>
      <body name="side" pos="0 0.15 0">
        <inertial pos="0.03 0.05 0.01" mass="0.9" diaginertia="0.002 0.003 0.004"/>
        <joint name="j4" type="slide" axis="0 0 1" range="-0.1 0.1"/>
        <joint name="j5" axis="0 1 0" pos="0 0.02 0" ref="-0.3" range="-2 2"/>
      </body>
    </body>
  </body>
</worldbody>
<equality><joint joint1="j5" joint2="j1" polycoef="0.1 -0.5 0.2 0.05 0.01"/></equality>
</mujoco>"""


def tree_model(text=TREE_MJCF):
    """
    Return a RobotModel of ``text``, by default a tree with what the URDF arms lack.

    Two joints on a body, slides, reference positions (``ref``), joint
    anchors off the body's origin, a branch, a joint driven by a
    polynomial, gravity off the vertical.
    """
    return RobotModel(mujoco.MjSpec.from_string(text).compile(), 'mjcf', 'a test tree')


def against_mujoco(dynamics, q, qd, qdd):
    """Return (the torques of a large batch, MuJoCo's sample by sample) for the same states."""
    assert len(q) >= dynamics.vectorised_from
    batch = dynamics.torques(q, qd, qdd)
    dynamics.vectorised_from = math.inf
    try:
        by_sample = dynamics.torques(q, qd, qdd)
    finally:
        del dynamics.vectorised_from    # back to the class's
    return batch, by_sample


@pytest.mark.parametrize('robot_name', sorted(ROBOTS))
@pytest.mark.parametrize('case', ['bare', 'payload', 'damping', 'some joints'])
def test_large_batches_match_mujoco_sample_by_sample(vendor, robot_name, case):
    robot, _ = vendor[robot_name]
    _, names, tool, _ = ROBOTS[robot_name]
    names = list(names)
    kwargs = {}
    if case != 'bare':
        kwargs = {'payload_mass': PAYLOAD_MASS, 'payload_center_of_mass': PAYLOAD_COM,
                  'payload_inertia': PAYLOAD_INERTIA}
    if case == 'damping':
        kwargs['include_damping'] = True
    if case == 'some joints':      # the others held, in another order
        names = [names[3], names[0], names[1]]
    dynamics = ArmDynamics(robot, names, tool, **kwargs)
    assert dynamics.vectorised
    rng = np.random.default_rng(len(robot_name) + len(case))
    q, qd, qdd = random_states(rng, 2000, *bounds(robot, names))
    batch, by_sample = against_mujoco(dynamics, q, qd, qdd)
    check_close(batch, by_sample)


def ball_jointed():
    """Return (robot, names, dynamics) of the tree with a ball joint: MuJoCo's at every size."""
    ball = tree_model(TREE_MJCF.replace('<joint name="j1" axis="0.3 0.4 1" pos="0.02 -0.03 0.01" '
                                        'ref="0.4" range="-2 2"/>', '<joint type="ball"/>')
                      .replace('<joint joint1="j5" joint2="j1" polycoef="0.1 -0.5 0.2 0.05 '
                               '0.01"/>', ''))
    names = ['j2a', 'j3', 'j5']
    return ball, names, ArmDynamics(ball, names, 'grip', 1.0)


def other_model(case):
    """
    Return (dynamics, robot, names) of one of the models besides the UR5 and the Panda.

    'tree' (slides, branches, two joints on a body, a payload), 'tree held'
    (j1 held: j5, driven by it, at a constant displacement), 'no gravity',
    'site damping' (the UR5 with a site as its tool, damping counted) or
    'mimic quadratic' (driven joints).
    """
    names, tool, kwargs = None, '', {}
    if case == 'tree':
        robot, tool = tree_model(), 'grip'
        kwargs = {'payload_mass': 1.0, 'payload_center_of_mass': (0.1, 0.0, 0.02),
                  'payload_inertia': (0.01, 0.02, 0.015)}
    elif case == 'tree held':
        robot, names = tree_model(), ['j3', 'j2a', 'j2b', 'j4']
    elif case == 'no gravity':
        robot = tree_model(TREE_MJCF.replace('<option ', '<option><flag gravity="disable"/>'
                                             '</option><option '))
    elif case == 'site damping':
        robot, tool = ur5_with_site(), 'grip'
        kwargs = {'payload_mass': 2.0, 'include_damping': True}
    else:
        robot, names, tool = mimic_quadratic(), MIMIC_PLANNED, 'tool'
        kwargs = {'payload_mass': 1.2, 'payload_center_of_mass': PAYLOAD_COM}
    names = list(names or robot.joint_names)
    return ArmDynamics(robot, names, tool, **kwargs), robot, names


@pytest.mark.parametrize('case', ['tree', 'tree held', 'no gravity', 'site damping',
                                  'mimic quadratic'])
def test_large_batches_match_mujoco_on_other_models(case):
    dynamics, robot, names = other_model(case)
    assert dynamics.vectorised
    rng = np.random.default_rng(len(case))
    q, qd, qdd = random_states(rng, 1000, *bounds(robot, names))
    batch, by_sample = against_mujoco(dynamics, q, qd, qdd)
    check_close(batch, by_sample)
    if case == 'no gravity':
        zeros = np.zeros_like(q)
        np.testing.assert_array_equal(dynamics.torques(q, zeros, zeros), 0.0)


def test_small_batches_and_unsupported_models_take_mujoco(vendor):
    robot, _ = vendor['ur5']
    names = list(vr.UR5_JOINTS)
    dynamics = ArmDynamics(robot, names, 'tool0', PAYLOAD_MASS, PAYLOAD_COM)
    rng = np.random.default_rng(23)
    q, qd, qdd = random_states(rng, dynamics.vectorised_from - 1, *bounds(robot, names))
    small = dynamics.torques(q, qd, qdd)
    dynamics.vectorised_from = 1
    check_close(small, dynamics.torques(q, qd, qdd))
    # A ball joint: MuJoCo's Newton-Euler at every batch size.
    ball, names, dynamics = ball_jointed()
    assert not dynamics.vectorised
    q, qd, qdd = random_states(rng, 2 * dynamics.vectorised_from, *bounds(ball, names))
    batch = dynamics.torques(q, qd, qdd)
    one_by_one = np.array([dynamics.torques(*sample) for sample in zip(q, qd, qdd)])
    np.testing.assert_array_equal(batch, one_by_one)


def loaded_panda(vendor, rng):
    """Return the Panda's dynamics with the payload and 1000 random states of its arm."""
    robot, _ = vendor['panda']
    names = list(vr.PANDA_ARM_JOINTS)
    dynamics = ArmDynamics(robot, names, 'panda_hand_tcp', PAYLOAD_MASS, PAYLOAD_COM)
    return (dynamics, *random_states(rng, 1000, *bounds(robot, names)))


def test_a_batch_taken_in_chunks_is_the_batch_taken_whole(vendor):
    """A 1 kHz check of a long plan goes through in chunks: the same torques, bit for bit."""
    dynamics, q, qd, qdd = loaded_panda(vendor, np.random.default_rng(5))
    whole = dynamics.torques(q, qd, qdd)
    dynamics.vectorised_chunk = 97     # the last chunk shorter than the others
    chunked = dynamics.torques(q, qd, qdd)
    np.testing.assert_array_equal(chunked, whole)
    check_close(chunked, against_mujoco(dynamics, q, qd, qdd)[1])


# gravity(q), the torques at rest by a pass of its own: torques(q, 0, 0) to round-off.
GRAVITY_RTOL = 1e-12


def held_still(dynamics, q):
    """Return (gravity(q), torques(q, 0, 0), the latter by MuJoCo sample by sample)."""
    zeros = np.zeros_like(q)
    at_rest = dynamics.torques(q, zeros, zeros)
    dynamics.vectorised_from = math.inf
    try:
        by_sample = dynamics.torques(q, zeros, zeros)
    finally:
        del dynamics.vectorised_from
    return dynamics.gravity(q), at_rest, by_sample


@pytest.mark.parametrize('robot_name', sorted(ROBOTS))
@pytest.mark.parametrize('count', [2000, 20, 5])
def test_gravity_is_the_torque_at_rest(vendor, robot_name, count):
    """Its own pass from gravity_vectorised_from samples on, torques' below: the same torques."""
    robot, _ = vendor[robot_name]
    _, names, tool, _ = ROBOTS[robot_name]
    dynamics = ArmDynamics(robot, names, tool, PAYLOAD_MASS, PAYLOAD_COM, PAYLOAD_INERTIA)
    assert dynamics.vectorised
    assert 5 < dynamics.gravity_vectorised_from <= 20 < dynamics.vectorised_from
    rng = np.random.default_rng(count + len(robot_name))
    q, _, _ = random_states(rng, count, *bounds(robot, list(names)))
    passes, own = [], dynamics._vectorised.gravity     # which path each batch takes
    dynamics._vectorised.gravity = lambda *args: (passes.append(len(args[0])), own(*args))
    gravity, at_rest, by_sample = held_still(dynamics, q)
    assert gravity.shape == q.shape
    assert passes == ([count] if count >= dynamics.gravity_vectorised_from else [])
    check_close(gravity, at_rest, GRAVITY_RTOL)
    check_close(gravity, by_sample, GRAVITY_RTOL)
    # The payload is in it: a bare arm's differ by much more than round-off.
    bare = ArmDynamics(robot, names, tool).gravity(q)
    assert np.max(np.abs(gravity - bare)) > 1.0
    if count < dynamics.gravity_vectorised_from:    # torques' path: the very same numbers
        np.testing.assert_array_equal(gravity, at_rest)
        # Its own pass on a small batch too.
        dynamics.gravity_vectorised_from = 1
        check_close(dynamics.gravity(q), by_sample, GRAVITY_RTOL)


@pytest.mark.parametrize('case', ['tree', 'tree held', 'no gravity', 'site damping',
                                  'mimic quadratic'])
def test_gravity_is_the_torque_at_rest_on_other_models(case):
    """Slides, branches, two joints on a body, held and driven joints, gravity off or askew."""
    dynamics, robot, names = other_model(case)
    assert dynamics.vectorised
    rng = np.random.default_rng(len(case) + 100)
    q, _, _ = random_states(rng, 500, *bounds(robot, names))
    gravity, at_rest, by_sample = held_still(dynamics, q)
    if case == 'no gravity':
        np.testing.assert_array_equal(gravity, 0.0)
        return
    check_close(gravity, at_rest, GRAVITY_RTOL)
    check_close(gravity, by_sample, GRAVITY_RTOL)


def test_gravity_of_one_sample_in_chunks_and_on_unsupported_models(vendor):
    rng = np.random.default_rng(29)
    dynamics, q, qd, qdd = loaded_panda(vendor, rng)
    # Callable as its torques: an inverse_dynamics for plan().
    np.testing.assert_array_equal(dynamics(q, qd, qdd), dynamics.torques(q, qd, qdd))
    one = dynamics.gravity(q[0])
    assert one.shape == (7,)
    np.testing.assert_array_equal(one, dynamics.torques(q[0], np.zeros(7), np.zeros(7)))
    assert dynamics.gravity(np.zeros((0, 7))).shape == (0, 7)
    whole = dynamics.gravity(q)
    dynamics.vectorised_chunk = 97
    np.testing.assert_array_equal(dynamics.gravity(q), whole)
    with pytest.raises(ValueError, match=r'shape \(N, 7\)'):
        dynamics.gravity(np.zeros((4, 6)))
    with pytest.raises(ValueError, match='not finite'):
        dynamics.gravity(np.full((30, 7), math.nan))
    # A ball joint: torques(q, 0, 0) (MuJoCo's) at every batch size.
    ball, names, dynamics = ball_jointed()
    assert not dynamics.vectorised
    q, _, _ = random_states(rng, 2 * dynamics.vectorised_from, *bounds(ball, names))
    zeros = np.zeros_like(q)
    np.testing.assert_array_equal(dynamics.gravity(q), dynamics.torques(q, zeros, zeros))


def test_effort_limits_as_the_urdf_says(vendor):
    for name, (path, names, *_) in ROBOTS.items():
        robot, tree = vendor[name]
        expected = [tree.joints[n]['effort'] for n in names]
        np.testing.assert_array_equal(effort_limits(robot, names), expected)


def test_effort_limits_from_mjcf_actuators():
    robot = ur5_with_site()
    limits = effort_limits(robot, vr.UR5_JOINTS)
    # forcerange 77; ctrlrange [-2, 2.5] x |gear -40| = 100; the others the URDF effort.
    np.testing.assert_array_equal(limits, [77.0, 150.0, 100.0, 28.0, 28.0, 28.0])


def test_the_planner_and_the_simulated_arm_read_one_torque_limit():
    robot = ur5_with_site()
    ids = [j.joint_id for j in robot.select(vr.UR5_JOINTS)]
    limits, sources = model_torque_limits(robot.model, ids, vr.UR5_JOINTS)
    np.testing.assert_array_equal(limits, effort_limits(robot, vr.UR5_JOINTS))
    assert sources == ('forcerange', 'effort', 'ctrlrange x gear', 'effort', 'effort', 'effort')
    assert [joint_torque_limit(robot.model, i) for i in ids[:3]] == [
        (77.0, 'forcerange'), (150.0, 'effort'), (100.0, 'ctrlrange x gear')]
    # Without a limit: the simulated arm names its parameter; skipped joints are NaN.
    robot = load_robot_model(urdf_string=MIMIC_URDF)
    ids = [j.joint_id for j in robot.select(MIMIC_PLANNED)]
    assert joint_torque_limit(robot.model, ids[-1]) is None
    with pytest.raises(ValueError, match="joint 's' has no torque limit.*set torque_limits"):
        model_torque_limits(robot.model, ids, MIMIC_PLANNED)
    limits, sources = model_torque_limits(robot.model, ids, MIMIC_PLANNED, [True, True, False])
    np.testing.assert_array_equal(limits, [40.0, 30.0, math.nan])
    assert sources == ('effort', 'effort', '')


def test_effort_limits_missing():
    robot = load_robot_model(urdf_string=MIMIC_URDF)
    with pytest.raises(ValueError, match="joint 's'.*no torque limit"):
        effort_limits(robot, MIMIC_PLANNED)
    np.testing.assert_array_equal(effort_limits(robot, MIMIC_PLANNED, missing='inf'),
                                  [40.0, 30.0, math.inf])
    with pytest.raises(ValueError, match='no actuated joint'):
        effort_limits(robot, ['a', 'nope'])
    with pytest.raises(ValueError, match='missing'):
        effort_limits(robot, ['a'], missing='zero')


@pytest.mark.parametrize('kwargs, message', [
    ({'payload_mass': -1.0}, 'payload_mass'),
    ({'payload_mass': math.nan}, 'payload_mass'),
    ({'payload_mass': math.inf}, 'payload_mass'),
    ({'payload_mass': 'heavy'}, 'payload_mass'),
    ({'payload_mass': 1.0, 'payload_center_of_mass': (0.0, 0.1)}, 'payload_center_of_mass'),
    ({'payload_mass': 1.0, 'payload_center_of_mass': (0.0, math.nan, 0.1)},
     'payload_center_of_mass'),
    ({'payload_mass': 1.0, 'payload_inertia': (0.1, 0.1, 0.1, 0.0)}, 'payload_inertia'),
    ({'payload_mass': 1.0, 'payload_inertia': (0.1, 0.1, -0.1)}, 'positive definite'),
    ({'payload_mass': 1.0, 'payload_inertia': (0.1, 0.1, 0.0)}, 'positive definite'),
    ({'payload_mass': 1.0, 'payload_inertia': (0.1, 0.1, 0.1, 0.2, 0.0, 0.0)},
     'positive definite'),
    ({'payload_mass': 1.0, 'payload_inertia': (0.01, 0.01, 0.05)}, 'triangle'),
    ({'payload_mass': 1.0, 'payload_inertia': (0.1, math.inf, 0.1)}, 'payload_inertia'),
    ({'payload_mass': 0.0, 'payload_inertia': (0.1, 0.1, 0.1)}, 'needs a mass'),
    ({'payload_mass': 1.0, 'tool_frame': ''}, 'needs a tool_frame'),
    ({'tool_frame': 'no_such_link'}, 'tool_frame'),
    ({'joint_names': ['shoulder_pan_joint', 'no_such_joint']}, 'no_such_joint'),
    ({'joint_names': ['elbow_joint', 'elbow_joint']}, 'duplicates'),
])
def test_bad_construction_refused(vendor, kwargs, message):
    robot, _ = vendor['ur5']
    arguments = {'joint_names': vr.UR5_JOINTS, 'tool_frame': 'tool0'}
    arguments.update(kwargs)
    with pytest.raises(ValueError, match=message):
        ArmDynamics(robot, **arguments)


def test_bad_samples_refused(vendor):
    robot, _ = vendor['ur5']
    dynamics = ArmDynamics(robot, vr.UR5_JOINTS, 'tool0')
    good = np.zeros((4, 6))
    for q, qd, qdd, message in [
            (np.zeros((4, 5)), good, good, r'shape \(N, 6\)'),
            (good, np.zeros((4, 7)), good, 'qd must have shape'),
            (good, good, np.zeros((4, 6, 1)), 'qdd must have shape'),
            (good, np.zeros((3, 6)), good, 'same shape'),
            (np.full((4, 6), math.nan), good, good, 'not finite'),
            (good, good, np.full((4, 6), math.inf), 'not finite'),
            ([['a'] * 6], good, good, 'numbers')]:
        with pytest.raises(ValueError, match=message):
            dynamics.torques(q, qd, qdd)


@pytest.mark.parametrize('quadratic', [False, True])
def test_the_damping_part_and_the_dry_friction_with_a_driven_joint(quadratic):
    """
    ``viscous`` and ``dry_friction`` on the mimic arm, its driven joint ``c`` damped too.

    Joint ``c = 0.3 - 0.7 b (+ 0.25 b**2)`` follows ``b``: its damping
    ``D_c qd_c`` reaches ``b`` times ``dc/db``, its friction times
    ``|dc/db|``; written out here from the coupling's coefficients.
    """
    spec = mujoco.MjSpec.from_string(strip_meshes(MIMIC_URDF))
    model = spec.compile()
    for equality in spec.equalities:
        if quadratic and mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT,
                                           model.eq_obj1id[equality.id]) == 'c':
            equality.data[2] = 0.25
    own = {'a': (0.0, 0.4), 'b': (0.5, 0.2), 'c': (0.8, 0.3), 's': (1.5, 2.0)}
    for name, (damping, friction) in own.items():
        spec.joint(name).damping = [damping, 0.0, 0.0]
        spec.joint(name).frictionloss = friction
    robot = RobotModel(spec.compile(), 'mjcf', 'mimic arm, damped')
    rng = np.random.default_rng(21)
    q, qd, qdd = random_states(rng, 80, *bounds(robot, MIMIC_PLANNED))
    dynamics = ArmDynamics(robot, MIMIC_PLANNED, include_damping=True)
    b_joint = robot.select(['b'])[0].joint_id
    b = q[:, 1] - float(robot.model.qpos0[robot.model.jnt_qposadr[b_joint]])
    slope = -0.7 + (0.5 if quadratic else 0.0) * b
    expected = np.stack([np.zeros(len(q)), (0.5 + 0.8 * slope * slope) * qd[:, 1],
                         1.5 * qd[:, 2]], axis=1)
    check_close(dynamics.viscous(q, qd), expected)
    friction = np.stack([np.full(len(q), 0.4), 0.2 + 0.3 * np.abs(slope),
                         np.full(len(q), 2.0)], axis=1)
    np.testing.assert_allclose(dynamics.dry_friction(q), friction, rtol=1e-12)
    # The damping part is part of the torques: they differ from the rigid ones by it alone.
    plain = ArmDynamics(robot, MIMIC_PLANNED).torques(q, qd, qdd)
    check_close(dynamics.torques(q, qd, qdd) - plain, expected)
    assert ArmDynamics(robot, MIMIC_PLANNED).viscous is None
    assert ArmDynamics(robot, MIMIC_PLANNED).dry_friction is None
