"""
Torque limits from a robot's description: one reader, for the planner and the simulated arm.

Pure Python (numpy, MuJoCo), no rclpy.  :func:`joint_torque_limit` reads
the limit of one joint of a compiled MuJoCo model, the first that exists:

1. the ``forcerange`` of an MJCF actuator on the joint (when force-limited);
2. its ``ctrlrange`` times ``|gear|`` (when control-limited: a motor's torque);
3. the joint's actuator force range: MJCF ``actuatorfrcrange``, or the URDF
   ``<limit effort>`` (MuJoCo imports it there).

Its callers say what a joint without a limit means:
:func:`effort_limits` (the torque constraint of the planner, with
:class:`~splines445_ros.robot.dynamics.ArmDynamics`) raises or gives
``inf``; :func:`model_torque_limits` (the simulated arm's drives) raises,
naming the ``torque_limits`` parameter.
"""

import math

import numpy as np

from .mujoco_import import import_mujoco
from .user_text import show

# Where a limit was found, as :func:`joint_torque_limit` names it.
FORCERANGE = 'forcerange'
CTRLRANGE = 'ctrlrange x gear'
EFFORT = 'effort'


def joint_torque_limit(model, joint_id):
    """
    Return (limit [N m or N], source) of joint ``joint_id`` of ``model``, or None without one.

    ``source`` is :data:`FORCERANGE`, :data:`CTRLRANGE` or :data:`EFFORT`
    (see the module docstring for the order).  The first of them that the
    joint has decides: a limit there that is 0, negative or not finite is
    no limit (None), whatever the others say.
    """
    mj = import_mujoco()
    found = None
    for a in range(model.nu):
        if (int(model.actuator_trntype[a]) != int(mj.mjtTrn.mjTRN_JOINT)
                or int(model.actuator_trnid[a, 0]) != joint_id):
            continue
        if model.actuator_forcelimited[a]:
            found = (float(np.max(np.abs(model.actuator_forcerange[a]))), FORCERANGE)
        elif model.actuator_ctrllimited[a]:
            gear = abs(float(model.actuator_gear[a, 0]))
            found = (float(np.max(np.abs(model.actuator_ctrlrange[a]))) * gear, CTRLRANGE)
        if found is not None:
            break
    if found is None and model.jnt_actfrclimited[joint_id]:
        found = (float(np.max(np.abs(model.jnt_actfrcrange[joint_id]))), EFFORT)
    if found is None or not math.isfinite(found[0]) or found[0] <= 0.0:
        return None
    return found


def model_torque_limits(model, joint_ids, joint_names, needed=None):
    """
    Return torque limits (n,) and their sources; ValueError naming a joint without.

    The simulated arm's drives: per joint :func:`joint_torque_limit`.
    Joints where ``needed`` (n,) is False are skipped (NaN, source '').
    """
    limits, sources = [], []
    needed = [True] * len(joint_names) if needed is None else needed
    for jid, name, need in zip(joint_ids, joint_names, needed):
        if not need:
            limits.append(math.nan)
            sources.append('')
            continue
        found = joint_torque_limit(model, jid)
        if found is None:
            raise ValueError(f'joint {name!r} has no torque limit in the model (no actuator '
                             'forcerange or ctrlrange, no URDF effort or actuatorfrcrange): '
                             'set torque_limits')
        limits.append(found[0])
        sources.append(found[1])
    return np.array(limits), tuple(sources)


def effort_limits(robot, joint_names=(), missing='raise'):
    """
    Return the torque limits (n,) [N m or N] of ``joint_names`` from the description.

    The limits of the torque constraint, read as the simulated arm reads
    them (:func:`joint_torque_limit`), per joint the first that exists: an
    MJCF actuator's ``forcerange``, its ``ctrlrange`` times ``|gear|``, the
    joint's ``actuatorfrcrange`` (a URDF ``<limit effort>``).
    ``joint_names`` empty: every actuated joint of ``robot`` (a
    :class:`~splines445_ros.robot.robot_model.RobotModel`).  A joint without
    a limit raises a ValueError naming it (``missing='raise'``) or gets
    ``inf`` (``missing='inf'``).
    """
    if missing not in ('raise', 'inf'):
        raise ValueError(f"missing must be 'raise' or 'inf', not {show(missing)}")
    joints = robot.select(tuple(joint_names))
    limits = np.empty(len(joints))
    for i, joint in enumerate(joints):
        found = joint_torque_limit(robot.model, joint.joint_id)
        if found is None:
            if missing == 'inf':
                limits[i] = math.inf
                continue
            raise ValueError(
                f'joint {show(joint.name)} of {robot.describe()} has no torque limit (no '
                'actuator forcerange or ctrlrange, no URDF <limit effort>, no MJCF '
                'actuatorfrcrange)')
        limits[i] = found[0]
    return limits
