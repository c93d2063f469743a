"""
Forward kinematics of one frame along the compiled model's chain, vectorised in numpy.

:class:`FrameChain` is what :meth:`RobotModel.frame_chain
<splines445_ros.robot.robot_model.RobotModel.frame_chain>` returns: the world
pose of a frame, its joint Jacobian and path rates, over many configurations
at once; :func:`z_onto` is the rotation that takes z onto an axis.
"""

import math

import numpy as np

from . import rotations as rot


class FrameChain:
    """
    Vectorised forward kinematics of one frame, from the compiled model's geometry.

    Mirrors MuJoCo's ``mj_kinematics`` along the bodies from the world to the
    frame's body (body offsets, hinge rotations about their anchors, slides),
    with rotation matrices in numpy over any number of configurations at
    once: the deviation search evaluates thousands per refinement step.
    Joints of the chain that are not planned stay at the model's ``qpos0``
    (their frame offsets are folded into constant steps).  A joint driven by
    another one through a joint equality (URDF ``<mimic>``) follows it as
    the equality says, ``q - q0 = c0 + c1 (p - p0) + ... + c4 (p - p0)^4``
    (``q0``, ``p0`` their ``qpos0``): as a function of its parent's column
    when the parent is planned, else at its constant ``q0 + c0``.
    """

    def __init__(self, robot, frame, joints, parameter='frame'):
        """Build the chain of ``frame`` for the planned ``joints`` (JointInfo tuple)."""
        mj, m = robot.mujoco, robot.model
        body, offset_pos, offset_quat = robot.frame(frame, parameter)
        self.body = body
        self.offset_pos = offset_pos
        self.offset_quat = offset_quat
        column = {j.joint_id: i for i, j in enumerate(joints)}
        drivers = self._drivers(mj, m)
        chain = []
        b = body
        while b != 0:
            chain.append(b)
            b = int(m.body_parentid[b])
        self.moving_joints = []
        # Driven joints of the chain, for a MuJoCo pose of the same configuration:
        # (qpos address, dof address, parent column or None, parent qpos0, coefficients,
        # own qpos0).
        self.driven = []
        # The planned joints' columns that move the frame, directly or through a driven joint.
        self.driving_columns = set()
        # Steps: ('fixed', R (3, 3), p (3,)) composes T = T * [R p]; ('hinge', col, ref,
        # poly, axis, anchor, skew, skew^2) and ('slide', ...) move with joint column col
        # by poly(q[col] - ref) (poly None: the identity); extent bounds a slide's |move|,
        # name is the joint's.
        self.steps = []
        self._rates = None      # the steps of speeds(), prepared on first use
        hinge = int(mj.mjtJoint.mjJNT_HINGE)
        slide = int(mj.mjtJoint.mjJNT_SLIDE)
        for b in reversed(chain):
            self._fixed(rot.to_matrix(m.body_quat[b]), m.body_pos[b])
            for j in range(int(m.body_jntadr[b]), int(m.body_jntadr[b] + m.body_jntnum[b])):
                kind = int(m.jnt_type[j])
                name = mj.mj_id2name(m, mj.mjtObj.mjOBJ_JOINT, j)
                if kind not in (hinge, slide):
                    raise ValueError(f'{parameter} {frame!r} hangs on joint {name!r}, which is '
                                     'a free or ball joint (only hinge and slide joints are '
                                     'supported)')
                self.moving_joints.append(name)
                axis = m.jnt_axis[j] / np.linalg.norm(m.jnt_axis[j])
                anchor = m.jnt_pos[j].copy()
                col, ref, poly = column.get(j), float(m.qpos0[m.jnt_qposadr[j]]), None
                if col is None and j in drivers:
                    parent, poly = drivers[j]
                    self._check_parent(mj, m, parent, drivers, column, frame, name, parameter)
                    col = column.get(parent)
                    self.driven.append((int(m.jnt_qposadr[j]), int(m.jnt_dofadr[j]), col,
                                        float(m.qpos0[m.jnt_qposadr[parent]])
                                        if parent >= 0 else 0.0, poly, ref))
                    if col is None:
                        # Its parent is held (or it has none): a constant displacement c0.
                        self._displaced(kind == hinge, axis, anchor, float(poly[0]))
                        continue
                    ref = self.driven[-1][3]
                    poly = None if np.array_equal(poly, [0.0, 1.0, 0.0, 0.0, 0.0]) else poly
                if col is None:
                    continue  # held at qpos0, where MuJoCo's joint displacement is zero
                self.driving_columns.add(col)
                x, y, z = axis
                skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
                extent = 0.0
                if kind == slide:
                    extent = self._extent(joints[col], ref, poly)
                self.steps.append(('hinge' if kind == hinge else 'slide', col, ref, poly, axis,
                                   anchor, skew, skew @ skew, extent, name))
        self._fixed(rot.to_matrix(offset_quat), offset_pos)
        self.n = len(joints)

    @staticmethod
    def _drivers(mj, m):
        """Return {driven joint id: (parent joint id or -1, coefficients (5,))}, active ones."""
        drivers = {}
        for e in range(m.neq):
            if int(m.eq_type[e]) == int(mj.mjtEq.mjEQ_JOINT) and m.eq_active0[e]:
                drivers[int(m.eq_obj1id[e])] = (int(m.eq_obj2id[e]),
                                                np.array(m.eq_data[e, :5], dtype=float))
        return drivers

    @staticmethod
    def _check_parent(mj, m, parent, drivers, column, frame, name, parameter):
        """Refuse a driven joint whose parent is itself driven (a chain of equalities)."""
        if parent >= 0 and parent not in column and parent in drivers:
            parent_name = mj.mj_id2name(m, mj.mjtObj.mjOBJ_JOINT, parent)
            raise ValueError(
                f'{parameter} {frame!r} hangs on joint {name!r}, which follows joint '
                f'{parent_name!r}, itself driven by another joint: chains of mimic joints are '
                f'not supported; choose a frame before {name!r}')

    @staticmethod
    def _extent(joint, ref, poly):
        """Return the largest |displacement| of a slide over its (parent's) range, inf if none."""
        lo, hi = joint.lower - ref, joint.upper - ref
        if poly is None:
            return max(abs(lo), abs(hi))
        if np.any(poly[2:] != 0.0):
            return math.inf
        if not (math.isfinite(lo) and math.isfinite(hi)) and poly[1] != 0.0:
            return math.inf
        return max(abs(poly[0] + poly[1] * lo), abs(poly[0] + poly[1] * hi)) \
            if poly[1] != 0.0 else abs(poly[0])

    def _displaced(self, is_hinge, axis, anchor, value):
        """Append a joint held at a constant displacement ``value`` as a fixed step."""
        if is_hinge:
            rotation = rot.to_matrix(np.concatenate([[math.cos(0.5 * value)],
                                                     math.sin(0.5 * value) * axis]))
            self._fixed(rotation, anchor - rotation @ anchor)
        else:
            self._fixed(np.eye(3), value * axis)

    def _fixed(self, rotation, position):
        """Append a constant transform, merged into a preceding constant one."""
        if self.steps and self.steps[-1][0] == 'fixed':
            _, r0, p0 = self.steps[-1]
            self.steps[-1] = ('fixed', r0 @ rotation, p0 + r0 @ position)
        else:
            self.steps.append(('fixed', np.array(rotation, dtype=float),
                               np.array(position, dtype=float)))

    def driven_positions(self, joints):
        """
        Return the chain's driven joints at planned ``joints`` (n,), for a MuJoCo pose.

        A list of ``(qpos address, dof address, parent column or None,
        position, d position / d parent)``.
        """
        out = []
        for adr, dof, col, parent_ref, poly, ref in self.driven:
            x = 0.0 if col is None else float(joints[col]) - parent_ref
            value = poly[0] + x * (poly[1] + x * (poly[2] + x * (poly[3] + x * poly[4])))
            slope = poly[1] + x * (2.0 * poly[2] + x * (3.0 * poly[3] + x * 4.0 * poly[4]))
            out.append((adr, dof, col, ref + value, slope))
        return out

    def reach(self):
        """
        Return ``(pivot (3,), radius, joint name)``: the frame stays within ``radius`` of it.

        ``pivot`` is a world point on the first moving joint (a hinge's axis
        point, or a slide's frame origin), fixed since nothing before it
        moves; ``radius`` sums the distances between successive joints' pivots
        (constant: a hinge turns what follows about its pivot) and the
        slides' largest moves.  None when the frame moves with no joint.
        """
        pos, mat = np.zeros(3), np.eye(3)
        pivots, extents = [], 0.0
        for step in self.steps:
            if step[0] == 'fixed':
                pos = pos + mat @ step[2]
                mat = mat @ step[1]
            elif step[0] == 'hinge':
                pivots.append(pos + mat @ step[5])
            else:
                pivots.append(pos.copy())
                extents += step[8]
        if not pivots:
            return None
        points = np.array(pivots + [pos])
        radius = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1))) + extents
        first = next(s for s in self.steps if s[0] != 'fixed')
        return pivots[0], radius, first[9]

    def transform(self, joints):
        """Return positions (..., 3) and rotation matrices (..., 3, 3) in the world."""
        q = np.asarray(joints, dtype=float)
        if q.shape[-1] != self.n:
            raise ValueError(f'need {self.n} joint positions, got {q.shape[-1]}')
        shape = q.shape[:-1]
        flat = q.reshape(-1, self.n)
        k = len(flat)
        pos = np.zeros((k, 3))
        mat = np.broadcast_to(np.eye(3), (k, 3, 3))

        def times(m, constant):
            # (K, 3, 3) @ (3, 3) or (3,) as one 2-D product (numpy's stacked matmul
            # of small matrices is several times slower).
            if constant.ndim == 1:
                return (m.reshape(-1, 3) @ constant).reshape(k, 3)
            return (m.reshape(-1, 3) @ constant).reshape(k, 3, 3)

        for step in self.steps:
            if step[0] == 'fixed':
                pos = pos + times(mat, step[2])
                mat = times(mat, step[1])
                continue
            kind, col, ref, poly, axis, anchor, skew, skew2 = step[:8]
            value = flat[:, col] - ref
            if poly is not None:
                x = value
                value = poly[0] + x * (poly[1] + x * (poly[2] + x * (poly[3] + x * poly[4])))
            if kind == 'slide':
                pos = pos + times(mat, axis) * value[:, None]
                continue
            if anchor.any():
                world_anchor = pos + times(mat, anchor)
            # mat @ (I + sin K + (1 - cos) K^2), Rodrigues about the joint axis.
            mat = (mat + np.sin(value)[:, None, None] * times(mat, skew)
                   + (1.0 - np.cos(value))[:, None, None] * times(mat, skew2))
            if anchor.any():
                pos = world_anchor - times(mat, anchor)
        return pos.reshape(shape + (3,)), mat.reshape(shape + (3, 3))

    def pose(self, joints):
        """Return positions (..., 3) and quaternions (..., 4) of the frame in the world."""
        pos, mat = self.transform(joints)
        return pos, rot.from_matrix(mat)

    def speeds(self, joints, rates):
        """
        Return the frame's linear and angular speed (...,) at ``joints`` moving at ``rates``.

        ``|J(q) qdot|`` in one pass along the chain: every hinge turns what
        follows about its world axis ``a`` through its world point ``o``, so
        the frame's angular velocity is ``w = sum(qdot_j a_j)`` and its linear
        one ``sum(qdot_j a_j x (p - o_j)) = w x p - sum(qdot_j a_j x o_j)`` (a
        slide adds ``qdot_j a_j``), with ``p`` the frame's position of the
        same pass.  Each hinge's axis is turned onto z by constant rotations
        folded into the chain's fixed steps (prepared once,
        :meth:`_rate_steps`), so a hinge step mixes two columns of the
        rotation and no 3 x 3 products.
        """
        q = np.asarray(joints, dtype=float)
        if q.shape[-1] != self.n:
            raise ValueError(f'need {self.n} joint positions, got {q.shape[-1]}')
        shape = q.shape[:-1]
        q = q.reshape(-1, self.n).T
        qdot = np.asarray(rates, dtype=float).reshape(-1, self.n).T
        k = q.shape[1]
        position = np.zeros((3, 1))
        # columns[c] is column c (3, K) of the rotation from the base to the current frame.
        columns = np.eye(3)[:, :, None]
        turning = np.zeros((3, k))
        moment = np.zeros((3, k))
        for step in self._rate_steps():
            if step[0] == 'fixed':
                flat = columns.reshape(3, -1)
                position = position + (step[2] @ flat).reshape(columns.shape[1:])
                columns = (step[1].T @ flat).reshape(columns.shape)
                continue
            col, ref, poly = step[1:4]
            value, rate = q[col] - ref, qdot[col]
            if poly is not None:
                x = value
                value = poly[0] + x * (poly[1] + x * (poly[2] + x * (poly[3] + x * poly[4])))
                rate = rate * (poly[1] + x * (2.0 * poly[2] + x * (3.0 * poly[3]
                                                                   + x * 4.0 * poly[4])))
            if step[0] == 'slide':
                axis = np.tensordot(step[4], columns, axes=(0, 0))
                position = position + axis * value
                moment = moment - axis * rate
                continue
            axis = np.broadcast_to(columns[2], (3, k))
            turning = turning + axis * rate
            moment = moment + _column_cross(axis, position) * rate
            cosine, sine = np.cos(value), np.sin(value)
            columns = np.stack([cosine * columns[0] + sine * columns[1],
                                cosine * columns[1] - sine * columns[0], axis])
        velocity = _column_cross(turning, position) - moment
        return (np.sqrt(np.sum(velocity ** 2, axis=0)).reshape(shape),
                np.sqrt(np.sum(turning ** 2, axis=0)).reshape(shape))

    def _rate_steps(self):
        """Return (once) the steps of :meth:`speeds`: each hinge's axis turned onto z."""
        if self._rates is not None:
            return self._rates
        steps = []

        def fixed(rotation, position):
            # A constant transform, merged into a preceding constant one.
            if steps and steps[-1][0] == 'fixed':
                _, r0, p0 = steps[-1]
                steps[-1] = ('fixed', r0 @ rotation, p0 + r0 @ position)
            else:
                steps.append(('fixed', np.array(rotation, float), np.array(position, float)))

        for step in self.steps:
            if step[0] == 'fixed':
                fixed(step[1], step[2])
                continue
            kind, col, ref, poly, axis, anchor = step[:6]
            if kind == 'slide':
                steps.append(('slide', col, ref, poly, np.array(axis, float)))
                continue
            # Trans(o) Rot(a, q) Trans(-o) = [B, o] Rot(z, q) [B^T, -B^T o], B z = a.
            turn = z_onto(axis)
            fixed(turn, anchor)
            steps.append(('hinge', col, ref, poly))
            fixed(turn.T, -turn.T @ anchor)
        self._rates = steps
        return steps


def z_onto(axis):
    """Return a rotation (3, 3) that takes the z axis onto the unit vector ``axis``."""
    z = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x = _column_cross(helper[:, None], z[:, None])[:, 0]
    x /= np.linalg.norm(x)
    return np.column_stack([x, _column_cross(z[:, None], x[:, None])[:, 0], z])


def _column_cross(a, b):
    """Return the cross products (3, K) of the columns of ``a`` and ``b`` (3, K)."""
    return np.stack([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                     a[0] * b[1] - a[1] * b[0]])
