"""
The recursive Newton-Euler inverse dynamics of a MuJoCo model, vectorised in numpy.

:class:`NewtonEuler` is MuJoCo's ``mj_rne`` written from the model's fields
for hinge and slide joints, evaluated over many samples at once;
:class:`~splines445_ros.robot.dynamics.ArmDynamics` runs it for the planned
joints with the payload.
"""

import numpy as np

from . import rotations as rot
from .frame_chain import z_onto


def _skew(v):
    """Return the matrix (3, 3) of the cross product ``v x``, v (3,)."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


# The products of an angular velocity's components that a Newton-Euler step needs.
_PRODUCTS = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (2, 0))


def _quadratic(function):
    """
    Return the matrix (3, 6) of a quadratic ``function`` of w (3,) on w's products.

    ``function(w) == matrix @ [wx wx, wy wy, wz wz, wx wy, wy wz, wz wx]``.
    """
    eye = np.eye(3)
    matrix = np.empty((3, 6))
    for column, (i, j) in enumerate(_PRODUCTS):
        if i == j:
            matrix[:, column] = function(eye[i])
        else:
            matrix[:, column] = function(eye[i] + eye[j]) - function(eye[i]) - function(eye[j])
    return matrix


# A node's state: a (origin's acceleration), dw, w (angular acceleration, velocity)
# stored by component, rows [ax dwx wx, ay dwy wy, az dwz wz], then w's _PRODUCTS;
# a load: f, n (force, moment about the origin) as rows [fx nx, fy ny, fz nz].
_STATE = np.array([0, 3, 6, 1, 4, 7, 2, 5, 8])     # row of a, dw, w's components
_LOAD = np.array([0, 2, 4, 1, 3, 5])               # row of f, n's components


class NewtonEuler:
    """
    MuJoCo's ``mj_rne`` for hinge and slide joints, vectorised in numpy over the samples.

    The recursive Newton-Euler of the tree, written from the model's fields:
    a body sits at ``body_pos``, ``body_quat`` in its parent's frame, then
    its joints move it in order, a hinge turning it by ``qpos - qpos0``
    about ``jnt_axis`` through ``jnt_pos`` and a slide shifting it by
    ``qpos - qpos0`` along ``jnt_axis`` (both in the body's frame, as
    ``mj_kinematics`` does); its mass ``body_mass`` sits at ``body_ipos``
    with principal moments ``body_inertia`` along ``body_iquat``.  Gravity
    is ``opt.gravity``, none when its flag is disabled.

    Each moving joint gets a node: a frame on its anchor whose z axis is
    the joint's axis, so the joint turns it about z or shifts it along z.
    The bodies that the joint carries without another moving joint in
    between are merged into its node (one spatial inertia about the node's
    origin), and the joints that do not move (held) are folded into the
    constant transforms between nodes.  The passes run over the nodes, on
    (rows, K) arrays of the K samples: forward, the angular velocity and
    acceleration and the origin's linear acceleration (gravity as an
    upward acceleration of the world) in the node's frame; backward, the
    force and moment about the origin that the node and what it carries
    need, carried to the parent node.  A hinge's torque is the moment's z
    component, a slide's force the force's.  Everything constant is in
    matrices applied by one product per node and pass (the velocity
    products enter through w's six products); what is left per sample is
    the joints' turns and the velocity terms.
    """

    @staticmethod
    def supports(mujoco, model):
        """
        Return whether this reproduces ``mj_rne`` on ``model``.

        Not with a free or ball joint, or a mocap body (placed by ``MjData``).
        """
        kinds = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
        return (all(int(kind) in kinds for kind in model.jnt_type)
                and not np.any(model.body_mocapid >= 0))

    def __init__(self, mujoco, model, moving, hold):
        """
        Build the nodes of ``model``'s joints ``moving`` (joint ids), the others at ``hold``.

        ``hold`` (nq,); ``model`` one that :meth:`supports` accepts.
        """
        slide = int(mujoco.mjtJoint.mjJNT_SLIDE)
        gravity = np.array(model.opt.gravity, dtype=float)
        if model.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_GRAVITY):
            gravity[:] = 0.0
        # Per node: parent node (-1 the world), its frame (rotation, origin) in the parent
        # node's before the joint moves it, slide?, qpos and dof address, qpos0.
        self.parent, frames, self.slides, qpos, dofs, qpos0 = [], [], [], [], [], []
        mass, first, second = [], [], []    # per node: m, m c (3,), inertia about origin (3, 3)
        # Per body: (node, rotation (3, 3), position (3,)), the body's frame in the node's.
        place = [(-1, np.eye(3), np.zeros(3))]
        for body in range(1, model.nbody):
            node, turn, shift = place[int(model.body_parentid[body])]
            shift = shift + turn @ model.body_pos[body]
            turn = turn @ rot.to_matrix(np.array(model.body_quat[body], dtype=float))
            start = int(model.body_jntadr[body])
            for joint in range(start, start + int(model.body_jntnum[body])):
                axis = np.array(model.jnt_axis[joint], dtype=float)
                axis /= np.linalg.norm(axis)
                anchor = np.array(model.jnt_pos[joint], dtype=float)
                adr = int(model.jnt_qposadr[joint])
                is_slide = int(model.jnt_type[joint]) == slide
                if joint not in moving:
                    value = float(hold[adr] - model.qpos0[adr])
                    if is_slide:
                        shift = shift + turn @ (value * axis)
                    else:
                        turning = rot.to_matrix(rot.from_axis_angle(axis, value))
                        shift = shift + turn @ (anchor - turning @ anchor)
                        turn = turn @ turning
                    continue
                align = z_onto(axis)
                self.parent.append(node)
                frames.append((turn @ align, shift + turn @ anchor))
                self.slides.append(is_slide)
                qpos.append(adr)
                dofs.append(int(model.jnt_dofadr[joint]))
                qpos0.append(float(model.qpos0[adr]))
                mass.append(0.0)
                first.append(np.zeros(3))
                second.append(np.zeros((3, 3)))
                node = len(self.parent) - 1
                turn, shift = align.T, -align.T @ anchor
            place.append((node, turn, shift))
            if node < 0:
                continue
            center = shift + turn @ model.body_ipos[body]
            axes = turn @ rot.to_matrix(np.array(model.body_iquat[body], dtype=float))
            m = float(model.body_mass[body])
            mass[node] += m
            first[node] = first[node] + m * center
            second[node] = (second[node] + axes @ np.diag(model.body_inertia[body]) @ axes.T
                            + m * (center @ center * np.eye(3) - np.outer(center, center)))
        self.count = len(self.parent)
        self.qpos = np.array(qpos, dtype=int)
        self.dofs = np.array(dofs, dtype=int)
        self.qpos0 = np.array(qpos0)[:, None]
        world = _as_state(np.concatenate([-gravity, np.zeros(12)]))[:, None]  # a = -g
        # Per node, the map (rows, 15) from the parent's state to the node's before its
        # joint moves: rows x, y, z; a hinge's [x; y; y; -x; z; wy; -wx; -wx; -wy], to
        # turn x and y and add w x (qd z) to dw (by components, both turned alike).
        # And the map (6, 6 or 10) of the node's load to its parent's: the hinge's
        # from [c fx; c nx; c fy; c ny; s fx; s nx; s fy; s ny; fz; nz] (turned back).
        self.forward_maps, self.carry_maps = [], []
        for k, (turn, at) in enumerate(frames):
            forward = self._forward_map(turn, at)
            carry = np.zeros((6, 6))
            carry[np.ix_(_LOAD[0:3], _LOAD[0:3])] = turn              # f
            carry[np.ix_(_LOAD[3:6], _LOAD[0:3])] = _skew(at) @ turn   # + r x f
            carry[np.ix_(_LOAD[3:6], _LOAD[3:6])] = turn              # n
            if not self.slides[k]:
                forward = np.concatenate([forward[0:6], forward[3:6], -forward[0:3],
                                          forward[6:9], forward[[5]], -forward[[2, 2, 5]]])
                back = np.zeros((6, 10))
                back[0:4, 0:4] = np.eye(4)
                back[0:2, 6:8] = -np.eye(2)
                back[2:4, 4:6] = np.eye(2)
                back[4:6, 8:10] = np.eye(2)
                carry = carry @ back
            if self.parent[k] < 0:      # the world does not move: constants (rows, 1)
                forward = forward @ world
            self.forward_maps.append(forward)
            self.carry_maps.append(carry)
        #: The maps (nodes, 6, 15) from each node's state to the load of its own bodies.
        self.loads_maps = np.array([self._loads_map(*inertia)
                                    for inertia in zip(mass, first, second)]).reshape(-1, 6, 15)
        self._gravity_maps(frames, mass, first, gravity)

    def _gravity_maps(self, frames, mass, first, gravity):
        """
        Build the maps of :meth:`gravity` from the nodes' frames and masses, and gravity (3,).

        At rest every node's acceleration is gravity's (upward) turned into
        its frame, ``a``, and what the node and all it carries need is the
        force ``M a`` and the moment ``H x a`` about its origin: ``M`` the
        mass it carries, ``H`` their first moment (mass times centre).  So
        the forward pass carries ``a`` alone, the backward pass ``H``
        alone (which gravity does not enter), and a hinge's torque is
        ``z . (H x a)``, a slide's force ``M a_z``.

        Each is kept in rows that the joint's turn scales without mixing
        them: ``a`` as [c px, c py, s py, -s px, pz], p = a before the
        joint turns the node (so ``a = [r0 + r2, r1 + r3, r4]``); ``H`` as
        [hx, hy, hx, hy, hz, 1], times [c, c, s, s, 1, 1] the rows
        [c hx, c hy, s hx, s hy, hz, 1] from which the parent's are one
        product (its constant part, its own bodies' first moment and its
        children's masses at their anchors, in the last column).  A slide
        has c = 1 and s = 0.
        """
        carried = np.array(mass, dtype=float)        # M: the node's bodies and all it carries
        for k in reversed(range(self.count)):
            if self.parent[k] >= 0:
                carried[self.parent[k]] += carried[k]
        constant = [np.array(h, dtype=float) for h in first]   # H's part that does not turn
        for k, (_, at) in enumerate(frames):
            if self.parent[k] >= 0:
                constant[self.parent[k]] = constant[self.parent[k]] + carried[k] * at
        spread = np.array([[1, 0, 0], [0, 1, 0], [0, 1, 0], [-1, 0, 0], [0, 0, 1]], float)
        gather = np.array([[1, 0, 1, 0, 0], [0, 1, 0, 1, 0], [0, 0, 0, 0, 1]], float)
        twice = np.array([[1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
        turn_z = np.array([[1, 0, 0, -1, 0], [0, 1, 1, 0, 0], [0, 0, 0, 0, 1]], float)
        #: Per node: its rows of ``a`` from its parent's (5, 5), or constant (5, 1) at the
        #: world's; the rows of H of a node that carries no other (6, 1), else None; the
        #: map (6, 6) from its turned rows of H to its parent's, which writes the parent's
        #: (with the constant part) for the last of the parent's children, else adds to it.
        self.gravity_forward, self.gravity_moments, self.gravity_carry = [], [], []
        self.gravity_writes = []
        children = [[] for _ in range(self.count)]
        for k in range(self.count):
            if self.parent[k] >= 0:
                children[self.parent[k]].append(k)
        for k, (turn, _) in enumerate(frames):
            parent = self.parent[k]
            if parent < 0:
                self.gravity_forward.append((spread @ turn.T @ -gravity)[:, None])
            else:
                self.gravity_forward.append(spread @ turn.T @ gather)
            self.gravity_moments.append(None if children[k] else
                                        np.append(twice @ constant[k], 1.0)[:, None])
            carry = np.zeros((6, 6))
            writes = parent >= 0 and k == children[parent][-1]
            if parent >= 0:
                carry[0:5, 0:5] = twice @ turn @ turn_z
                if writes:
                    carry[0:5, 5] = twice @ constant[parent]
                    carry[5, 5] = 1.0
            self.gravity_carry.append(carry)
            self.gravity_writes.append(writes)
        self.carried = carried[:, None]
        self.slide_nodes = np.flatnonzero(self.slides)

    @staticmethod
    def _forward_map(turn, at):
        """
        Return the map (9, 15) from a parent's state to a node's before its joint moves.

        The node's frame is (``turn``, ``at``) in the parent's: a = C^T (a_p
        + dw_p x r + w_p x (w_p x r)), dw = C^T dw_p, w = C^T w_p.
        """
        back, lever = turn.T, _skew(at)
        natural = np.zeros((9, 15))
        natural[0:3, 0:3] = back
        natural[0:3, 3:6] = -back @ lever
        natural[0:3, 9:15] = back @ _quadratic(lambda w: np.cross(w, np.cross(w, at)))
        natural[3:6, 3:6] = back
        natural[6:9, 6:9] = back
        forward = np.zeros((9, 15))
        forward[np.ix_(_STATE, _STATE)] = natural[:, 0:9]
        forward[_STATE, 9:15] = natural[:, 9:15]
        return forward

    @staticmethod
    def _loads_map(mass, first, inertia):
        """
        Return the map (6, 15) from a node's state to the load its own bodies need.

        ``mass``, ``first`` (m c), ``inertia`` about the origin: f = m a +
        dw x h + w x (w x h), n = I dw + w x (I w) + h x a.
        """
        lever = _skew(first)
        natural = np.zeros((6, 15))
        natural[0:3, 0:3] = mass * np.eye(3)
        natural[0:3, 3:6] = -lever
        natural[0:3, 9:15] = _quadratic(lambda w: np.cross(w, np.cross(w, first)))
        natural[3:6, 0:3] = lever
        natural[3:6, 3:6] = inertia
        natural[3:6, 9:15] = _quadratic(lambda w: np.cross(w, inertia @ w))
        loads = np.zeros((6, 15))
        loads[np.ix_(_LOAD, _STATE)] = natural[:, 0:9]
        loads[_LOAD, 9:15] = natural[:, 9:15]
        return loads

    def forces(self, qpos, qvel, qacc, out):
        """
        Write the moving joints' forces into ``out`` (K, nv) at ``qpos``, ``qvel``, ``qacc``.

        ``qpos`` (K, nq), ``qvel`` and ``qacc`` (K, nv); the forces are
        what ``mj_rne`` with ``flg_acc`` gives: M(q) qacc + bias (gravity,
        Coriolis and centrifugal).  The other columns of ``out`` are left
        alone.  Fastest with the arrays in Fortran order (each joint's
        samples contiguous).
        """
        count = len(qpos)
        moves = qpos.T[self.qpos] - self.qpos0          # (nodes, K)
        speeds = qvel.T[self.dofs]
        rates_speeds = np.stack([qacc.T[self.dofs], speeds], axis=1)     # (nodes, 2, K)
        cosines, sines = np.cos(moves), np.sin(moves)
        states = np.empty((self.count, 15, count))
        ahead, spare = np.empty((19, count)), np.empty((6, count))
        for k in range(self.count):
            parent, state, speed = self.parent[k], states[k], speeds[k]
            if parent < 0:
                pre = self.forward_maps[k]
            else:
                pre = ahead[0:len(self.forward_maps[k])]
                np.matmul(self.forward_maps[k], states[parent], out=pre)
            if self.slides[k]:
                state[0:9] = pre
            else:
                if parent >= 0:                 # else w = 0
                    pre[1:12:3] += speed * pre[15:19]      # dw += w x (qd z)
                # Turned by the joint: x = c x + s y, y = c y - s x.
                np.multiply(cosines[k], pre[0:6], out=state[0:6])
                np.multiply(sines[k], pre[6:12], out=spare)
                state[0:6] += spare
                np.add(pre[13:15], rates_speeds[k], out=state[7:9])    # dw += qdd z, w += qd z
                state[6] = pre[12]
            w = state[2:9:3]
            np.multiply(w, w, out=state[9:12])
            np.multiply(state[2], state[5], out=state[12])
            np.multiply(state[5], state[8], out=state[13])
            np.multiply(state[8], state[2], out=state[14])
            if self.slides[k]:
                # a += dw x (d z) + w x (w x (d z)) + 2 w x (qd z) + qdd z
                move = moves[k]
                state[0] += move * (state[4] + state[14]) + 2.0 * speed * state[5]
                state[3] += move * (state[13] - state[1]) - 2.0 * speed * state[2]
                state[6] += rates_speeds[k, 0] - move * (state[9] + state[10])
        loads = np.matmul(self.loads_maps, states)      # (nodes, 6, K): each node's own
        forces, turned = out.T, np.empty((10, count))
        for k in reversed(range(self.count)):
            load = loads[k]                             # and, by now, its children's
            if self.slides[k]:
                forces[self.dofs[k]] = load[_LOAD[2]]
            else:
                forces[self.dofs[k]] = load[_LOAD[5]]
            parent = self.parent[k]
            if parent < 0:
                continue
            if self.slides[k]:
                move = moves[k]
                load[1] -= move * load[2]           # n += d z x f
                load[3] += move * load[0]
                np.matmul(self.carry_maps[k], load, out=spare)
            else:
                np.multiply(cosines[k], load[0:4], out=turned[0:4])
                np.multiply(sines[k], load[0:4], out=turned[4:8])
                turned[8:10] = load[4:6]
                np.matmul(self.carry_maps[k], turned, out=spare)
            loads[parent] += spare

    def gravity(self, qpos, out):
        """
        Write the moving joints' forces at rest into ``out`` (K, nv) at ``qpos`` (K, nq).

        What :meth:`forces` gives with ``qvel`` and ``qacc`` zero, gravity's
        alone, by the passes of :meth:`_gravity_maps`: per node and pass one
        product of a few rows and one scaling by the joint's turn.  The
        other columns of ``out`` are left alone; fastest in Fortran order.
        """
        count = len(qpos)
        moves = qpos.T[self.qpos] - self.qpos0          # (nodes, K)
        # c and s from the half angle's tangent t: (1 - t^2, 2 t) / (1 + t^2), within an ulp
        # or two of cos and sin and a fraction of their cost (numpy's tan is vectorised).
        half = np.tan(0.5 * moves)
        square = half * half
        scale = 1.0 / (1.0 + square)
        turns = np.empty((self.count, 6, count))         # [c, c, s, s, 1, 1] per node
        turns[:, 0:2] = ((1.0 - square) * scale)[:, None]
        turns[:, 2:4] = (2.0 * half * scale)[:, None]
        turns[:, 4:6] = 1.0
        if self.slide_nodes.size:
            turns[self.slide_nodes, 0:2] = 1.0
            turns[self.slide_nodes, 2:4] = 0.0
        accelerations = np.empty((self.count, 5, count))
        for k in range(self.count):
            parent, rows = self.parent[k], accelerations[k]
            if parent < 0:
                np.multiply(self.gravity_forward[k], turns[k, 0:5], out=rows)
            else:
                np.matmul(self.gravity_forward[k], accelerations[parent], out=rows)
                rows *= turns[k, 0:5]
        moments, turned = np.empty((self.count, 6, count)), np.empty((6, count))
        for k in reversed(range(self.count)):
            if self.gravity_moments[k] is not None:
                moments[k] = self.gravity_moments[k]
            parent = self.parent[k]
            if parent < 0:
                continue
            np.multiply(moments[k], turns[k], out=turned)
            if self.slides[k]:
                turned[4] += self.carried[k] * moves[k]     # H about the origin before: + M d z
            if self.gravity_writes[k]:
                np.matmul(self.gravity_carry[k], turned, out=moments[parent])
            else:
                moments[parent] += self.gravity_carry[k] @ turned
        # z . (H x a) = hx ay - hy ax; a slide's M az.
        torques = moments[:, 0] * (accelerations[:, 1] + accelerations[:, 3])
        torques -= moments[:, 1] * (accelerations[:, 0] + accelerations[:, 2])
        if self.slide_nodes.size:
            torques[self.slide_nodes] = (self.carried[self.slide_nodes]
                                         * accelerations[self.slide_nodes, 4])
        out.T[self.dofs] = torques


def _as_state(natural):
    """Return a state (15,) in the stored row order from [a, dw, w, products] (15,)."""
    state = np.empty(15)
    state[_STATE] = natural[0:9]
    state[9:15] = natural[9:15]
    return state
