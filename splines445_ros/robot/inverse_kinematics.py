"""
Tool kinematics of a :class:`~splines445_ros.robot.robot_model.RobotModel`, 6-D; no rclpy.

:class:`ModelKinematics` implements the kinematics protocol of
:mod:`splines445_ros.cartesian.tool_paths` for full tool poses, rows
``(x, y, z, qw, qx, qy, qz)`` of the ``tool_frame`` in the ``base_frame``
(position [m], unit quaternion scalar first):

* ``forward(joints)``: vectorised, by :class:`~splines445_ros.robot.frame_chain.FrameChain`;
* ``inverse(poses)``: damped least squares on MuJoCo's Jacobians
  (``mj_jac``), every step kept in the joint ranges (a joint on a limit
  sits out the steps that push it further).

A joint of the tool's chain that follows another one (URDF ``<mimic>``, a
MuJoCo joint equality) is driven from its parent in both, its Jacobian
column folded into the parent's.

How the inverse stays on one branch
-----------------------------------
Pose k is not solved from scratch: the solver walks from pose k-1 (whose
joints it has) to pose k along the straight line and the slerp between them,
in sub-steps of at most :data:`CONTINUATION_STEP` m and
:data:`CONTINUATION_ANGLE` rad, each solved from the previous one.  So the
joints follow the tool's own path continuously, on the branch of the seed.
A sub-step that would move a joint by more than :data:`MAX_JOINT_STEP`
(a branch flip, a 2*pi wrap, or a near-singular pose where the joint rates
blow up) is refused with an error naming the pose, as is a sub-step the
solver cannot reach within the joint ranges.  The first pose is reached
the same way from the ``seed`` configuration (the current joint state when
the caller knows it, else the model's ``home`` keyframe or reference pose);
when that walk fails, it is solved directly from the seed and from a few
fixed pseudo-random starts, keeping the solution closest to the seed.
A pose farther from the chain's first joint than the sum of the lengths
between its joints (:meth:`~splines445_ros.robot.frame_chain.FrameChain.reach`)
is refused as out of reach, with that distance, before any walk.
"""

import math

import numpy as np

from . import rotations as rot
from .robot_model import joint_ranges
from .user_text import show_names

POSITION_TOLERANCE = 1e-10   # m and rad, what the solver aims at for a pose
# m and rad, a pose is accepted when the solver's iterations end within it: six
# orders of magnitude below the planner's 1 mm / 1 degree deviation tolerances,
# ten times the aim (the last steps near a joint limit or a singular pose only
# crawl below 1e-9, where rounding of the forward kinematics is 1e-15).
ACCEPT_TOLERANCE = 1e-9
STEP_TOLERANCE = 1e-4        # m and rad, intermediate continuation sub-steps
CONTINUATION_STEP = 0.04     # m of tool travel per sub-step
CONTINUATION_ANGLE = 0.1     # rad of tool rotation per sub-step
# Tool coordinates beyond this [m] are refused outright (they overflow the walk's step count).
MAX_COORDINATE = 1e6
MAX_JOINT_STEP = 0.5         # rad (or m) one joint may move in one sub-step
DAMPING = 1e-4               # lambda of damped least squares [m]
MAX_ITERATIONS = 200
MAX_UPDATE = 0.25            # largest joint change of one iteration [rad or m]
FIRST_POSE_RESTARTS = 16
_CACHE_SIZE = 20000
CACHE_MATCH = 1e-9  # rad: a walk from joints this close to the cached start is reused


class KinematicsError(ValueError):
    """A pose the inverse kinematics refuses; ``pose_index`` and ``reason`` say which and why."""

    def __init__(self, pose_index, pose, reason):
        """Keep the index and reason; the message names the pose."""
        self.pose_index = pose_index
        self.pose = np.asarray(pose, dtype=float)
        self.reason = reason
        super().__init__(f'tool pose {pose_index} at {format_pose(pose)} {reason}')


def format_pose(pose):
    """Return a pose row (x, y, z, qw, qx, qy, qz) as text."""
    p = [float(v) for v in pose]
    return (f'(x, y, z) = ({p[0]:.6g}, {p[1]:.6g}, {p[2]:.6g}), '
            f'(qw, qx, qy, qz) = ({p[3]:.6g}, {p[4]:.6g}, {p[5]:.6g}, {p[6]:.6g})')


def pose_rows(poses):
    """Return poses as a finite (K, 7) array with unit quaternions (ValueError otherwise)."""
    try:
        arr = np.array(poses, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'tool poses must be numeric: {exc}') from None
    if arr.ndim == 1:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != 7:
        raise ValueError(f'tool poses must have shape (K, 7) = (x, y, z, qw, qx, qy, qz), '
                         f'got {arr.shape}')
    if not np.all(np.isfinite(arr)):
        k = int(np.argwhere(~np.isfinite(arr))[0][0])
        raise ValueError(f'tool pose {k} is not finite: {arr[k].tolist()}')
    far = np.max(np.abs(arr[:, :3]), axis=1) > MAX_COORDINATE
    if np.any(far):
        k = int(np.argmax(far))
        raise ValueError(f'tool pose {k} is {np.max(np.abs(arr[k, :3])):.3g} m from the base '
                         f'frame, beyond {MAX_COORDINATE:g} m: no arm reaches it')
    norm = np.linalg.norm(arr[:, 3:], axis=1)
    if np.any(norm < 1e-9):
        raise ValueError(f'tool pose {int(np.argmin(norm))} has a zero quaternion')
    arr[:, 3:] /= norm[:, None]
    return arr


class ModelKinematics:
    """Forward and inverse kinematics of ``tool_frame`` in ``base_frame`` of a robot model."""

    def __init__(self, robot, tool_frame, base_frame='', joint_names=(), seed=None):
        """
        Set up the kinematics of ``joint_names`` (all actuated joints when empty).

        ValueError for unknown frames or joints, a base frame that moves with
        a joint, or a tool frame that moves with none of the planned joints.
        """
        if not tool_frame:
            raise ValueError('tool_frame must name a link, body or site of the model')
        self.robot = robot
        self.mujoco = robot.mujoco
        self.joints = robot.select(tuple(joint_names))
        self.joint_names = tuple(j.name for j in self.joints)
        self.tool_frame = tool_frame
        self.base_frame = base_frame
        self.lower, self.upper = joint_ranges(self.joints)
        self.tool = robot.frame_chain(tool_frame, self.joint_names, 'tool_frame')
        base = robot.frame_chain(base_frame, self.joint_names, 'base_frame')
        if base.moving_joints:
            raise ValueError(f'base_frame {base_frame!r} moves with the joints '
                             f'{show_names(base.moving_joints)}: it must be fixed to the world')
        # Planned joints that move the tool, also through a joint that follows
        # them (URDF <mimic>), which the kinematics drive from their parent.
        if not self.tool.driving_columns:
            raise ValueError(f'tool_frame {tool_frame!r} moves with none of the joints '
                             f'{show_names(self.joint_names)}')
        n = len(self.joints)
        self.base_pos, self.base_quat = base.pose(np.zeros(n))
        self._base_mat = rot.to_matrix(self.base_quat)
        self._qpos = np.array([j.qpos for j in self.joints], dtype=int)
        self._dof = np.array([j.dof for j in self.joints], dtype=int)
        model = robot.model
        self._data = self.mujoco.MjData(model)
        self._hold = robot.hold_positions()
        self._jac = np.zeros((6, model.nv))
        self._jacp = self._jac[:3]  # contiguous row blocks, filled by mj_jac
        self._jacr = self._jac[3:]
        self._reach = self.tool.reach()
        self._cache = {}
        self._reached = {}  # pose -> (the pose it was walked from, its joints)
        self._seed = None
        self.seed = robot.default_seed(self.joints) if seed is None else self.check_seed(seed)

    @property
    def seed(self):
        """Return the joints (n,) the first pose is reached from (its branch is kept)."""
        return self._seed

    @seed.setter
    def seed(self, value):
        """Set the seed; a different one forgets every remembered walk (another branch)."""
        value = np.array(value, dtype=float)
        if self._seed is None or value.shape != self._seed.shape or \
                np.any(value != self._seed):
            self.forget_walks()
        self._seed = value

    def forget_walks(self):
        """
        Forget every remembered walk: the next :meth:`inverse` walks all its poses afresh.

        A redundant arm's joints at a pose depend on the walk that reached
        it; a dense walk along lines must not jump to a pose's joints from
        an earlier, coarser walk (:mod:`tool_lines`).
        """
        self._cache.clear()
        self._reached.clear()

    @property
    def n_joints(self):
        """Return the number of planned joints."""
        return len(self.joints)

    def check_seed(self, seed):
        """Return ``seed`` (n,) as an array inside the joint ranges (ValueError otherwise)."""
        q = np.asarray(seed, dtype=float)
        if q.shape != (self.n_joints,) or not np.all(np.isfinite(q)):
            raise ValueError(f'the seed needs {self.n_joints} finite joint positions, got '
                             f'{q.tolist()}')
        return np.clip(q, self.lower, self.upper)

    # ------------------------------------------------------------------ forward

    def forward(self, joints):
        """Return tool poses (..., 7) = (x, y, z, qw, qx, qy, qz) in the base frame."""
        pos, mat = self.tool.transform(joints)
        base = self._base_mat
        pos = (pos - self.base_pos) @ base          # R_base^T (p - p_base)
        mat = np.swapaxes(base, -1, -2) @ mat
        return np.concatenate([pos, rot.from_matrix(mat)], axis=-1)

    def forward_transform(self, joints):
        """Return tool positions (..., 3) and rotation matrices (..., 3, 3) in the base frame."""
        pos, mat = self.tool.transform(joints)
        base = self._base_mat
        return (pos - self.base_pos) @ base, np.swapaxes(base, -1, -2) @ mat

    def _to_world(self, pose):
        quat = np.empty(4)
        self.mujoco.mju_mulQuat(quat, self.base_quat, np.ascontiguousarray(pose[3:]))
        return self.base_pos + self._base_mat @ pose[:3], quat

    def _world_pose(self, q, jacobian=False):
        """Return MuJoCo's world pose of the tool at joints ``q`` (and its Jacobian (6, n))."""
        mj, m, d = self.mujoco, self.robot.model, self._data
        d.qpos[:] = self._hold
        d.qpos[self._qpos] = q
        driven = self.tool.driven_positions(q) if self.tool.driven else ()
        for adr, _, _, value, _ in driven:
            d.qpos[adr] = value  # a joint that follows another one (mimic)
        mj.mj_kinematics(m, d)
        body = self.tool.body
        quat = np.empty(4)
        mj.mju_mulQuat(quat, d.xquat[body], self.tool.offset_quat)
        offset = np.empty(3)
        mj.mju_rotVecQuat(offset, self.tool.offset_pos, d.xquat[body])
        pos = d.xpos[body] + offset
        if not jacobian:
            return pos, quat, None
        mj.mj_comPos(m, d)
        mj.mj_jac(m, d, self._jacp, self._jacr, pos, body)
        jac = self._jac[:, self._dof]
        for _, dof, col, _, slope in driven:
            if col is not None:
                jac[:, col] += slope * self._jac[:, dof]  # chain rule through the mimic
        return pos, quat, jac

    # ------------------------------------------------------------------ inverse

    def solve(self, target_pos, target_quat, start, tolerance=POSITION_TOLERANCE,
              accept=None):
        """
        Damped least squares from ``start`` to a world pose; return (q, converged, residual).

        ``residual`` is (position error [m], orientation error [rad]) of q.
        The iterations stop within ``tolerance``; when they run out, q is
        converged if within ``accept`` (default ``tolerance``).  A joint on
        a limit that a step would push beyond is left out of that step (the
        others then solve for the pose without it) instead of being clipped
        afterwards, which stalled the steps short of the pose.
        """
        mj = self.mujoco
        q = np.array(start, dtype=float)
        damping = np.full(6, DAMPING ** 2)
        step = np.empty(6)
        error = (math.inf, math.inf)
        target_quat = np.ascontiguousarray(target_quat, dtype=float)
        inverse, turn, e = np.empty(4), np.empty(4), np.empty(6)
        for iteration in range(MAX_ITERATIONS + 1):
            pos, quat, jac = self._world_pose(q, jacobian=True)
            e[:3] = target_pos - pos
            # World-frame rotation from the tool to the target, as a rotation vector.
            mj.mju_negQuat(inverse, quat)
            mj.mju_mulQuat(turn, target_quat, inverse)
            if turn[0] < 0.0:
                turn *= -1.0
            e_rot = e[3:]
            mj.mju_quat2Vel(e_rot, turn, 1.0)
            error = (math.sqrt(e[0] ** 2 + e[1] ** 2 + e[2] ** 2),
                     math.sqrt(e[3] ** 2 + e[4] ** 2 + e[5] ** 2))
            if error[0] <= tolerance and error[1] <= tolerance:
                return q, True, error
            if iteration == MAX_ITERATIONS:
                break
            dq = self._step(jac, e, damping, step, q)
            largest = float(np.max(np.abs(dq)))
            if largest > MAX_UPDATE:
                dq *= MAX_UPDATE / largest
            q = np.clip(q + dq, self.lower, self.upper)
        accept = tolerance if accept is None else accept
        return q, bool(error[0] <= accept and error[1] <= accept), error

    def _step(self, jac, e, damping, step, q):
        """Return the damped least-squares step of joints q, without joints held on a limit."""
        mj = self.mujoco
        blocked = np.zeros(len(q), dtype=bool)
        for _ in range(len(q)):
            # (J J^T + lambda^2 I) is symmetric positive definite: MuJoCo's
            # Cholesky, far cheaper than a LAPACK call on a 6x6 system.
            normal = jac @ jac.T
            normal[np.diag_indices(6)] += damping
            mj.mju_cholFactor(normal, 0.0)
            mj.mju_cholSolve(step, normal, e)
            dq = jac.T @ step
            pushed = ((q <= self.lower) & (dq < 0.0)) | ((q >= self.upper) & (dq > 0.0))
            if not pushed.any():
                return dq
            blocked |= pushed
            jac[:, blocked] = 0.0
        dq[blocked] = 0.0
        return dq

    def inverse(self, poses):
        """
        Return joint positions (K, n) of tool poses (K, 7), continuous along K.

        Raises :class:`KinematicsError` (a ValueError naming the pose) for an
        unreachable pose or a branch flip between neighbours.
        """
        rows = pose_rows(poses)
        out = np.empty((len(rows), self.n_joints))
        q = self.seed.copy()
        pos, quat, _ = self._world_pose(q)
        previous = None
        for k, row in enumerate(rows):
            target = self._to_world(row)
            self._check_reach(k, row, target[0])
            # The walk from the previous pose is deterministic: a refinement that asks
            # again for the same pair of poses from (nearly) the same joints gets the
            # same answer without walking again.
            key = (None if previous is None else previous.tobytes(), row.tobytes())
            cached = self._cache.get(key)
            if cached is None or np.max(np.abs(cached[0] - q)) > CACHE_MATCH:
                reached = self._reached.get(row.tobytes()) if k > 0 else None
                if reached is not None and _between(reached[0], previous, row):
                    # The previous pose was inserted on the line this pose was walked
                    # along before (a refinement's midpoint): that walk's end is this
                    # walk's end.
                    solution = reached[1]
                elif k == 0:
                    solution = self._first(row, target, q, (pos, quat))
                else:
                    solution = self._follow(k, row, (pos, quat), target, q)
                if len(self._cache) >= _CACHE_SIZE:
                    self._cache.clear()
                    self._reached.clear()
                cached = (q.copy(), solution)
                self._cache[key] = cached
                if previous is not None and reached is None:
                    self._reached[row.tobytes()] = (previous, solution)
            q = cached[1].copy()
            out[k] = q
            pos, quat = target
            previous = row
        return out

    def _check_reach(self, k, row, position):
        """Refuse a pose farther from the tool chain's first joint than the chain is long."""
        if self._reach is None:
            return
        pivot, radius, joint = self._reach
        distance = float(np.linalg.norm(position - pivot))
        if distance > radius * (1.0 + 1e-9) + 1e-12:
            at = (pivot - self.base_pos) @ self._base_mat
            raise KinematicsError(k, row, (
                f'is out of reach: it is {distance:.3g} m from joint {joint} (at '
                f'({at[0]:.3g}, {at[1]:.3g}, {at[2]:.3g}) m in the base frame), and '
                f'{self.tool_frame} stays within {radius:.3g} m of it (the sum of the '
                f'lengths between the joints)'))

    def _follow(self, k, row, start, target, q):
        """Walk from the world pose ``start`` (joints q) to ``target``; return the joints."""
        (p0, q0), (p1, q1) = start, target
        distance = float(np.linalg.norm(p1 - p0))
        # The slerp as q0 * (rotation by s * angle about a fixed axis), the short way.
        turn = rot.multiply(rot.conjugate(q0), q1)
        if turn[0] < 0.0:
            turn = -turn
        sine = float(np.linalg.norm(turn[1:]))
        angle = 2.0 * math.atan2(sine, float(turn[0]))
        axis = turn[1:] / sine if sine > 1e-15 else np.array([1.0, 0.0, 0.0])
        steps = max(1, math.ceil(distance / CONTINUATION_STEP),
                    math.ceil(angle / CONTINUATION_ANGLE))
        local = np.empty(4)
        quat = np.empty(4)
        for i in range(1, steps + 1):
            s = i / steps
            last = i == steps
            p = p0 + s * (p1 - p0)
            if last:
                quat = q1
            else:
                local[0] = math.cos(0.5 * s * angle)
                local[1:] = math.sin(0.5 * s * angle) * axis
                self.mujoco.mju_mulQuat(quat, q0, local)
            if last:
                new, ok, error = self.solve(p, quat, q, POSITION_TOLERANCE, ACCEPT_TOLERANCE)
            else:
                new, ok, error = self.solve(p, quat, q, STEP_TOLERANCE)
            if not ok:
                raise KinematicsError(k, row, (
                    f'is out of reach within the joint ranges: the tool stops '
                    f'{error[0]:.3g} m and {error[1]:.3g} rad short of the straight line from '
                    f'the previous pose, {100.0 * s:.0f} % of the way'))
            jump = np.abs(new - q)
            j = int(np.argmax(jump))
            if jump[j] > MAX_JOINT_STEP:
                raise KinematicsError(k, row, (
                    f'needs a branch flip or passes near a singularity: on the way from the '
                    f'previous pose ({100.0 * s:.0f} % of it) joint {self.joint_names[j]} jumps '
                    f'{jump[j]:.3g} rad for {distance / steps:.3g} m and {angle / steps:.3g} '
                    f'rad of tool motion (more than {MAX_JOINT_STEP} allowed)'))
            q = new
        return q

    def _first(self, row, target, seed, seed_pose):
        """Reach the first pose from the seed: walk there, else solve directly."""
        try:
            return self._follow(0, row, seed_pose, target, seed)
        except KinematicsError:
            pass
        rng = np.random.default_rng(0)
        lower = np.where(np.isfinite(self.lower), self.lower, -math.pi)
        upper = np.where(np.isfinite(self.upper), self.upper, math.pi)
        starts = [seed] + [rng.uniform(lower, upper) for _ in range(FIRST_POSE_RESTARTS)]
        best, best_error = None, None
        for start in starts:
            q, ok, error = self.solve(*target, start, accept=ACCEPT_TOLERANCE)
            if ok and (best is None or np.linalg.norm(q - seed) < np.linalg.norm(best - seed)):
                best = q
            if best_error is None or sum(error) < sum(best_error):
                best_error = error
        if best is None:
            raise KinematicsError(0, row, (
                f'is out of reach within the joint ranges (closest: {best_error[0]:.3g} m, '
                f'{best_error[1]:.3g} rad away, from {len(starts)} starts)'))
        return best


def _between(start, middle, end, tolerance=1e-9):
    """Return True when pose ``middle`` lies on the line and slerp from ``start`` to ``end``."""
    a, m, b = start[:3], middle[:3], end[:3]
    if (np.linalg.norm(m - a) + np.linalg.norm(b - m) - np.linalg.norm(b - a)) > tolerance:
        return False
    angles = rot.angle_between(np.array([start[3:], middle[3:], start[3:]]),
                               np.array([middle[3:], end[3:], end[3:]]))
    return bool(angles[0] + angles[1] - angles[2] <= tolerance)
