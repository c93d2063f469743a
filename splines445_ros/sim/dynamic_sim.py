"""
The dynamic arm: MuJoCo physics with a joint controller (pure Python, no rclpy).

Control law, every physics step, for each driven joint::

    tau_ff  = inverse dynamics of the rigid model at (q_d, v_d, a_d)   (mujoco.mj_inverse)
    theta_d = q_d + (tau_ff - armature * a_d - damping * v_d) / k      (elastic joints;
              the motor leads the link by the spring's deflection; q_d when rigid)
    tau_f   = f tanh(v_d / v_f + (theta_d - theta) / e_f)             (dry friction)
    tau     = clip(tau_ff + tau_f + C (kp (theta_d - theta) + kd (v_d - omega)), -limit, limit)
    C       = M(q_d) diag(M_0)^-1       (a model file; the built-in arm: the identity)

where theta, omega are the driven (motor) joint's position and velocity (the
link's when rigid).  ``tau`` is the actuator's control; the actuator follows
it with a first-order lag (MuJoCo ``filterexact`` dynamics), so the applied
torque (``effort``) lags the command.  MuJoCo integrates everything (the
model's integrator): there is no integrator here.

**Decoupling.**  The gains are per joint, designed on the joint's own
inertia ``I_j``, the diagonal of the joint-space inertia matrix ``M_0`` at
the initial pose (:mod:`~splines445_ros.sim.model_drives`).  A plain
per-joint loop ``kp e + kd e'`` runs at that bandwidth only there.  Coupled
joints can feel far less: the inertia a joint feels is ``1 / (M^-1)_jj``,
on a Panda with joint 2 near 0 (shoulder joints 1 and 3 aligned) 0.04 of the
diagonal; and the diagonal itself changes with the pose (a Kinova's first
joint: 0.022 kg m^2 folded, 0.24 at the ready pose).  There the loop runs
several times faster than designed, beyond what the 1 kHz step and the 2 ms
lag carry: the dynamic Panda shook at rest at up to 5.7 rad/s at 5 of 9
random poses, a UR5 and a Kinova at one each.  ``C`` maps the per-joint
corrections through the inertia matrix at the commanded pose (from the same
``mj_inverse`` as ``tau_ff``), so the error dynamics are
``e'' = -diag(M_0)^-1 (kp e + kd e')``: every joint at its designed
bandwidth at every pose, whatever the coupling (the computed-torque law,
with the per-joint gains kept).  At the initial pose of an arm whose
inertia matrix is diagonal ``C`` is the identity: the plain per-joint loop.
An elastic joint's motor is a rotor of its own, coupled only through its
spring: its row and column of ``C`` are the identity's.  On a step where the
decoupled command exceeds a limit, the command is the one within the limits
nearest to it in the inertia's norm (:meth:`DynamicArm.decoupled_command`):
joints at a limit give it, every other joint gets its own loop's
acceleration.  Clipped alone, the others would chase the saturated joint's
error (an xArm7 on a plan that left out its joints' damping: a saturated
joint 3 pulled joint 6 29 mrad off), and leaving the saturated joint's terms
out of theirs made a coupled pair's commands jump between their limits from
step to step (helper-82, helper-83).

The built-in arm keeps the plain per-joint loop (``C`` the identity), as it
keeps its friction uncompensated: its gains are set by hand for its large
rotor inertias (10, 4, 0.1 kg m^2, as large as its links'), it is stable
there, and its figures and tests are those of that loop (decoupled, the
friction that its light tool joint's loop holds would be carried into the
shoulder's: 0.72 mrad of error on a slow move where the plain loop keeps
0.31).

**Dry friction.**  The rigid model leaves the joints' ``frictionloss`` ``f``
out (its exact sign would step the command at every reversal); ``tau_f``
puts it back, smoothed.  MuJoCo's friction is a soft constraint: below the
sliding speed ``s = f R / B`` of its constraint row (regulariser ``efc_R``,
reference damping ``efc_KBIP[1]``; see :func:`dry_friction`) it acts as a
viscous damper ``beta = B / R``, above it as Coulomb's ``f``.  On a heavy
joint ``s`` is a few mrad/s: a PD loop alone stops ``f / kp`` short and
creeps on at ``kp / (beta + kd + c)`` (xArm7 joint 2: 1 mrad, 3 /s).  On a
light wrist ``s`` is several rad/s (xArm7 joint 7: 7.7 rad/s): its friction
is a damper.  So the smoothing follows the model:

* ``v_f = max(FRICTION_VELOCITY, s)``: while the reference moves, the
  commanded velocity sets the compensation, never steeper than MuJoCo's own
  friction (no torque step at reversals, no over-compensation of a soft one);
* ``e_f = s / FRICTION_RATE``: at rest, the position error does.  Where
  ``|tau_f| < f`` the joint creeps at about ``tau_f / beta``, so the error
  closes at up to ``FRICTION_RATE`` (``f / e_f = beta * FRICTION_RATE``): a
  joint that stopped short in its friction is pushed on at a rate the physics
  step and the actuator lag carry, whatever its inertia, and eases in
  without overshoot.  A sharper error term (a fixed small ``e_f``) makes a light
  wrist hunt around the goal.

By default a user's model file is compensated (the description's friction is
the file's); the built-in arm is not: its figures and tests are those of the
plain PD loop with stiff gains (dead band ``friction / kp``).

:class:`TrackingMetrics` accumulates the tracking and effort figures that
``arm_sim_node`` reports at the end of each trajectory and the benchmark
tabulates.
"""

import numpy as np

from ..robot.mujoco_import import import_mujoco as _import_mujoco

# Commanded velocity [rad/s or m/s] at which 76 % of the dry friction is compensated
# (more where MuJoCo's friction is softer: see the module docstring).
FRICTION_VELOCITY = 0.02
# Rate [1/s] at which the position error alone moves a joint at rest through its friction.
FRICTION_RATE = 50.0


def dry_friction(mujoco, model, dofs):
    """
    Return MuJoCo's dry friction (n,) on ``dofs`` and the speed (n,) where it is reached.

    ``frictionloss`` is a soft constraint: below the speed ``f R / B`` it acts
    as a viscous damper ``B / R`` (the constraint row's reference damping
    ``efc_KBIP[1]`` over its regulariser ``efc_R``, both fixed by the model).
    A dof without a friction row (none, or disabled) has friction 0.
    """
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    friction = np.zeros(len(dofs))
    speed = np.full(len(dofs), np.inf)
    where = {int(dof): j for j, dof in enumerate(dofs)}
    kind = int(mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF)
    for row in range(data.nefc):
        j = where.get(int(data.efc_id[row]))
        if int(data.efc_type[row]) != kind or j is None:
            continue
        friction[j] = model.dof_frictionloss[dofs[j]]
        damping = data.efc_KBIP[row, 1]
        if damping > 0.0:
            speed[j] = friction[j] * data.efc_R[row] / damping
    return friction, speed


# MuJoCo's warnings of a simulation gone unstable: it resets its state to the
# model's reference pose and goes on, which the arm must not pass off as motion.
UNSTABLE_WARNINGS = ('mjWARN_BADQPOS', 'mjWARN_BADQVEL', 'mjWARN_BADQACC', 'mjWARN_BADCTRL')
# ... and a state beyond what any trajectory commands (playback.MAX_MAGNITUDE) or not finite.
MAX_STATE = 1e6


def _nearest_within(inertia, command, limits):
    """
    Return the torque within ``+-limits`` nearest to ``command`` in the norm of ``inertia^-1``.

    ``(tau - command)^T inertia^-1 (tau - command)`` as a bounded least-squares
    problem (scipy's BVLS, exact for these few joints); the clipped command where
    the inertia is not positive definite or the solve fails.
    """
    clipped = np.clip(command, -limits, limits)
    try:
        from scipy.optimize import lsq_linear
        weight = np.linalg.cholesky(np.linalg.inv(inertia)).T     # weight^T weight = A^-1
        with np.errstate(all='ignore'):
            target = weight @ command
        found = lsq_linear(weight, target, bounds=(-limits, limits), method='bvls', tol=1e-12)
    except (np.linalg.LinAlgError, ValueError):
        return clipped
    if not found.success or not np.all(np.isfinite(found.x)):
        return clipped
    return np.clip(found.x, -limits, limits)


class UnstableSimulation(ValueError):
    """The physics went unstable during a run; the arm is back at its state before it."""


class DynamicArm:
    """One simulated arm with its controller; ``run`` steps it along reference arrays."""

    def __init__(self, arm_model, kp, kd, torque_limits, compensate_friction=None,
                 decouple=None, design_pose=None):
        """
        Create MuJoCo data for ``arm_model`` (:class:`ArmModel`) with PD gains (n,).

        ``compensate_friction``: put the driven joints' dry friction
        (``frictionloss``) into the command; ``decouple``: map the PD terms
        through ``C`` (see the module docstring); None, for both: for a model
        file, not for the built-in arm.  ``design_pose``: the pose (n,) whose
        inertia diagonal ``M_0`` the gains were designed on (the initial
        pose); None: the pose of the first :meth:`reset` or :meth:`set_state`.
        """
        self.mujoco = _import_mujoco()
        self.arm = arm_model
        self.model = arm_model.model
        self.data = self.mujoco.MjData(self.model)
        self._unstable_warnings = [int(getattr(self.mujoco.mjtWarning, name))
                                   for name in UNSTABLE_WARNINGS]
        self.rigid_data = self.mujoco.MjData(arm_model.rigid)
        self.kp = np.asarray(kp, dtype=float)
        self.kd = np.asarray(kd, dtype=float)
        self.limits = np.asarray(torque_limits, dtype=float)
        if compensate_friction is None:
            compensate_friction = arm_model.source != 'built-in'
        #: Whether the PD terms go through ``C = M diag(M_0)^-1`` (else the identity).
        self.decouple = arm_model.source != 'built-in' if decouple is None else bool(decouple)
        friction, speed = dry_friction(self.mujoco, self.model, arm_model.motor_dof)
        #: Dry friction (n,) put into the command [N m or N]; 0 = none.
        self.friction = friction if compensate_friction else np.zeros_like(friction)
        self._friction_v = np.maximum(FRICTION_VELOCITY, speed)
        self._friction_e = np.maximum(speed / FRICTION_RATE, 1e-12)
        rigid = arm_model.rigid
        self._armature = rigid.dof_armature[arm_model.rigid_dof].copy()
        self._damping = rigid.dof_damping[arm_model.rigid_dof].copy()
        self._elastic = arm_model.stiffness > 0.0
        safe = np.where(self._elastic, arm_model.stiffness, 1.0)
        self._inverse_k = np.where(self._elastic, 1.0 / safe, 0.0)
        self._same_layout = (self.model.nq == rigid.nq and self.model.nv == rigid.nv)
        self._act_adr = self.model.actuator_actadr[arm_model.actuators]
        self._full_inertia = np.zeros((rigid.nv, rigid.nv))
        self._design_inertia = None
        if design_pose is not None:
            self._design_inertia = self._inertia_diagonal(design_pose)
        rigid_site = None
        if arm_model.tool_site is not None:
            name = self.mujoco.mj_id2name(self.model, self.mujoco.mjtObj.mjOBJ_SITE,
                                          arm_model.tool_site)
            rigid_site = self.mujoco.mj_name2id(rigid, self.mujoco.mjtObj.mjOBJ_SITE, name)
        self._rigid_site = rigid_site if rigid_site is not None and rigid_site >= 0 else None
        self.time = 0.0

    @property
    def n_joints(self):
        """Return the number of driven joints."""
        return len(self.arm.joint_names)

    @property
    def timestep(self):
        """Return the physics time step [s]."""
        return self.arm.timestep

    def feedforward(self, q_d, v_d, a_d):
        """Return the inverse-dynamics torque (n,) of the rigid model at a commanded state."""
        mj, rd, arm = self.mujoco, self.rigid_data, self.arm
        if self._same_layout:
            rd.qpos[:] = self.data.qpos
            rd.qvel[:] = self.data.qvel
        rd.qacc[:] = 0.0
        rd.qpos[arm.rigid_qpos] = q_d
        rd.qvel[arm.rigid_dof] = v_d
        rd.qacc[arm.rigid_dof] = a_d
        mj.mj_inverse(arm.rigid, rd)
        return rd.qfrc_inverse[arm.rigid_dof].copy()

    def _inertia_matrix(self):
        """Return the driven joints' block (n, n) of the rigid model's inertia matrix now."""
        arm, full = self.arm, self._full_inertia
        self.mujoco.mj_fullM(arm.rigid, self.rigid_data, full)
        dofs = arm.rigid_dof
        return full[np.ix_(dofs, dofs)]

    def _inertia_diagonal(self, pose):
        """Return the inertia diagonal (n,) at a pose of the driven joints."""
        pose = np.asarray(pose, dtype=float)
        self.feedforward(pose, np.zeros_like(pose), np.zeros_like(pose))
        return np.diag(self._inertia_matrix()).copy()

    def _default_design(self, pose):
        """Take ``pose`` as the design pose when none was given (the first reset or run)."""
        if self.decouple and self._design_inertia is None:
            self._design_inertia = self._inertia_diagonal(pose)

    def coupling(self):
        """
        Return ``C = M diag(M_0)^-1`` (n, n) at the pose of the last :meth:`feedforward`.

        ``M`` is the driven joints' block of the rigid model's inertia matrix
        (MuJoCo computed it in ``mj_inverse``), ``M_0`` the one at the
        design pose; an elastic joint's row and column are the identity's;
        without :attr:`decouple`, the identity.
        """
        if not self.decouple:
            return np.eye(self.n_joints)
        coupling = self._inertia_matrix() / self._design_inertia[None, :]
        if np.any(self._elastic):
            elastic = self._elastic
            coupling[elastic, :] = 0.0
            coupling[:, elastic] = 0.0
            coupling[elastic, elastic] = 1.0
        return coupling

    def decoupled_command(self, forward, feedback):
        """
        Return the decoupled command (n,) and whether it saturated: ``forward + C feedback``.

        Written as ``forward + A u`` with ``A = C diag(M_0)`` (the inertia matrix ``M``
        at the commanded pose, its elastic rows and columns the identity's) and
        ``u = feedback / diag(M_0)`` the acceleration each joint's loop asks for.
        Where that exceeds a limit, the command is the one within the limits whose
        accelerations ``x = A^-1 (tau - forward)`` come nearest to ``u`` in the inertia's
        norm, ``(x - u)^T A (x - u)`` (a small box-constrained problem, solved by active
        sets): the joints at a limit give it, and every other joint gets exactly its own
        loop's acceleration, ``tau_F = forward_F + A_FF u_F + A_FS x_S`` with
        ``x_S = A_SS^-1 (tau_S - forward_S - A_SF u_F)``.  A joint at a limit is let go
        when that gives it more acceleration than its loop asks (``(x_j - u_j)`` of its
        limit's sign), a free joint over its limit is held at it, one at a time.  So no
        joint chases a saturated one, and coupled joints at their limits do not push
        each other the wrong way.  Those steps can cycle on an ill-conditioned inertia
        (helper-84: about once in 13,000 random cases of condition 1.5e3-2.5e3; a
        Kinova reaches 2e4): after ``4 n`` of them the problem is solved as a bounded
        least-squares one (scipy's BVLS, ``||R (tau - tau*)||`` with ``R^T R = A^-1``).
        """
        limits = self.limits
        design = self._design_inertia
        inertia = self.coupling() * design[None, :]
        wanted = feedback / design
        command = np.nan_to_num(forward + inertia @ wanted, nan=0.0, posinf=1e300,
                                neginf=-1e300)
        if not np.any(np.abs(command) > limits):
            return command, False
        n = len(command)
        held = np.zeros(n)              # -1 / +1 at the lower / upper limit, 0 free
        over = np.abs(command) / limits
        first = int(np.argmax(over))
        held[first] = np.sign(command[first])
        for _ in range(4 * n):
            at = held != 0.0
            free = ~at
            tau = np.where(at, held * limits, 0.0)
            try:
                fixed = tau[at] - forward[at] - inertia[np.ix_(at, free)] @ wanted[free]
                moved = np.linalg.solve(inertia[np.ix_(at, at)], fixed)
            except np.linalg.LinAlgError:
                break
            tau[free] = (forward[free] + inertia[np.ix_(free, free)] @ wanted[free]
                         + inertia[np.ix_(free, at)] @ moved)
            if not np.all(np.isfinite(tau)):
                break
            ratio = np.where(free, np.abs(tau) / limits, 0.0)
            if np.max(ratio) > 1.0:
                j = int(np.argmax(ratio))
                held[j] = np.sign(tau[j])
                continue
            # A held joint let go where its limit gives it more than its loop asks.
            push = np.zeros(n)
            push[at] = held[at] * (moved - wanted[at])
            if np.max(push) > 0.0:
                held[int(np.argmax(push))] = 0.0
                continue
            return tau, True
        return _nearest_within(inertia, command, limits), True

    def friction_compensation(self, v_d, error):
        """Return ``tau_f`` (n,) at a commanded velocity and position error (motor side)."""
        return self.friction * np.tanh(v_d / self._friction_v + error / self._friction_e)

    def reset(self, positions, velocities=None, accelerations=None):
        """Put the arm at ``positions`` (moving when given), springs and actuators in balance."""
        mj, d, arm = self.mujoco, self.data, self.arm
        q = np.asarray(positions, dtype=float)
        v = np.zeros_like(q) if velocities is None else np.asarray(velocities, dtype=float)
        a = np.zeros_like(q) if accelerations is None else np.asarray(accelerations, dtype=float)
        self._default_design(q)
        mj.mj_resetData(self.model, d)
        d.qpos[arm.qpos] = q
        d.qvel[arm.dof] = v
        tau = self.feedforward(q, v, a)
        if np.any(self._elastic):
            link = tau - self._armature * a - self._damping * v
            d.qpos[arm.motor_qpos[self._elastic]] = (q + link * self._inverse_k)[self._elastic]
            d.qvel[arm.motor_dof[self._elastic]] = v[self._elastic]
        tau = np.clip(tau + self.friction_compensation(v, 0.0), -self.limits, self.limits)
        d.ctrl[arm.actuators] = tau
        valid = self._act_adr >= 0
        d.act[self._act_adr[valid]] = tau[valid]
        mj.mj_forward(self.model, d)
        self.time = 0.0

    def set_state(self, positions, velocities):
        """Reset to a measured state (after a model change), keeping the clock."""
        time = self.time
        self.reset(positions, velocities)
        self.time = time

    def positions(self):
        """Return where the links are now (n,) [rad or m]."""
        return self.data.qpos[self.arm.qpos].copy()

    def velocities(self):
        """Return how fast the links move now (n,)."""
        return self.data.qvel[self.arm.dof].copy()

    def efforts(self):
        """Return the applied actuator torques (n,) of the last step."""
        return self.data.actuator_force[self.arm.actuators].copy()

    def tool_pose(self):
        """Return the tool site position (3,) and rotation (3, 3); None without a tool site."""
        site = self.arm.tool_site
        if site is None:
            return None
        mj, d = self.mujoco, self.data
        mj.mj_kinematics(self.model, d)
        return d.site_xpos[site].copy(), d.site_xmat[site].reshape(3, 3).copy()

    def run(self, q_d, v_d, a_d):
        """
        Step once per row of the reference arrays (K, n); return the step log.

        The log (dict of arrays) has, per step: ``position`` and ``velocity``
        (K, n) measured at the start of the step (when the reference row
        applies), ``command`` (the controller's torque), ``effort`` (the
        applied torque during the step), ``saturated`` (K,) bool, and
        ``tool_error`` (K,) [m] when the model has a tool site.
        :class:`UnstableSimulation` (the state put back as it was before
        the run) when MuJoCo warns of a bad position, velocity, acceleration
        or control, or the state is not finite or beyond :data:`MAX_STATE`.
        """
        mj, m, d, arm = self.mujoco, self.model, self.data, self.arm
        K, n = q_d.shape
        before = self.positions(), self.velocities()
        self._default_design(before[0])     # run before any reset
        warnings = self._unstable_warnings
        for w in warnings:
            d.warning[w].number = 0
        position = np.empty((K, n))
        velocity = np.empty((K, n))
        command = np.empty((K, n))
        effort = np.empty((K, n))
        saturated = np.zeros(K, dtype=bool)
        site = arm.tool_site
        tool_error = np.zeros(K) if site is not None and self._rigid_site is not None else None
        elastic = np.any(self._elastic)
        kp, kd, limits = self.kp, self.kd, self.limits
        compensate = bool(np.any(self.friction > 0.0))
        for k in range(K):
            mj.mj_step1(m, d)
            q = d.qpos[arm.qpos]
            position[k] = q
            velocity[k] = d.qvel[arm.dof]
            tau = self.feedforward(q_d[k], v_d[k], a_d[k])
            if tool_error is not None:
                tool_error[k] = np.linalg.norm(d.site_xpos[site]
                                               - self.rigid_data.site_xpos[self._rigid_site])
            if elastic:
                link = tau - self._armature * a_d[k] - self._damping * v_d[k]
                target = q_d[k] + link * self._inverse_k
            else:
                target = q_d[k]
            error = target - d.qpos[arm.motor_qpos]
            feedback = kp * error + kd * (v_d[k] - d.qvel[arm.motor_dof])
            if compensate:
                tau = tau + self.friction_compensation(v_d[k], error)
            if self.decouple:
                raw, saturated[k] = self.decoupled_command(tau, feedback)
            else:
                raw = np.nan_to_num(tau + feedback, nan=0.0, posinf=1e300, neginf=-1e300)
                saturated[k] = bool(np.any(np.abs(raw) > limits))
            tau = np.clip(raw, -limits, limits)
            command[k] = tau
            d.ctrl[arm.actuators] = tau
            mj.mj_step2(m, d)
            effort[k] = d.actuator_force[arm.actuators]
        if any(d.warning[w].number for w in warnings) or not (
                np.all(np.abs(d.qpos) <= MAX_STATE) and np.all(np.abs(d.qvel) <= MAX_STATE)):
            self.set_state(*before)
            raise UnstableSimulation(
                'the physics went unstable (MuJoCo reset its state): the gains kp, kd are '
                'too high for physics_rate, or the torque limits let the arm be thrown')
        self.time += K * self.timestep
        log = {'position': position, 'velocity': velocity, 'command': command,
               'effort': effort, 'saturated': saturated}
        if tool_error is not None:
            log['tool_error'] = tool_error
        return log


def rotation_to_quaternion(rotation):
    """Return the quaternion (w, x, y, z) of a rotation matrix (3, 3), by MuJoCo."""
    mujoco = _import_mujoco()
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(rotation, dtype=float).reshape(9))
    return tuple(float(v) for v in quat)


class TrackingMetrics:
    """Running tracking and effort figures of one trajectory, fed step log by step log."""

    def __init__(self, n_joints, timestep):
        """Start empty for ``n_joints`` joints and physics step ``timestep`` [s]."""
        self.n = n_joints
        self.dt = timestep
        self.steps = 0
        self.sum_sq = np.zeros(n_joints)
        self.max_error = np.zeros(n_joints)
        self.tool_max_error = 0.0
        self.has_tool = False
        self.peak_effort = np.zeros(n_joints)
        self.peak_effort_rate = np.zeros(n_joints)
        self.peak_command_rate = np.zeros(n_joints)
        self.max_rate_jump = np.zeros(n_joints)
        self.saturated_steps = 0
        self._last_effort = None
        self._last_command = None
        self._last_command_rate = None

    def update(self, q_d, log, timestep=None):
        """
        Add a step log of :meth:`DynamicArm.run` and its reference positions (K, n).

        ``timestep`` [s] is the physics step the log was taken at, when it is
        not the one given at construction (the physics rate can change while
        a trajectory runs); rates across the border use the new step.
        """
        if timestep is not None:
            self.dt = timestep
        K = len(q_d)
        if K == 0:
            return
        with np.errstate(over='ignore', invalid='ignore'):  # absurd references: inf
            self._update(q_d, log, K)

    def _update(self, q_d, log, K):
        error = np.abs(q_d - log['position'])
        self.steps += K
        self.sum_sq += np.sum(error ** 2, axis=0)
        self.max_error = np.maximum(self.max_error, error.max(axis=0))
        if 'tool_error' in log:
            self.has_tool = True
            self.tool_max_error = max(self.tool_max_error, float(log['tool_error'].max()))
        effort, command = log['effort'], log['command']
        self.peak_effort = np.maximum(self.peak_effort, np.abs(effort).max(axis=0))
        self.saturated_steps += int(np.count_nonzero(log['saturated']))
        if self._last_effort is not None:
            effort = np.vstack([self._last_effort, effort])
            command = np.vstack([self._last_command, command])
        self._last_effort = effort[-1:].copy()
        self._last_command = command[-1:].copy()
        if len(effort) > 1:
            self.peak_effort_rate = np.maximum(
                self.peak_effort_rate, np.abs(np.diff(effort, axis=0)).max(axis=0) / self.dt)
            rate = np.diff(command, axis=0) / self.dt
            self.peak_command_rate = np.maximum(self.peak_command_rate,
                                                np.abs(rate).max(axis=0))
            if self._last_command_rate is not None:
                rate = np.vstack([self._last_command_rate, rate])
            self._last_command_rate = rate[-1:].copy()
            if len(rate) > 1:
                self.max_rate_jump = np.maximum(self.max_rate_jump,
                                                np.abs(np.diff(rate, axis=0)).max(axis=0))

    @property
    def rms_error(self):
        """Return the RMS joint tracking error (n,) [rad]."""
        return np.sqrt(self.sum_sq / max(self.steps, 1))

    @property
    def saturated(self):
        """Return True when the torque command was clipped at any step."""
        return self.saturated_steps > 0

    def summary(self):
        """Return the figures as a dict of arrays and floats."""
        result = {'tracking_rms_error': self.rms_error, 'tracking_max_error': self.max_error,
                  'peak_effort': self.peak_effort, 'peak_effort_rate': self.peak_effort_rate,
                  'peak_command_rate': self.peak_command_rate,
                  'max_command_rate_jump': self.max_rate_jump,
                  'saturated_steps': self.saturated_steps}
        if self.has_tool:
            result['tool_max_error'] = self.tool_max_error
        return result
