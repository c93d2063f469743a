"""
Drives of a user's robot model: torque limits from the description, gains from its inertia.

Pure Python (numpy, MuJoCo), no rclpy.

Torque limits (:func:`model_torque_limits`), per joint, the first that exists:

1. the ``forcerange`` of an MJCF actuator on the joint (when force-limited);
2. its ``ctrlrange`` times ``|gear|`` (when control-limited: a motor's torque);
3. the joint's actuator force range: MJCF ``actuatorfrcrange``, or the URDF
   ``<limit effort>`` (MuJoCo imports it there).

Gains (:func:`inertia_gains`): each joint is treated as a second-order loop
on the diagonal of the joint-space inertia matrix at the initial pose
(``mj_fullM``; MuJoCo adds the rotor inertia, ``armature``, to that
diagonal): ``kp = I w^2`` and ``kd = 2 zeta I w`` with ``w = 2 pi
bandwidth``.  With the inverse-dynamics feed-forward of
:class:`~splines445_ros.arm.dynamic_sim.DynamicArm` the PD loop only
corrects model errors, so a moderate bandwidth (:data:`DEFAULT_BANDWIDTH`)
and critical damping (:data:`DEFAULT_DAMPING_RATIO`) are the defaults.
"""

import math

import numpy as np

from .mujoco_import import import_mujoco as _import_mujoco

DEFAULT_BANDWIDTH = 8.0       # Hz, closed-loop natural frequency of every joint
DEFAULT_DAMPING_RATIO = 1.0   # critical


def model_torque_limits(model, joint_ids, joint_names, needed=None):
    """
    Return torque limits (n,) and their sources; ValueError naming a joint without.

    Joints where ``needed`` (n,) is False are skipped (NaN, source '').
    """
    mj = _import_mujoco()
    limits, sources = [], []
    needed = [True] * len(joint_names) if needed is None else needed
    for jid, name, need in zip(joint_ids, joint_names, needed):
        if not need:
            limits.append(math.nan)
            sources.append('')
            continue
        found = None
        for a in range(model.nu):
            if (int(model.actuator_trntype[a]) != int(mj.mjtTrn.mjTRN_JOINT)
                    or int(model.actuator_trnid[a, 0]) != jid):
                continue
            if model.actuator_forcelimited[a]:
                found = (float(np.max(np.abs(model.actuator_forcerange[a]))), 'forcerange')
            elif model.actuator_ctrllimited[a]:
                gear = abs(float(model.actuator_gear[a, 0]))
                found = (float(np.max(np.abs(model.actuator_ctrlrange[a]))) * gear,
                         'ctrlrange x gear')
            if found is not None:
                break
        if found is None and model.jnt_actfrclimited[jid]:
            found = (float(np.max(np.abs(model.jnt_actfrcrange[jid]))), 'effort')
        if found is None or not math.isfinite(found[0]) or found[0] <= 0.0:
            raise ValueError(f'joint {name!r} has no torque limit in the model (no actuator '
                             'forcerange or ctrlrange, no URDF effort or actuatorfrcrange): '
                             'set torque_limits')
        limits.append(found[0])
        sources.append(found[1])
    return np.array(limits), tuple(sources)


def inertia_gains(model, qpos_addresses, dof_addresses, positions,
                  bandwidth=DEFAULT_BANDWIDTH, damping_ratio=DEFAULT_DAMPING_RATIO):
    """Return kp, kd (n,) and the joint inertias (n,) at ``positions`` (the rest at qpos0)."""
    mj = _import_mujoco()
    data = mj.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[np.asarray(qpos_addresses, dtype=int)] = positions
    mj.mj_forward(model, data)
    full = np.zeros((model.nv, model.nv))
    mj.mj_fullM(model, data, full)  # MuJoCo 4 signature (m, d, dst)
    dofs = np.asarray(dof_addresses, dtype=int)
    inertia = full[dofs, dofs]
    omega = 2.0 * math.pi * bandwidth
    return inertia * omega ** 2, 2.0 * damping_ratio * inertia * omega, inertia
