"""
A robot from its description: a URDF or MJCF file, or a URDF string, compiled by MuJoCo.

Pure Python (numpy, MuJoCo, xml.etree): no rclpy.  :func:`load_robot_model`
returns a :class:`RobotModel` with

* the actuated joints, in the model's order: every hinge or slide joint that is
  not driven by another one (URDF ``<mimic>``, which MuJoCo turns into a joint
  equality; an MJCF joint equality's first joint likewise);
* their position ranges (``-inf, inf`` when unlimited, e.g. URDF
  ``continuous``);
* for a URDF, each joint's ``<limit velocity effort>`` (MuJoCo keeps the
  effort as the joint's actuator force range but drops the velocity, so both
  are read here from the XML);
* :meth:`RobotModel.frame_chain`: vectorised forward kinematics of any frame
  (a URDF link, an MJCF body or site) in any fixed frame.

URDF import
-----------
The URDF is read with :mod:`xml.etree.ElementTree` (a string larger than
:data:`MAX_DESCRIPTION_CHARS`, or one declaring XML entities, is refused),
then handed to MuJoCo with ``<mujoco><compiler fusestatic="false"
discardvisual="true" balanceinertia="true"/></mujoco>``: ``fusestatic="false"``
keeps the bodies of fixed-joint links such as ``tool0``, which MuJoCo would
otherwise merge into their parent and lose as frames.  Kinematics needs no
meshes: every ``<visual>`` is removed (MuJoCo discards visuals anyway), and
a ``<collision>`` mesh is kept only when its file is found (absolute path,
``file://``, relative to the URDF's folder, or ``package://pkg/rest`` as
``rest`` below one of the URDF's parent folders) and MuJoCo can read its
format (STL, OBJ, MSH).  What was dropped is said once, in
:attr:`RobotModel.notes` and on the Python log.
"""

from dataclasses import dataclass
import logging
import math
import os
from typing import Optional
import xml.etree.ElementTree as ET

import numpy as np

from . import rotations as rot
from .mujoco_import import import_mujoco

MAX_DESCRIPTION_CHARS = 20_000_000
MESH_FORMATS = ('.stl', '.obj', '.msh')
_LOG = logging.getLogger('splines445_ros.robot_model')


@dataclass(frozen=True)
class JointInfo:
    """One actuated joint of a robot model."""

    name: str
    kind: str                     # 'hinge' (revolute, continuous) or 'slide' (prismatic)
    lower: float                  # position range [rad or m], -inf when unlimited
    upper: float                  # +inf when unlimited
    velocity: Optional[float]     # URDF <limit velocity>; None when not given
    effort: Optional[float]       # URDF <limit effort>; None when not given
    qpos: int                     # MuJoCo qpos address
    dof: int                      # MuJoCo dof address
    joint_id: int


def _float_attribute(element, name, joint):
    text = element.get(name)
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f'joint {joint!r}: <limit {name}="{text}"> is not a number') from None
    if math.isnan(value):
        raise ValueError(f'joint {joint!r}: <limit {name}> is NaN')
    return value


class _UrdfDescription:
    """What MuJoCo drops from a URDF, and the cleaned text MuJoCo compiles."""

    def __init__(self, text, where, base_dir):
        if len(text) > MAX_DESCRIPTION_CHARS:
            raise ValueError(f'{where} has {len(text)} characters, more than the '
                             f'{MAX_DESCRIPTION_CHARS} accepted')
        if '<!ENTITY' in text:
            raise ValueError(f'{where} declares XML entities, which are not accepted')
        try:
            root = ET.fromstring(text)
        except ET.ParseError as exc:
            raise ValueError(f'{where} is not well-formed XML: {exc}') from None
        if root.tag != 'robot':
            raise ValueError(f'{where} is not a URDF (its root element is <{root.tag}>, '
                             'not <robot>)')
        self.limits = {}
        self.mimic = set()
        for joint in root.findall('joint'):
            name = joint.get('name', '')
            limit = joint.find('limit')
            if limit is not None:
                self.limits[name] = (_float_attribute(limit, 'velocity', name),
                                     _float_attribute(limit, 'effort', name))
            if joint.find('mimic') is not None:
                self.mimic.add(name)
        dropped = []
        for link in root.findall('link'):
            for visual in link.findall('visual'):
                link.remove(visual)
            for collision in link.findall('collision'):
                mesh = collision.find('geometry/mesh')
                if mesh is None:
                    continue
                uri = mesh.get('filename', '')
                path = _resolve_mesh(uri, base_dir)
                if path is None:
                    link.remove(collision)
                    dropped.append(uri)
                else:
                    mesh.set('filename', path)
        self.notes = []
        if dropped:
            self.notes.append(
                f'{where}: {len(dropped)} collision mesh(es) not found or not readable by '
                f'MuJoCo were dropped (kinematics does not need them), e.g. {dropped[0]!r}; '
                'visuals are never loaded')
        extension = root.find('mujoco')
        if extension is None:
            extension = ET.SubElement(root, 'mujoco')
        compiler = extension.find('compiler')
        if compiler is None:
            compiler = ET.SubElement(extension, 'compiler')
        compiler.set('fusestatic', 'false')
        compiler.set('discardvisual', 'true')
        compiler.set('balanceinertia', 'true')
        compiler.set('boundmass', '1e-6')
        compiler.set('boundinertia', '1e-9')
        self.text = ET.tostring(root, encoding='unicode')


def _resolve_mesh(uri, base_dir):
    """Return the absolute path of a mesh MuJoCo can read, or None."""
    if not uri.lower().endswith(MESH_FORMATS):
        return None
    candidates = []
    if uri.startswith('package://'):
        rest = uri[len('package://'):].partition('/')[2]
        folder = base_dir
        while folder and rest:
            candidates.append(os.path.join(folder, rest))
            parent = os.path.dirname(folder)
            if parent == folder:
                break
            folder = parent
    elif uri.startswith('file://'):
        candidates.append(uri[len('file://'):])
    elif os.path.isabs(uri):
        candidates.append(uri)
    elif base_dir:
        candidates.append(os.path.join(base_dir, uri))
    for path in candidates:
        if os.path.isfile(path):
            return os.path.abspath(path)
    return None


def _drop_mjcf_meshes(mujoco, spec):
    """Delete every mesh geom and mesh asset of an MJCF spec; return how many geoms."""
    count = 0
    for geom in list(spec.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            spec.delete(geom)
            count += 1
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    return count


class RobotModel:
    """A compiled MuJoCo model of a robot with its actuated joints and URDF limits."""

    def __init__(self, model, kind, source, urdf_limits=None, mimic=(), notes=()):
        """Wrap a compiled ``mujoco.MjModel``; use :func:`load_robot_model` instead."""
        self.mujoco = import_mujoco()
        self.model = model
        self.kind = kind          # 'urdf' or 'mjcf'
        self.source = source      # file path, or 'robot_description'
        self.notes = tuple(notes)
        mj = self.mujoco
        urdf_limits = urdf_limits or {}
        driven = set()
        for e in range(model.neq):
            if int(model.eq_type[e]) == int(mj.mjtEq.mjEQ_JOINT):
                driven.add(int(model.eq_obj1id[e]))
        kinds = {int(mj.mjtJoint.mjJNT_HINGE): 'hinge', int(mj.mjtJoint.mjJNT_SLIDE): 'slide'}
        joints = []
        for j in range(model.njnt):
            name = mj.mj_id2name(model, mj.mjtObj.mjOBJ_JOINT, j) or f'joint{j}'
            kind = kinds.get(int(model.jnt_type[j]))
            if kind is None or j in driven or name in mimic:
                continue
            lower, upper = -math.inf, math.inf
            if model.jnt_limited[j]:
                lower, upper = (float(v) for v in model.jnt_range[j])
            velocity, effort = urdf_limits.get(name, (None, None))
            joints.append(JointInfo(name, kind, lower, upper, velocity, effort,
                                    int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), j))
        self.joints = tuple(joints)

    @property
    def joint_names(self):
        """Return the actuated joints' names, in the model's order."""
        return tuple(j.name for j in self.joints)

    def joint(self, name):
        """Look up an actuated joint by name: its JointInfo (ValueError naming the others)."""
        for info in self.joints:
            if info.name == name:
                return info
        raise ValueError(f'{self.describe()} has no actuated joint {name!r}; its actuated '
                         f'joints: {list(self.joint_names)}')

    def select(self, joint_names=()):
        """Return the JointInfo of ``joint_names`` (all actuated joints when empty)."""
        if not joint_names:
            return self.joints
        if len(set(joint_names)) != len(joint_names):
            raise ValueError(f'joint_names has duplicates: {list(joint_names)}')
        return tuple(self.joint(n) for n in joint_names)

    def describe(self):
        """Return a short text naming the model, for error messages."""
        return f'the {self.kind.upper()} model {self.source!r}'

    def frame(self, name, parameter='frame'):
        """
        Return ``(body id, position offset (3,), quaternion offset (4,))`` of a frame.

        ``name`` is an MJCF site, else a body (an URDF link); ``''`` is the
        world.  ValueError names the frames there are.
        """
        mj, m = self.mujoco, self.model
        if not name:
            return 0, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
        site = mj.mj_name2id(m, mj.mjtObj.mjOBJ_SITE, name)
        if site >= 0:
            return (int(m.site_bodyid[site]), m.site_pos[site].copy(),
                    m.site_quat[site].copy())
        body = mj.mj_name2id(m, mj.mjtObj.mjOBJ_BODY, name)
        if body >= 0:
            return body, np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
        bodies = [mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b) for b in range(m.nbody)]
        sites = [mj.mj_id2name(m, mj.mjtObj.mjOBJ_SITE, s) for s in range(m.nsite)]
        known = [n for n in bodies + sites if n]
        shown = ', '.join(known[:40]) + (' ...' if len(known) > 40 else '')
        raise ValueError(f'{parameter} {name!r} is not a link, body or site of '
                         f'{self.describe()}; it has: {shown}')

    def frame_chain(self, frame, joint_names=(), parameter='frame'):
        """Return a :class:`FrameChain`: the world pose of ``frame`` as a function of joints."""
        return FrameChain(self, frame, self.select(joint_names), parameter)

    def hold_positions(self):
        """Return the model's reference positions qpos0 (nq,), where unplanned joints stay."""
        return self.model.qpos0.copy()

    def default_seed(self, joints):
        """Return a start configuration (n,): keyframe 'home', else qpos0 moved into range."""
        mj, m = self.mujoco, self.model
        key = mj.mj_name2id(m, mj.mjtObj.mjOBJ_KEY, 'home')
        qpos = m.key_qpos[key] if key >= 0 else m.qpos0
        seed = np.array([qpos[j.qpos] for j in joints], dtype=float)
        for i, j in enumerate(joints):
            if not j.lower <= seed[i] <= j.upper:
                seed[i] = 0.5 * (j.lower + j.upper)
        return seed


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


def load_robot_model(model_file='', urdf_string=None, where=None):
    """
    Load a robot from a URDF or MJCF file, or a URDF string (ValueError with the reason).

    A file is a URDF when its root element is ``<robot>``, else MJCF.
    ``where`` names a string's origin in messages (default
    ``robot_description``).
    """
    mujoco = import_mujoco()
    if urdf_string is not None:
        where = where or 'robot_description'
        if not isinstance(urdf_string, str) or not urdf_string.strip():
            raise ValueError(f'{where} is empty')
        return _from_urdf(mujoco, urdf_string, where, None, where)
    if not model_file:
        raise ValueError('no model: model_file is empty')
    where = where or f'model_file {model_file!r}'
    if not os.path.isfile(model_file):
        raise ValueError(f'{where}: no such file')
    size = os.path.getsize(model_file)
    if size > MAX_DESCRIPTION_CHARS:
        raise ValueError(f'{where} has {size} bytes, more than the {MAX_DESCRIPTION_CHARS} '
                         'accepted')
    try:
        with open(model_file, encoding='utf-8') as stream:
            text = stream.read()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f'{where}: cannot read it ({exc})') from None
    if _root_tag(text) == 'robot':
        return _from_urdf(mujoco, text, where, os.path.dirname(os.path.abspath(model_file)),
                          model_file)
    return _from_mjcf(mujoco, model_file, where)


def _root_tag(text):
    try:
        for _, element in ET.iterparse(_Lines(text), events=('start',)):
            return element.tag
    except ET.ParseError:
        return None
    return None


class _Lines:
    """A minimal file object over a string for :func:`ET.iterparse`."""

    def __init__(self, text):
        self._text = text
        self._at = 0

    def read(self, size=-1):
        if size is None or size < 0:
            size = len(self._text)
        chunk = self._text[self._at:self._at + size]
        self._at += len(chunk)
        return chunk


def _from_urdf(mujoco, text, where, base_dir, source):
    description = _UrdfDescription(text, where, base_dir)
    try:
        spec = mujoco.MjSpec.from_string(description.text)
        model = spec.compile()
    except Exception as exc:  # mujoco raises ValueError or its own errors
        raise ValueError(f'MuJoCo cannot load {where}: {str(exc).strip()}') from None
    for note in description.notes:
        _LOG.warning(note)
    return RobotModel(model, 'urdf', source, description.limits, description.mimic,
                      description.notes)


def _from_mjcf(mujoco, path, where):
    notes = []
    try:
        spec = mujoco.MjSpec.from_file(path)
    except Exception as exc:
        raise ValueError(f'cannot load MJCF {where}: {str(exc).strip()}') from None
    try:
        model = spec.compile()
    except Exception as first:
        try:
            spec = mujoco.MjSpec.from_file(path)
            dropped = _drop_mjcf_meshes(mujoco, spec)
            model = spec.compile()
        except Exception:
            raise ValueError(f'cannot compile MJCF {where}: {str(first).strip()}') from None
        notes.append(f'{where}: {dropped} mesh geom(s) dropped since the model did not '
                     f'compile with them ({str(first).strip()})')
        _LOG.warning(notes[-1])
    return RobotModel(model, 'mjcf', path, notes=notes)


def joint_ranges(joints):
    """Return the lower and upper position bounds (n,) of JointInfo ``joints``."""
    return (np.array([j.lower for j in joints], dtype=float),
            np.array([j.upper for j in joints], dtype=float))


def urdf_spec(mujoco, path):
    """
    Return an MjSpec of the URDF file ``path`` for simulation, or None when it is not a URDF.

    The URDF is cleaned as for :func:`load_robot_model`; contacts are
    disabled (a URDF arm has no environment, and its collision meshes touch
    between links).
    """
    try:
        with open(path, encoding='utf-8') as stream:
            text = stream.read(MAX_DESCRIPTION_CHARS + 1)
    except (OSError, UnicodeDecodeError):
        return None
    if _root_tag(text) != 'robot':
        return None
    where = f'model_file {path!r}'
    description = _UrdfDescription(text, where, os.path.dirname(os.path.abspath(path)))
    for note in description.notes:
        _LOG.warning(note)
    try:
        spec = mujoco.MjSpec.from_string(description.text)
    except Exception as exc:  # mujoco raises ValueError or its own errors
        raise ValueError(f'MuJoCo cannot load {where}: {str(exc).strip()}') from None
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return spec
