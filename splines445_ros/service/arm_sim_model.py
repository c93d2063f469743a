"""
arm_sim_node with a user's ``model_file`` (URDF or MJCF): what the model itself says (no rclpy).

:func:`resolve_model_config` turns a config whose per-joint values are unset
(see :meth:`ArmSimConfig.from_model`) into the *effective* config the node
runs with:

* ``joint_names`` ``['']``: every actuated joint of the model, in its order;
* ``initial_positions``: the model's ``home`` keyframe, else its reference
  pose moved into the joint ranges;
* ``torque_limits``: the model's (MJCF actuator ``forcerange``, or
  ``ctrlrange`` x gear; URDF ``effort``), see
  :func:`~splines445_ros.robot.torque_limits.model_torque_limits`;
* ``kp``, ``kd``: from the joint-space inertia at the initial pose, for
  ``control_bandwidth`` [Hz] and ``control_damping_ratio``, see
  :func:`~splines445_ros.sim.model_drives.inertia_gains`.

Explicit values (non-zero entries) override, joint by joint.

:func:`add_payload` merges ``payload_*`` into the body of the tool frame of
a compiled simulated arm, both the simulated model and the controller's
(the gains above are then those of the arm with its payload).
"""

from dataclasses import replace

import numpy as np

from ..robot import rotations as rot
from ..robot.dynamics import add_rigid_mass, payload_inertia_matrix
from ..robot.mujoco_import import import_mujoco
from ..robot.robot_model import load_robot_model, model_file_where
from ..robot.torque_limits import model_torque_limits
from ..robot.user_text import show_names
from ..sim.model_drives import inertia_gains
from ..sim.mujoco_model import load_arm_model


def add_payload(arm, config):
    """
    Merge ``config``'s payload into the tool frame's body of ``arm`` (an ArmModel; ValueError).

    The payload (``payload_mass`` [kg], ``payload_center_of_mass`` [m] and
    ``payload_inertia`` [kg m^2] about it, in the tool frame) is rigidly
    held by the tool frame, the site of ``tool_pose`` (built-in arm: the
    ``tool`` site on joint 3; a model file: ``tool_frame`` or
    ``tool_site``), as :class:`~splines445_ros.robot.dynamics.ArmDynamics`
    holds the planner's.  It goes into the simulated model and into the
    controller's rigid model (its inverse-dynamics feed-forward knows the
    payload, as a real arm's controller is told it).  No payload: nothing
    changes.
    """
    if config.payload_mass <= 0.0:
        return
    mujoco = import_mujoco()
    if arm.tool_site is None:
        raise ValueError(f'payload_mass = {config.payload_mass:g} kg needs the frame that '
                         'holds it: set tool_frame (a link, body or site of model_file) or '
                         'tool_site')
    site_name = mujoco.mj_id2name(arm.model, mujoco.mjtObj.mjOBJ_SITE, arm.tool_site)
    center = np.array(config.payload_center_of_mass, dtype=float)
    inertia = payload_inertia_matrix(config.payload_inertia or None)
    for model in (arm.model, arm.rigid):
        site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, site_name)
        if site < 0:
            raise ValueError(f'the controller model of {arm.source} has no site '
                             f'{site_name!r} to hold the payload')
        turn = rot.to_matrix(np.array(model.site_quat[site], dtype=float))
        add_rigid_mass(model, int(model.site_bodyid[site]), config.payload_mass,
                       model.site_pos[site] + turn @ center, turn @ inertia @ turn.T)
        mujoco.mj_setConst(model, mujoco.MjData(model))


def _merge(explicit, from_model, use_model):
    if use_model:
        return np.asarray(from_model, dtype=float)
    explicit = np.asarray(explicit, dtype=float)
    return np.where(explicit > 0.0, explicit, from_model)


def resolve_model_config(config):
    """
    Return ``(effective config, sources)`` of a config with ``model_file`` (ValueError).

    ``sources`` maps 'torque_limits', 'kp' and 'kd' to a short text saying
    where the values came from, for the log.  The gains are those of the
    arm with its payload.
    """
    robot = load_robot_model(config.model_file)
    where = model_file_where(config.model_file)
    if config.all_model_joints:
        joints = robot.joints
        if not joints:
            raise ValueError(f'{where} has no actuated (hinge or slide) joints')
    else:
        known = {j.name: j for j in robot.joints}
        missing = [n for n in config.joint_names if n not in known]
        if missing:
            raise ValueError(f'{where} has no joint(s) {show_names(missing)} (joint_names); its '
                             f'joints: {show_names(known)}')
        joints = tuple(known[n] for n in config.joint_names)
    names = tuple(j.name for j in joints)
    n = len(names)
    for name in ('initial_positions', 'torque_limits', 'kp', 'kd'):
        values = getattr(config, name)
        if not config.from_model(name) and len(values) != n:
            raise ValueError(f'{name} must be {n} values (one per joint of {show_names(names)}), '
                             f'got {list(values)}')
    initial = (robot.default_seed(joints) if config.from_model('initial_positions')
               else np.asarray(config.initial_positions, dtype=float))
    sources = {}
    explicit_torque = np.asarray(config.torque_limits if not config.from_model('torque_limits')
                                 else np.zeros(n), dtype=float)
    if np.all(explicit_torque > 0.0):
        torque = explicit_torque
        sources['torque_limits'] = 'parameter'
    else:
        from_model, kinds = model_torque_limits(
            robot.model, [j.joint_id for j in joints], names, explicit_torque <= 0.0)
        torque = np.where(explicit_torque > 0.0, explicit_torque, from_model)
        sources['torque_limits'] = ', '.join(
            f'{name}: {"parameter" if e > 0.0 else kind}'
            for name, e, kind in zip(names, explicit_torque, kinds))
    kp = kd = None
    if config.dynamic:
        arm = load_arm_model(names, torque, config.actuator_time_constant, config.timestep,
                             model_file=config.model_file, tool_site=config.tool_site,
                             tool_frame=config.tool_frame)
        add_payload(arm, config)
        gain_p, gain_d, inertia = inertia_gains(
            arm.rigid, arm.rigid_qpos, arm.rigid_dof, initial, config.control_bandwidth,
            config.control_damping_ratio)
        kp = _merge(config.kp, gain_p, config.from_model('kp'))
        kd = _merge(config.kd, gain_d, config.from_model('kd'))
        damping = arm.rigid.dof_damping[arm.rigid_dof]
        sources['gains'] = (f'inertia {", ".join(f"{v:.4g}" for v in inertia)} kg m^2 at the '
                            f'initial pose, {config.control_bandwidth:g} Hz, damping ratio '
                            f'{config.control_damping_ratio:g}, joint damping '
                            f'{", ".join(f"{v:.4g}" for v in damping)} N m s/rad (kp raised '
                            'where it would slow the loop; explicit non-zero kp, kd kept)')
        friction = arm.model.dof_frictionloss[arm.dof]
        if np.any(friction > 0.0):
            sources['dry friction'] = (f'frictionloss {", ".join(f"{v:.4g}" for v in friction)} '
                                       'N m, compensated by the controller')
    effective = replace(
        config, joint_names=names, initial_positions=tuple(float(v) for v in initial),
        frame_id=config.frame_id or robot.root_link or 'world',
        torque_limits=tuple(float(v) for v in torque),
        kp=tuple(float(v) for v in (kp if kp is not None else np.zeros(n))),
        kd=tuple(float(v) for v in (kd if kd is not None else np.zeros(n))))
    return effective, sources
