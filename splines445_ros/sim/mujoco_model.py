"""
MuJoCo models of the arm: the paper's planar 3-DOF arm built as MJCF, or a user's file.

The built-in arm (:func:`planar_arm_mjcf`) moves in the vertical x-y plane
(gravity along -y when on), every joint a hinge about z:

* link 1 (length d1) and link 2 (length d2) are uniform rods of
  ``link_masses[0]`` and ``[1]``; body 3 is the tool, a point mass
  ``link_masses[2]`` at 0.15 m from joint 3; the site ``tool`` sits on joint 3
  (the paper's tool point (X, Y), yaw O = q1 + q2 + q3);
* every joint has the motor's rotor inertia reflected through its gear
  (``armature``), viscous damping and dry friction (``frictionloss``);
* with ``joint_stiffness[j] > 0`` joint j is elastic: the motor is a rotor of
  its own (hinge ``<joint>_motor``, carrying armature, damping and friction),
  coupled to the link's hinge by a spring (a fixed tendon motor - link with
  that stiffness, damped at ``spring_damping_ratio`` of critical for the link).

:func:`load_arm_model` compiles the built-in arm or a user's MJCF file with
:class:`mujoco.MjSpec`, checks that every joint of ``joint_names`` exists as a
hinge or slide, removes the file's own actuators on those joints and adds one
torque actuator per joint (on the motor hinge when elastic) with first-order
lag (``filterexact`` dynamics, time constant ``actuator_time_constant``) and
its control range at the torque limit.  It also returns the rigid model the
controller uses for inverse dynamics (the same file; for the built-in arm,
the same arm with stiff joints).
"""

from dataclasses import dataclass
import math
from typing import Optional, Tuple

import numpy as np

from ..robot.mujoco_import import import_mujoco
from ..robot.robot_model import (check_mjcf, model_file_where, read_description_file,
                                 urdf_spec)
from ..robot.user_text import clip, show, show_names, show_path

TOOL_SITE = 'tool'
TOOL_OFFSET = 0.15  # m, centre of mass of the tool body beyond joint 3
GRAVITY = 9.81
MOTOR_SUFFIX = '_motor'


@dataclass(frozen=True)
class PlanarArmModel:
    """Physical parameters of the built-in planar arm (SI units, per joint)."""

    link_lengths: Tuple[float, ...] = (1.1, 0.9)
    link_masses: Tuple[float, ...] = (20.0, 12.0, 4.0)
    rotor_inertia: Tuple[float, ...] = (10.0, 4.0, 0.1)
    joint_damping: Tuple[float, ...] = (10.0, 4.0, 0.2)
    joint_friction: Tuple[float, ...] = (10.0, 4.0, 0.2)
    joint_stiffness: Tuple[float, ...] = (0.0, 0.0, 0.0)
    spring_damping_ratio: float = 0.02
    gravity: bool = True

    def link_inertias(self):
        """Return the link-side inertia (3,) about each joint, arm stretched."""
        d1, d2 = self.link_lengths
        m1, m2, m3 = self.link_masses
        i3 = m3 * TOOL_OFFSET ** 2
        i2 = m2 * d2 ** 2 / 3.0 + m3 * (d2 + TOOL_OFFSET) ** 2
        i1 = (m1 * d1 ** 2 / 3.0 + m2 * (d2 ** 2 / 12.0 + (d1 + 0.5 * d2) ** 2)
              + m3 * (d1 + d2 + TOOL_OFFSET) ** 2)
        return np.array([i1, i2, i3])


def stiffness_for_frequency(model, frequency_hz):
    """Return stiffnesses (3,) giving each joint ``frequency_hz`` (motor held, arm stretched)."""
    return tuple(float(v) for v in (2.0 * math.pi * frequency_hz) ** 2 * model.link_inertias())


def _f(value):
    return f'{float(value):.12g}'


def _rod(mass, length):
    """Return the inertial element of a uniform rod along x."""
    across = max(mass * length ** 2 / 12.0, 1e-9)
    return (f'<inertial pos="{_f(0.5 * length)} 0 0" mass="{_f(mass)}" '
            f'diaginertia="{_f(1e-6 * across)} {_f(across)} {_f(across)}"/>')


def planar_arm_mjcf(model, joint_names, timestep=0.001):
    """Return the MJCF text of the built-in planar arm with ``joint_names`` (3 names)."""
    d1, d2 = model.link_lengths
    m1, m2, m3 = model.link_masses
    inertias = model.link_inertias()
    gravity = f'0 {_f(-GRAVITY)} 0' if model.gravity else '0 0 0'
    tool_point = (f'<inertial pos="{_f(TOOL_OFFSET)} 0 0" mass="{_f(m3)}" '
                  f'diaginertia="1e-6 1e-6 1e-6"/>')
    inertial = [_rod(m1, d1), _rod(m2, d2), tool_point]
    offsets = ['0 0 0', f'{_f(d1)} 0 0', f'{_f(d2)} 0 0']
    geoms = [f'<geom type="capsule" fromto="0 0 0 {_f(d1)} 0 0" size="0.04" mass="0"/>',
             f'<geom type="capsule" fromto="0 0 0 {_f(d2)} 0 0" size="0.03" mass="0"/>',
             f'<geom type="sphere" pos="{_f(TOOL_OFFSET)} 0 0" size="0.03" mass="0"/>']
    tendons = []

    def body(j):
        name = joint_names[j]
        drive = (f'armature="{_f(model.rotor_inertia[j])}" '
                 f'damping="{_f(model.joint_damping[j])}" '
                 f'frictionloss="{_f(model.joint_friction[j])}"')
        rotor = ''
        if model.joint_stiffness[j] > 0.0:
            k = model.joint_stiffness[j]
            c = 2.0 * model.spring_damping_ratio * math.sqrt(k * inertias[j])
            rotor = (f'<body name="{name}{MOTOR_SUFFIX}_rotor" pos="{offsets[j]}">'
                     f'<inertial pos="0 0 0" mass="0.001" diaginertia="1e-6 1e-6 1e-6"/>'
                     f'<joint name="{name}{MOTOR_SUFFIX}" type="hinge" axis="0 0 1" {drive}/>'
                     f'</body>')
            tendons.append(f'<fixed name="{name}_spring" stiffness="{_f(k)}" '
                           f'damping="{_f(c)}" springlength="0">'
                           f'<joint joint="{name}{MOTOR_SUFFIX}" coef="1"/>'
                           f'<joint joint="{name}" coef="-1"/></fixed>')
            drive = ''
        inner = body(j + 1) if j < 2 else ''
        site = (f'<site name="{TOOL_SITE}" pos="0 0 0" size="0.02"/>' if j == 2 else '')
        return (f'{rotor}<body name="link{j + 1}" pos="{offsets[j]}">{inertial[j]}'
                f'<joint name="{name}" type="hinge" axis="0 0 1" {drive}/>'
                f'{geoms[j]}{site}{inner}</body>')

    tree = body(0)
    return ('<mujoco model="splines445_planar_arm">'
            '<compiler angle="radian" autolimits="true"/>'
            f'<option timestep="{_f(timestep)}" gravity="{gravity}" integrator="implicitfast">'
            '<flag contact="disable"/></option>'
            f'<worldbody>{tree}</worldbody>'
            f'<tendon>{"".join(tendons)}</tendon>'
            '</mujoco>')


@dataclass
class ArmModel:
    """A compiled simulation model, the controller's rigid model and the joint mapping."""

    model: object                  # mujoco.MjModel, the simulated arm
    rigid: object                  # mujoco.MjModel for inverse dynamics
    joint_names: Tuple[str, ...]
    qpos: np.ndarray               # (n,) qpos address of each link joint
    dof: np.ndarray                # (n,) dof address of each link joint
    motor_qpos: np.ndarray         # (n,) qpos address of the driven joint (motor when elastic)
    motor_dof: np.ndarray          # (n,) dof address of the driven joint
    actuators: np.ndarray          # (n,) actuator ids
    rigid_qpos: np.ndarray         # (n,) in the rigid model
    rigid_dof: np.ndarray
    stiffness: np.ndarray          # (n,) spring of elastic joints, 0 = rigid
    tool_site: Optional[int]       # site id for tool_pose, None = none
    source: str                    # 'built-in' or the file's path

    @property
    def timestep(self):
        """Return the physics time step [s]."""
        return float(self.model.opt.timestep)


def _load_spec(mujoco, xml=None, path=None, text=None):
    """Return the MjSpec of MJCF ``xml``, or of the file ``path`` whose ``text`` was read."""
    if path is not None:
        spec = urdf_spec(mujoco, path, text)
        if spec is not None:
            return spec
        check_mjcf(path, text, model_file_where(path))
    try:
        if path is not None:
            return mujoco.MjSpec.from_file(path)
        return mujoco.MjSpec.from_string(xml)
    except Exception as exc:  # mujoco raises ValueError or its own errors
        where = show_path(path) if path is not None else 'built-in model'
        raise ValueError(f'cannot load MJCF {where}: {clip(str(exc).strip(), 500)}') from None


def _compile(spec, where):
    try:
        return spec.compile()
    except Exception as exc:
        raise ValueError(f'cannot compile MJCF {where}: {clip(str(exc).strip(), 500)}') \
            from None


def _add_actuators(mujoco, spec, targets, torque_limits, time_constant):
    driven = set(targets)
    for act in list(spec.actuators):
        if act.trntype == mujoco.mjtTrn.mjTRN_JOINT and act.target in driven:
            spec.delete(act)
    for target, limit in zip(targets, torque_limits):
        act = spec.add_actuator()
        act.name = f'splines445_torque_{target}'
        act.target = target
        act.trntype = mujoco.mjtTrn.mjTRN_JOINT
        act.gainprm[0] = 1.0
        if time_constant > 0.0:
            act.dyntype = mujoco.mjtDyn.mjDYN_FILTEREXACT
            act.dynprm[0] = time_constant
        act.ctrllimited = 1
        act.ctrlrange = [-float(limit), float(limit)]


def _joint_addresses(mujoco, model, names, where):
    qpos, dof = [], []
    missing = []
    for name in names:
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0:
            missing.append(name)
            continue
        kinds = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        if int(model.jnt_type[jid]) not in kinds:
            raise ValueError(f'joint {show(name)} of {where} is not a hinge or slide joint')
        qpos.append(int(model.jnt_qposadr[jid]))
        dof.append(int(model.jnt_dofadr[jid]))
    if missing:
        available = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
                     for j in range(model.njnt)]
        raise ValueError(f'{where} has no joint(s) {show_names(missing)} (joint_names); its '
                         f'joints: {show_names(available)}')
    return np.array(qpos, dtype=int), np.array(dof, dtype=int)


def _add_tool_frame_site(mujoco, spec, tool_frame, where):
    """Put a site on the body (URDF link) ``tool_frame``; return the site's name."""
    for site in spec.sites:
        if site.name == tool_frame:
            return tool_frame
    body = spec.body(tool_frame)
    if body is None:
        raise ValueError(f'{where} has no link, body or site {show(tool_frame)} (tool_frame)')
    name = f'splines445_tool_frame_{tool_frame}'
    body.add_site(name=name)
    return name


def load_arm_model(joint_names, torque_limits, actuator_time_constant, timestep=0.001,
                   planar=None, model_file='', tool_site='', tool_frame=''):
    """
    Compile the simulated arm and the controller's rigid model (ValueError with the reason).

    ``planar`` (a :class:`PlanarArmModel`) is used when ``model_file`` is
    empty; otherwise the file's own bodies, masses, joint properties and
    options are used, with its time step replaced by ``timestep``.
    ``tool_site`` names the site of ``tool_pose`` (built-in arm: ``tool``
    when empty; a file: none when empty); ``tool_frame`` (a file: a URDF
    link, MJCF body or site) overrides it.  A URDF ``model_file`` is read as
    by :func:`splines445_ros.robot.robot_model.load_robot_model` (fixed-joint
    links kept, unreadable meshes dropped) and simulated without contacts.
    """
    mujoco = import_mujoco()
    names = tuple(joint_names)
    if model_file:
        where = model_file_where(model_file)
        text = read_description_file(model_file, where)
        spec = _load_spec(mujoco, path=model_file, text=text)
        rigid_spec = _load_spec(mujoco, path=model_file, text=text)
        stiffness = np.zeros(len(names))
        targets = list(names)
    else:
        where = 'the built-in arm'
        planar = planar or PlanarArmModel()
        if len(names) != 3:
            raise ValueError('the built-in arm has 3 joints')
        spec = _load_spec(mujoco, xml=planar_arm_mjcf(planar, names, timestep))
        rigid = PlanarArmModel(**{**planar.__dict__, 'joint_stiffness': (0.0, 0.0, 0.0)})
        rigid_spec = _load_spec(mujoco, xml=planar_arm_mjcf(rigid, names, timestep))
        stiffness = np.array(planar.joint_stiffness, dtype=float)
        targets = [n + MOTOR_SUFFIX if k > 0.0 else n for n, k in zip(names, stiffness)]
        tool_site = tool_site or TOOL_SITE
    for s in (spec, rigid_spec):
        s.option.timestep = timestep
    if model_file and tool_frame:
        tool_site = _add_tool_frame_site(mujoco, spec, tool_frame, where)
        _add_tool_frame_site(mujoco, rigid_spec, tool_frame, where)
    # Joints first, so a missing joint is reported as such (not as a bad actuator target).
    _joint_addresses(mujoco, _compile(rigid_spec, where), names, where)
    _add_actuators(mujoco, spec, targets, torque_limits, actuator_time_constant)
    model = _compile(spec, where)
    rigid = _compile(rigid_spec, where)
    # The controller does not compensate dry friction: its sign flips at every
    # velocity reversal would put torque steps into the command.  The PD loop takes it.
    rigid.dof_frictionloss[:] = 0.0
    qpos, dof = _joint_addresses(mujoco, model, names, where)
    motor_qpos, motor_dof = _joint_addresses(mujoco, model, targets, where)
    rigid_qpos, rigid_dof = _joint_addresses(mujoco, rigid, names, where)
    actuators = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR,
                                            f'splines445_torque_{t}') for t in targets])
    site = None
    if tool_site:
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, tool_site)
        if site < 0:
            raise ValueError(f'{where} has no site {show(tool_site)} (tool_site)')
    return ArmModel(model, rigid, names, qpos, dof, motor_qpos, motor_dof, actuators,
                    rigid_qpos, rigid_dof, stiffness, site,
                    'built-in' if not model_file else model_file)
