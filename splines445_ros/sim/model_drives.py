"""
Drives of a user's robot model: gains from its inertia.

Pure Python (numpy, MuJoCo), no rclpy.  The drives' torque limits come from
the description as the planner reads them:
:func:`~splines445_ros.robot.torque_limits.model_torque_limits`.

Gains (:func:`inertia_gains`): each joint is treated as a second-order loop
on the diagonal of the joint-space inertia matrix at the initial pose
(``mj_fullM``; MuJoCo adds the rotor inertia, ``armature``, to that
diagonal): ``kp = I w^2`` and ``kd = 2 zeta I w`` with ``w = 2 pi
bandwidth``.  With the inverse-dynamics feed-forward of
:class:`~splines445_ros.sim.dynamic_sim.DynamicArm` the PD loop only
corrects model errors, so a moderate bandwidth (:data:`DEFAULT_BANDWIDTH`)
and critical damping (:data:`DEFAULT_DAMPING_RATIO`) are the defaults.

The joint's own viscous damping ``c`` (the description's ``damping``,
``dof_damping``) adds to ``kd`` in the loop ``I s^2 + (kd + c) s + kp``.
On a light joint with much damping (a wrist) that loop creeps back from
an error with the slow mode ``kp / (kd + c)``, far below the bandwidth
(xArm7 joint 7: 0.18 rad/s, a time constant of 6 s).  So ``kp`` is
raised where needed until the slowest mode is at least
:data:`SLOWEST_MODE_FRACTION` of the design's slowest decay rate ``p0``
(``w (zeta - sqrt(zeta^2 - 1))`` when ``zeta >= 1``, ``zeta w`` below)::

    p  = SLOWEST_MODE_FRACTION * p0
    kp = max(I w^2, (kd + c) p - I p^2)

The second term is the ``kp`` whose slower root is exactly ``p``; without
damping it is below ``I w^2``, so joints whose damping is a small part of
the loop's keep the inertia gains.  The raised ``kp`` does not make the
loop faster than designed (its slow mode is ``p < w``; its fast mode
``(kd + c) / I - p`` is the damping's, which MuJoCo integrates
implicitly), so the physics step carries it as it carries ``I w^2``.
Dry friction is not a matter of gains (``kp`` would have to exceed
friction / dead band, thousands of N m/rad on a wrist of 1e-4 kg m^2):
:class:`~splines445_ros.sim.dynamic_sim.DynamicArm` compensates it.
"""

import math

import numpy as np

from ..robot.mujoco_import import import_mujoco as _import_mujoco

DEFAULT_BANDWIDTH = 8.0       # Hz, closed-loop natural frequency of every joint
DEFAULT_DAMPING_RATIO = 1.0   # critical
# The joint's own damping may slow the loop's slowest mode to this fraction of the design's.
SLOWEST_MODE_FRACTION = 0.5


def slowest_decay_rate(bandwidth, damping_ratio):
    """Return the slowest decay rate [1/s] of the designed loop ``s^2 + 2 zeta w s + w^2``."""
    omega = 2.0 * math.pi * bandwidth
    if damping_ratio >= 1.0:
        return omega * (damping_ratio - math.sqrt(damping_ratio ** 2 - 1.0))
    return damping_ratio * omega


def inertia_gains(model, qpos_addresses, dof_addresses, positions,
                  bandwidth=DEFAULT_BANDWIDTH, damping_ratio=DEFAULT_DAMPING_RATIO):
    """
    Return kp, kd (n,) and the joint inertias (n,) at ``positions`` (the rest at qpos0).

    ``kp`` is raised above ``I w^2`` on joints whose own damping
    (``model.dof_damping``) would slow the loop (see the module docstring).
    """
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
    kd = 2.0 * damping_ratio * inertia * omega
    rate = SLOWEST_MODE_FRACTION * slowest_decay_rate(bandwidth, damping_ratio)
    total_damping = kd + model.dof_damping[dofs]
    kp = np.maximum(inertia * omega ** 2, total_damping * rate - inertia * rate ** 2)
    return kp, kd, inertia
