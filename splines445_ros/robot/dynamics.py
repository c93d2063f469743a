"""
Rigid-body inverse dynamics of the planned joints, with a payload: the torque constraint's model.

Pure Python (numpy, MuJoCo), no rclpy.  :class:`ArmDynamics` evaluates

    tau = M(q) qdd + c(q, qd) + g(q)

for the planned joints of a :class:`~splines445_ros.robot.robot_model.RobotModel`
over many samples at once (``torques``, (N, n) in, (N, n) out), with
MuJoCo's recursive Newton-Euler (``mj_rne`` after ``mj_kinematics``,
``mj_comPos`` and ``mj_comVel``) on a private copy of the compiled model,
sample by sample; a batch of :attr:`ArmDynamics.vectorised_from` samples
or more takes the same recursion written here in numpy over all its
samples at once, from that copy's fields (the same torques to round-off:
within about 1e-14 of their scale).

What is counted
---------------
* The bodies' masses and inertias as the model was compiled (for a URDF,
  :func:`~splines445_ros.robot.robot_model.load_robot_model` gives a massless
  link 1e-6 kg and 1e-9 kg m^2), and gravity as the description sets it
  (``opt.gravity``, none when its ``gravity`` flag is disabled).
* A payload rigidly held by the tool frame: ``payload_mass`` [kg] with its
  centre of mass ``payload_center_of_mass`` [m] and optionally its inertia
  ``payload_inertia`` [kg m^2] about that centre, both in the tool frame's
  axes.  It is merged into the body holding the tool frame (a URDF link,
  an MJCF body, or the body of an MJCF site): combined mass, centre of mass
  and inertia by the parallel-axis theorem, then diagonalised into MuJoCo's
  principal inertia (``body_inertia``, ``body_iquat``).
* The joints that are not planned stay where the kinematics holds them
  (:meth:`~splines445_ros.robot.robot_model.RobotModel.hold_positions`), at
  rest.  A joint driven by another through a joint equality (URDF
  ``<mimic>``: ``q - q0 = c0 + c1 x + ... + c4 x^4``, ``x = p - p0`` its
  parent's displacement) follows its parent with the chain rule's velocity
  and acceleration; when the parent is planned, the driven joint's torque
  is carried to it by virtual work (``tau_p += dq/dp * tau_q``), as an
  ideal coupling would.

What is not counted (by default)
--------------------------------
Joint damping, dry friction (``frictionloss``), rotor inertia
(``armature``), springs, gravity compensation and every other passive
force, and constraint forces (joint limits, contacts, equalities other
than the joint coupling above): the torque is what the links' motion
needs.  With ``include_damping=True`` the linear viscous damping
``dof_damping * qd`` and the rotor inertia ``dof_armature * qdd`` of the
description are added (carried through joint couplings like the rest);
MuJoCo 4's higher-order damping (``dof_dampingpoly``) and actuator damping
are not.  The damping alone is then :meth:`ArmDynamics.viscous` (a torque
limit slowed down uniformly needs it apart: it falls as ``1 / f``, the rest
of the motion's torque as ``1 / f**2``), and the dry friction a moving
joint's motor overcomes, ``|tau_f| <= frictionloss`` whatever the speed,
:meth:`ArmDynamics.dry_friction` (a driven joint's carried by ``|dq/dp|``).

Cost: below :attr:`ArmDynamics.vectorised_from` (50) samples, and at
any size for a model with a free or ball joint or a mocap body, one
MuJoCo pass per sample on a reused ``MjData``: about 3 us a sample for a
6- or 7-joint arm (UR5, Panda), 16-19 us for a one-sample call with its
checks.  From 50 samples on, the vectorised pass: about 100-130 us a call
plus 0.4-0.6 us a sample, so 1.5-1.9 us a sample at 100 samples, 0.65-0.75
at 1000 and 0.55-0.65 at 3000, 4-5 times less than MuJoCo's loop there
(and some 170 bytes of work arrays a sample per moving joint).  The
torques that hold the arm still, ``gravity(q)`` (``torques(q, 0, 0)``),
take a pass of their own from :attr:`ArmDynamics.gravity_vectorised_from`
(12) samples on: about 40 us a call plus 0.12-0.15 us a sample, 3 times
less than ``torques``.  An :class:`ArmDynamics` is callable as its
``torques`` (an ``inverse_dynamics`` for
:func:`~splines445_ros.planning.plan`, which then takes its ``gravity``
too) and is not thread-safe.

:func:`effort_limits` (from :mod:`~splines445_ros.robot.torque_limits`, and
importable from here too) returns the description's per-joint torque
limits, read as the simulated arm reads them.
"""

import copy

import numpy as np

from . import rotations as rot
from .mujoco_import import import_mujoco
from .newton_euler import NewtonEuler
from .torque_limits import effort_limits  # noqa: F401 - the torque constraint's limits
from .user_text import show, show_names
from ..planning.validation import non_negative

# Relative slack of the triangle inequality of a payload's principal moments.
_TRIANGLE_SLACK = 1e-9


def payload_inertia_matrix(inertia):
    """Return a payload's inertia (3, 3) from None, (3,) or (6,) values (ValueError)."""
    if inertia is None:
        return np.zeros((3, 3))
    values = _float_array(inertia, 'payload_inertia')
    if values.shape == (3,):
        matrix = np.diag(values)
    elif values.shape == (6,):
        ixx, iyy, izz, ixy, ixz, iyz = values
        matrix = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    else:
        raise ValueError('payload_inertia must be 3 principal moments or 6 values [ixx iyy '
                         f'izz ixy ixz iyz], got shape {values.shape}')
    moments = np.linalg.eigvalsh(matrix)
    if moments[0] <= 0.0:
        raise ValueError(f'payload_inertia {show(values.tolist())} is not positive definite '
                         f'(principal moments {show(moments.tolist())} kg m^2)')
    if moments[0] + moments[1] < moments[2] * (1.0 - _TRIANGLE_SLACK):
        raise ValueError(f'payload_inertia {show(values.tolist())} is not a rigid body '
                         f'inertia: its principal moments {show(moments.tolist())} kg m^2 '
                         'break the triangle inequality (the two smaller must add up to the '
                         'largest)')
    return matrix


def _float_array(value, name):
    """Return ``value`` as a finite float array (ValueError naming ``name``)."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be numbers, got {show(value)}') from None
    if not np.all(np.isfinite(array)):
        raise ValueError(f'{name} must be finite numbers, got {show(array.tolist())}')
    return array


def add_rigid_mass(model, body, mass, center, inertia):
    """
    Merge a rigid mass into ``body`` of a compiled MuJoCo ``model`` (changed in place).

    ``center`` (3,) and ``inertia`` (3, 3) (about ``center``) are in the
    body's frame.  The body's mass, centre of mass (``body_ipos``) and
    principal inertia (``body_inertia`` along ``body_iquat``) become the
    combination's, by the parallel-axis theorem.
    """
    mujoco = import_mujoco()
    own_mass = float(model.body_mass[body])
    own_center = np.array(model.body_ipos[body], dtype=float)
    axes = rot.to_matrix(np.array(model.body_iquat[body], dtype=float))
    own_inertia = axes @ np.diag(model.body_inertia[body]) @ axes.T
    total = own_mass + mass
    if total <= 0.0:
        return
    joint_center = (own_mass * own_center + mass * np.asarray(center, dtype=float)) / total

    def shifted(m, c, i):
        d = c - joint_center
        return i + m * (np.dot(d, d) * np.eye(3) - np.outer(d, d))

    combined = (shifted(own_mass, own_center, own_inertia)
                + shifted(mass, np.asarray(center, dtype=float), inertia))
    combined = 0.5 * (combined + combined.T)
    moments, vectors = np.linalg.eigh(combined)
    if np.linalg.det(vectors) < 0.0:
        vectors[:, 2] = -vectors[:, 2]
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(vectors).reshape(9))
    model.body_mass[body] = total
    model.body_ipos[body] = joint_center
    model.body_inertia[body] = np.maximum(moments, 0.0)
    model.body_iquat[body] = quat


class ArmDynamics:
    """Inverse dynamics (N samples at once) of the planned joints of a robot with a payload."""

    #: Batches of at least this many samples take the vectorised Newton-Euler (when
    #: :attr:`vectorised`): below, its fixed cost (about 100 us for a 6- or 7-joint arm)
    #: outweighs MuJoCo's few microseconds a sample.
    vectorised_from = 50
    #: ... taken this many samples at a time: the pass keeps some 1 kB a sample for a
    #: 7-joint arm, and a 1 kHz check of a long plan has millions of samples.
    vectorised_chunk = 16384
    #: :meth:`gravity`'s batches of at least this many samples take its own pass (when
    #: :attr:`vectorised`): its fixed cost (about 40 us) is a third of the full pass's.
    gravity_vectorised_from = 12

    def __init__(self, robot, joint_names=(), tool_frame='', payload_mass=0.0,
                 payload_center_of_mass=(0.0, 0.0, 0.0), payload_inertia=None,
                 include_damping=False):
        """
        Build the dynamics of ``robot`` (a RobotModel) for ``joint_names`` (ValueError).

        ``joint_names`` empty: every actuated joint.  ``tool_frame`` (a URDF
        link, MJCF body or site, as :meth:`RobotModel.frame` accepts) holds
        the payload: ``payload_mass`` [kg] >= 0, ``payload_center_of_mass``
        (3,) [m] in the tool frame, ``payload_inertia`` None (a point mass),
        (3,) principal moments or (6,) ``[ixx iyy izz ixy ixz iyz]``
        [kg m^2] about the payload's centre of mass in the tool frame's
        axes.  ``include_damping``: add the joints' viscous damping and
        rotor inertia (armature), and give :meth:`viscous` and
        :meth:`dry_friction` (else both are None).
        """
        mujoco = import_mujoco()
        self.mujoco = mujoco
        self.robot = robot
        self.joints = robot.select(tuple(joint_names))
        self.joint_names = tuple(j.name for j in self.joints)
        self.n = len(self.joints)
        self.tool_frame = tool_frame
        self.payload_mass = non_negative('payload_mass [kg]', payload_mass)
        center = _float_array(payload_center_of_mass, 'payload_center_of_mass')
        if center.shape != (3,):
            raise ValueError('payload_center_of_mass must be 3 numbers [m], got shape '
                             f'{center.shape}')
        inertia = payload_inertia_matrix(payload_inertia)
        if self.payload_mass == 0.0 and payload_inertia is not None:
            raise ValueError('payload_inertia is given but payload_mass is 0: a payload with '
                             'inertia needs a mass')
        if self.payload_mass > 0.0 and not tool_frame:
            raise ValueError('a payload (payload_mass > 0) needs a tool_frame to hold it')
        self.payload_center_of_mass = center
        self.payload_inertia = inertia
        self.include_damping = bool(include_damping)
        body, offset_pos, offset_quat = robot.frame(tool_frame, 'tool_frame')
        #: The body holding the payload (0, the world, when there is no tool frame).
        self.payload_body = body
        model = copy.deepcopy(robot.model)
        self._damping = np.array(model.dof_damping, dtype=float)
        self._armature = np.array(model.dof_armature, dtype=float)
        self._friction = np.array(model.dof_frictionloss, dtype=float)
        # mj_rne counts none of these; zeroed so the copy says what it computes.
        model.dof_damping[:] = 0.0
        model.dof_armature[:] = 0.0
        model.dof_frictionloss[:] = 0.0
        model.jnt_stiffness[:] = 0.0
        for name in ('dof_dampingpoly', 'jnt_stiffnesspoly'):  # MuJoCo 4's higher orders
            if hasattr(model, name):
                getattr(model, name)[:] = 0.0
        if self.payload_mass > 0.0 and body > 0:
            turn = rot.to_matrix(offset_quat)
            add_rigid_mass(model, body, self.payload_mass, offset_pos + turn @ center,
                           turn @ inertia @ turn.T)
        #: The private copy of the compiled model, payload included.
        self.model = model
        self.data = mujoco.MjData(model)
        mujoco.mj_setConst(model, self.data)
        self._hold = np.array(robot.hold_positions(), dtype=float)
        self._qpos = np.array([j.qpos for j in self.joints], dtype=int)
        self._dof = np.array([j.dof for j in self.joints], dtype=int)
        self._coupled = self._couplings()
        moving = {int(model.dof_jntid[dof]) for dof in self._dof}
        moving.update(int(model.dof_jntid[entry[1]]) for entry in self._coupled)
        self._vectorised = (NewtonEuler(mujoco, model, moving, self._hold)
                            if NewtonEuler.supports(mujoco, model) else None)
        #: Whether batches of :attr:`vectorised_from` samples or more take the vectorised
        #: Newton-Euler (not for a free or ball joint, or a mocap body: MuJoCo's throughout).
        self.vectorised = self._vectorised is not None
        if not self.include_damping:
            #: ``include_damping``: the joints' viscous damping torques ``viscous(q, qd)``
            #: ((N, n), part of :meth:`torques`); else None.
            self.viscous = None
            #: ``include_damping``: the dry friction ``dry_friction(q)`` (N, n) a moving
            #: joint overcomes (not part of :meth:`torques`); else None.
            self.dry_friction = None

    def _couplings(self):
        """
        Return the driven joints in the order to evaluate them, and fix the held ones.

        Each entry: (qpos address, dof address, own q0, parent qpos address,
        parent dof address, parent q0, coefficients (5,)), each after its
        parent when the parent is driven too.  A driven joint whose chain of
        parents ends at a joint that is not planned is constant: its
        position goes into the held positions and it is not listed.
        """
        mj, m = self.mujoco, self.model
        drivers = {}
        for e in range(m.neq):
            if int(m.eq_type[e]) == int(mj.mjtEq.mjEQ_JOINT) and m.eq_active0[e]:
                drivers[int(m.eq_obj1id[e])] = (int(m.eq_obj2id[e]),
                                                np.array(m.eq_data[e, :5], dtype=float))
        column = {j.joint_id: i for i, j in enumerate(self.joints)}
        root, order = {}, []

        def resolve(joint, seen):
            if joint in root:
                return root[joint]
            if joint in column:
                root[joint] = column[joint]
                return root[joint]
            if joint not in drivers:
                root[joint] = None
                return None
            if joint in seen:
                name = mj.mj_id2name(m, mj.mjtObj.mjOBJ_JOINT, joint)
                raise ValueError(f'joint {show(name)} of {self.robot.describe()} is driven '
                                 'by a loop of joint equalities')
            parent, coefficients = drivers[joint]
            top = resolve(parent, seen | {joint}) if parent >= 0 else None
            q0 = float(m.qpos0[m.jnt_qposadr[joint]])
            if top is None:
                x = 0.0
                if parent >= 0:
                    adr = int(m.jnt_qposadr[parent])
                    x = self._hold[adr] - float(m.qpos0[adr])
                self._hold[int(m.jnt_qposadr[joint])] = q0 + np.polyval(coefficients[::-1], x)
            else:
                order.append((int(m.jnt_qposadr[joint]), int(m.jnt_dofadr[joint]), q0,
                              int(m.jnt_qposadr[parent]), int(m.jnt_dofadr[parent]),
                              float(m.qpos0[m.jnt_qposadr[parent]]), coefficients))
            root[joint] = top
            return top

        for joint in sorted(drivers):
            resolve(joint, frozenset())
        return order

    def _check(self, value, name):
        """Return ``value`` as a finite (N, n) float array (ValueError)."""
        try:
            array = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f'{name} must be numbers, got {show(value)}') from None
        if array.ndim == 1:
            array = array[None, :]
        if array.ndim != 2 or array.shape[1] != self.n:
            raise ValueError(f'{name} must have shape (N, {self.n}) (one column per joint of '
                             f'{show_names(self.joint_names)}), got shape {array.shape}')
        if not np.all(np.isfinite(array)):
            raise ValueError(f'{name} has values that are not finite numbers')
        return array

    def torques(self, q, qd, qdd):
        """
        Return the joint torques [N m or N], (N, n), at positions, velocities, accelerations.

        ``q``, ``qd``, ``qdd``: (N, n) (or (n,), giving (n,)) for the planned
        joints, in the order of ``joint_names``; the other joints are held,
        at rest.  ValueError for other shapes or values that are not finite.
        """
        single = np.ndim(q) == 1
        q = self._check(q, 'q')
        qd = self._check(qd, 'qd')
        qdd = self._check(qdd, 'qdd')
        if not q.shape == qd.shape == qdd.shape:
            raise ValueError(f'q, qd and qdd must have the same shape, got {q.shape}, '
                             f'{qd.shape} and {qdd.shape}')
        m, d, mj = self.model, self.data, self.mujoco
        count = len(q)
        vectorised = self._vectorised is not None and count >= self.vectorised_from
        # MuJoCo reads a sample's row; the vectorised pass a joint's column.
        layout = 'F' if vectorised else 'C'
        qpos, slopes, displacements = self._positions(q, layout)
        qvel = np.zeros((count, m.nv), order=layout)
        qacc = np.zeros((count, m.nv), order=layout)
        qvel[:, self._dof] = qd
        qacc[:, self._dof] = qdd
        # Driven joints, parents first: qd = f'(x) xd, qdd = f''(x) xd^2 + f'(x) xdd.
        for (_, dof, _, _, parent_dof, _, c), slope, x in zip(self._coupled, slopes,
                                                              displacements):
            xd, xdd = qvel[:, parent_dof], qacc[:, parent_dof]
            curve = 2.0 * c[2] + x * (6.0 * c[3] + x * 12.0 * c[4])
            qvel[:, dof] = slope * xd
            qacc[:, dof] = curve * xd * xd + slope * xdd
        if vectorised:
            # Only the moving joints' columns are filled: the held ones' are not read.
            force = np.zeros((count, m.nv), order=layout)
            for rows in self._chunks(count):
                self._vectorised.forces(qpos[rows], qvel[rows], qacc[rows], force[rows])
        else:
            force = np.empty((count, m.nv))
            qpos_now, qvel_now, qacc_now = d.qpos, d.qvel, d.qacc
            kinematics, com_pos, com_vel = mj.mj_kinematics, mj.mj_comPos, mj.mj_comVel
            rne = mj.mj_rne
            for k in range(count):
                qpos_now[:] = qpos[k]
                qvel_now[:] = qvel[k]
                qacc_now[:] = qacc[k]
                kinematics(m, d)
                com_pos(m, d)
                com_vel(m, d)
                rne(m, d, 1, force[k])
        if self.include_damping:
            force += self._damping * qvel + self._armature * qacc
        return self._planned(force, slopes, single)

    __call__ = torques

    def gravity(self, q):
        """
        Return the torques [N m or N] that hold the joints still at ``q``: ``torques(q, 0, 0)``.

        ``q`` (N, n) (or (n,), giving (n,)), as :meth:`torques` takes it,
        payload and driven joints alike.  With the velocities and
        accelerations zero, a batch of :attr:`gravity_vectorised_from`
        samples or more takes a pass of its own (when :attr:`vectorised`):
        only gravity's acceleration goes down the tree and only the first
        moment of the masses comes back up, about 35-45 us a call plus
        0.12-0.15 us a sample for a 6- or 7-joint arm (UR5, Panda), 3 times
        less than :meth:`torques`' vectorised pass from 50 to 3000 samples.
        Smaller batches, and a model that pass does not support, take
        :meth:`torques`.  The same torques to round-off (within about 1e-14
        of their scale).
        """
        single = np.ndim(q) == 1
        q = self._check(q, 'q')
        count = len(q)
        if self._vectorised is None or count < self.gravity_vectorised_from:
            zero = np.zeros_like(q)
            out = self.torques(q, zero, zero)
            return out[0] if single else out
        qpos, slopes, _ = self._positions(q, 'F')
        # Only the moving joints' columns are filled: the held ones' are not read.
        force = np.zeros((count, self.model.nv), order='F')
        for rows in self._chunks(count):
            self._vectorised.gravity(qpos[rows], force[rows])
        return self._planned(force, slopes, single)

    def passive(self):
        """Return the planned joints' own (damping, frictionloss, armature), each (n,)."""
        return self._damping[self._dof], self._friction[self._dof], self._armature[self._dof]

    def viscous(self, q, qd):
        """
        Return the joints' viscous damping torques (N, n) (or (n,)): the ``dof_damping`` part.

        ``dof_damping * qd`` of every moving dof, driven joints' carried to
        their parents as :meth:`torques` carries them; it is part of
        :meth:`torques` (``include_damping``), and is given apart because a
        uniform slow-down divides it by ``f`` where the rest of the motion's
        torque falls by ``f**2``.
        """
        single = np.ndim(q) == 1
        q = self._check(q, 'q')
        qd = self._check(qd, 'qd')
        _, slopes, _ = self._positions(q, 'C')
        qvel = np.zeros((len(q), self.model.nv))
        qvel[:, self._dof] = qd
        for (_, dof, _, _, parent_dof, _, _), slope in zip(self._coupled, slopes):
            qvel[:, dof] = slope * qvel[:, parent_dof]
        return self._planned(self._damping * qvel, slopes, single)

    def dry_friction(self, q):
        """
        Return the dry friction (N, n) (or (n,)) each planned joint's motor overcomes moving.

        A joint's ``frictionloss`` plus, for every joint it drives (a URDF
        ``<mimic>``), that joint's times ``|dq/dp|`` at ``q``: the most the
        motion can meet, whichever way each joint turns.  Not part of
        :meth:`torques`: its sign is the velocity's, and at rest it is
        anything within it.
        """
        single = np.ndim(q) == 1
        q = self._check(q, 'q')
        _, slopes, _ = self._positions(q, 'C')
        force = np.broadcast_to(self._friction, (len(q), self.model.nv)).copy()
        for (_, dof, _, _, parent_dof, _, _), slope in zip(reversed(self._coupled),
                                                           reversed(slopes)):
            force[:, parent_dof] += np.abs(slope) * force[:, dof]
        out = np.ascontiguousarray(force[:, self._dof])
        return out[0] if single else out

    def _chunks(self, count):
        """Return the slices of ``count`` samples the vectorised passes take at a time."""
        return [slice(start, min(start + self.vectorised_chunk, count))
                for start in range(0, count, self.vectorised_chunk)]

    def _positions(self, q, layout):
        """
        Return every joint's positions (N, nq) in ``layout`` at the planned ``q`` (N, n).

        With, per driven joint (in :meth:`_couplings`' order), the slope
        ``f'(x)`` (N,) of its coupling and its parent's displacement ``x`` (N,).
        """
        qpos = np.empty((len(q), self.model.nq), order=layout)
        qpos[:] = self._hold
        qpos[:, self._qpos] = q
        # Driven joints, parents first: q = q0 + f(x).
        slopes, displacements = [], []
        for adr, _, q0, parent_adr, _, parent_q0, c in self._coupled:
            x = qpos[:, parent_adr] - parent_q0
            value = c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * c[4])))
            slopes.append(c[1] + x * (2.0 * c[2] + x * (3.0 * c[3] + x * 4.0 * c[4])))
            displacements.append(x)
            qpos[:, adr] = q0 + value
        return qpos, slopes, displacements

    def _planned(self, force, slopes, single):
        """Return the planned joints' torques (N, n) (or (n,)) from every dof's ``force``."""
        # Children last in the evaluation order: carry each one's torque to its parent.
        for (_, dof, _, _, parent_dof, _, _), slope in zip(reversed(self._coupled),
                                                           reversed(slopes)):
            force[:, parent_dof] += slope * force[:, dof]
        out = np.ascontiguousarray(force[:, self._dof])
        return out[0] if single else out
