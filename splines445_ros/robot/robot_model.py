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
:attr:`RobotModel.notes` and on the Python log (there once per process,
however often the file is read).

A revolute or prismatic joint's ``<limit lower upper>`` must be finite
numbers with ``lower <= upper`` (MuJoCo would drop an upside-down range and
leave the joint unlimited); ``lower == upper`` holds the joint there (MuJoCo
drops that range too; :class:`JointInfo` keeps it).

Size caps
---------
MuJoCo's compile time grows faster than linearly with the number of bodies
(the UR5 plus 60,000 fixed links: two minutes).  Before MuJoCo sees it, a
description is counted with ElementTree and refused, with the count and the
cap, when it has more than :data:`MAX_LINKS` links (MJCF bodies, including
``<replicate>`` copies), :data:`MAX_JOINTS` joints, or a link more than
:data:`MAX_DEPTH` links from the root (MJCF: bodies nested that deep).  Real
robots stay far below (a humanoid has about 100 links).  An MJCF's
``<include>`` files are checked and counted too, and its asset files
(meshes, textures, height fields, skins) must be regular files of at most
:data:`MAX_ASSET_BYTES` (:func:`check_mjcf`): MuJoCo opens them itself.
"""

from dataclasses import dataclass
import logging
import math
import os
from typing import Optional
import xml.etree.ElementTree as ET

import numpy as np

from .frame_chain import FrameChain
from .mujoco_import import import_mujoco
from .user_text import check_text_file, clip, read_text_file, show, show_names, show_path

MAX_DESCRIPTION_CHARS = 20_000_000
MAX_LINKS = 1000    # URDF links, MJCF bodies
MAX_JOINTS = 1000   # URDF joints (fixed ones too), MJCF joints
MAX_DEPTH = 200     # links from the root to the deepest one (MJCF: nested bodies)
MAX_INCLUDE_DEPTH = 10          # MJCF <include> levels
MAX_ASSET_BYTES = 100_000_000   # one mesh, texture, height field or skin file (MJCF)
MESH_FORMATS = ('.stl', '.obj', '.msh')
_LOG = logging.getLogger('splines445_ros.robot_model')
# Notes already logged: a file read again (the planner's model, the arm's model and
# its controller's rigid copy, every reload) is not noted again.  Bounded.
_LOGGED_NOTES = set()
MAX_LOGGED_NOTES = 1000


def _log_note(note):
    """Log a note about a description on the Python log once per process."""
    if note in _LOGGED_NOTES:
        return
    if len(_LOGGED_NOTES) < MAX_LOGGED_NOTES:
        _LOGGED_NOTES.add(note)
    _LOG.warning(note)


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


def _float_attribute(element, name, joint, where, finite=False, default=None):
    """Return a ``<limit>`` attribute as a float (``default`` when absent; ValueError)."""
    text = element.get(name)
    if text is None:
        return default
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f'{where}: joint {show(joint)}: <limit {name}="{clip(text)}"> is not '
                         'a number') from None
    if finite and not math.isfinite(value):
        raise ValueError(f'{where}: joint {show(joint)}: <limit> {name}="{clip(text)}" is not '
                         'a finite number')
    if math.isnan(value):
        raise ValueError(f'{where}: joint {show(joint)}: <limit {name}> is NaN')
    return value


def _check_range(limit, joint, where):
    """Return a revolute or prismatic joint's (lower, upper) (URDF default 0; ValueError)."""
    lower = _float_attribute(limit, 'lower', joint, where, finite=True, default=0.0)
    upper = _float_attribute(limit, 'upper', joint, where, finite=True, default=0.0)
    if lower > upper:
        raise ValueError(f'{where}: joint {show(joint)}: <limit> '
                         f'lower="{clip(limit.get("lower"))}" is above '
                         f'upper="{clip(limit.get("upper", "0"))}"')
    return lower, upper


def _check_urdf_size(root, where):
    """Refuse a URDF with more links, joints or depth than the caps (ValueError)."""
    links = root.findall('link')
    joints = root.findall('joint')
    if len(links) > MAX_LINKS:
        raise ValueError(f'{where} has {len(links)} links, more than the {MAX_LINKS} '
                         'accepted')
    if len(joints) > MAX_JOINTS:
        raise ValueError(f'{where} has {len(joints)} joints, more than the {MAX_JOINTS} '
                         'accepted')
    parent_of = {}
    for joint in joints:
        parent, child = joint.find('parent'), joint.find('child')
        if parent is not None and child is not None:
            parent_of[child.get('link')] = parent.get('link')
    link, depth = _deepest(parent_of)
    if depth > MAX_DEPTH:
        raise ValueError(f'{where}: link {show(link)} is {depth} links deep (from the root '
                         f'link), more than the {MAX_DEPTH} accepted')


def _deepest(parent_of):
    """
    Return ``(link, depth)`` of the deepest link of a tree given as {child: parent}.

    A root (a link that is no joint's child) has depth 1.  Linear in the
    number of links; a loop (not a tree: MuJoCo refuses it) does not hang it.
    """
    depth = {}
    deepest = (None, 0)
    for link in parent_of:
        path, seen, node = [], set(), link
        while node in parent_of and node not in depth and node not in seen:
            seen.add(node)
            path.append(node)
            node = parent_of[node]
        if node not in parent_of:
            depth.setdefault(node, 1)
        level = depth.get(node, 0)
        for item in reversed(path):
            level += 1
            depth[item] = level
            if level > deepest[1]:
                deepest = (item, level)
    return deepest


# The numbers of a URDF's kinematics and inertia (element, child path, attributes):
# MuJoCo loads NaN, inf or 1e308 there without a word, and every request then
# fails obscurely ("cannot convert float NaN to integer", helper-47).
_URDF_NUMBERS = (('joint', 'origin', ('xyz', 'rpy')), ('joint', 'axis', ('xyz',)),
                 ('joint', 'mimic', ('multiplier', 'offset')),
                 ('link', 'inertial/origin', ('xyz', 'rpy')),
                 ('link', 'inertial/mass', ('value',)),
                 ('link', 'inertial/inertia', ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz')))
# ... and the largest magnitude taken there [m, rad, kg, kg m^2]: far beyond any arm.
MAX_URDF_NUMBER = 1e6


def _check_urdf_numbers(root, where):
    """Refuse a URDF origin, axis, mimic or inertial number that is not finite or absurd."""
    for parent_tag, path, attributes in _URDF_NUMBERS:
        for parent in root.findall(parent_tag):
            for element in parent.findall(path):
                for attribute in attributes:
                    text = element.get(attribute)
                    if text is None:
                        continue
                    try:
                        values = [float(word) for word in text.split()]
                    except ValueError:
                        values = [math.nan]
                    if not all(abs(v) <= MAX_URDF_NUMBER for v in values):
                        raise ValueError(
                            f'{where}: {parent_tag} {show(parent.get("name", ""))}: '
                            f'<{element.tag} {attribute}={show(text)}> must be finite numbers '
                            f'of at most {MAX_URDF_NUMBER:g} in magnitude')


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
            raise _not_well_formed(where, exc) from None
        if root.tag != 'robot':
            raise ValueError(f'{where} is not a URDF (its root element is <{clip(root.tag)}>, '
                             'not <robot>)')
        _check_urdf_size(root, where)
        _check_urdf_numbers(root, where)
        self.limits = {}
        self.mimic = set()
        self.held = {}         # joint -> position, for a range with lower == upper
        self.joint_names = []  # every <joint>, fixed ones too
        for joint in root.findall('joint'):
            name = joint.get('name', '')
            self.joint_names.append(name)
            limit = joint.find('limit')
            if limit is not None:
                self.limits[name] = (_float_attribute(limit, 'velocity', name, where),
                                     _float_attribute(limit, 'effort', name, where))
                if joint.get('type') in ('revolute', 'prismatic'):
                    lower, upper = _check_range(limit, name, where)
                    if lower == upper:
                        self.held[name] = lower
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
                f'{where}: {len(dropped)} collision mesh(es) not found, not readable by '
                f'MuJoCo or above {MAX_ASSET_BYTES} bytes were dropped (kinematics does '
                f'not need them), e.g. {show(dropped[0])}; visuals are never loaded')
        if self.held:
            held = ', '.join(f'{show(n)} at {v:g}' for n, v in list(self.held.items())[:5])
            self.notes.append(
                f'{where}: {len(self.held)} joint(s) with <limit lower> = <limit upper> are '
                f'held there ({held}); MuJoCo would leave them unlimited')
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
        try:
            self.text = ET.tostring(root, encoding='unicode')
        except RecursionError:
            raise ValueError(f'{where}: its elements nest too deep to read') from None


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
        if os.path.isfile(path) and os.path.getsize(path) <= MAX_ASSET_BYTES:
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

    def __init__(self, model, kind, source, urdf_limits=None, mimic=(), notes=(), held=None,
                 all_joint_names=None):
        """
        Wrap a compiled ``mujoco.MjModel``; use :func:`load_robot_model` instead.

        ``held``: {joint: position} of URDF joints whose range is that one
        position (MuJoCo leaves them unlimited); ``all_joint_names``: every
        joint of the description (None: the MuJoCo model's joints).
        """
        self.mujoco = import_mujoco()
        self.model = model
        self.kind = kind          # 'urdf' or 'mjcf'
        self.source = source      # file path, or 'robot_description'
        self.notes = tuple(notes)
        mj = self.mujoco
        urdf_limits = urdf_limits or {}
        held = held or {}
        if all_joint_names is None:
            all_joint_names = [mj.mj_id2name(model, mj.mjtObj.mjOBJ_JOINT, j) or ''
                               for j in range(model.njnt)]
        self.all_joint_names = tuple(n for n in all_joint_names if n)
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
            elif name in held:
                lower = upper = held[name]
            velocity, effort = urdf_limits.get(name, (None, None))
            joints.append(JointInfo(name, kind, lower, upper, velocity, effort,
                                    int(model.jnt_qposadr[j]), int(model.jnt_dofadr[j]), j))
        self.joints = tuple(joints)

    @property
    def root_link(self):
        """
        Return the URDF's root link, where the model's world is; None for MJCF or where unclear.

        The one body on MuJoCo's world, at its origin unrotated, fixed to it
        (no joint: a URDF whose root link is ``world`` with a revolute or
        prismatic joint to the next link has a moving first body, helper-91):
        tool poses "in the world" are in its frame, which TF knows by that
        name (``panda_link0``, ``base_link``); RViz has no frame ``world``
        for a Panda (helper-90).  None for an MJCF model (its world is ``world``)
        and where several bodies, or one away from the origin, hang from it.
        """
        if self.kind != 'urdf':
            return None
        m, mj = self.model, self.mujoco
        roots = [b for b in range(1, m.nbody) if int(m.body_parentid[b]) == 0]
        if len(roots) != 1:
            return None
        b = roots[0]
        if (int(m.body_jntnum[b]) or np.any(m.body_pos[b] != 0.0)
                or np.any(m.body_quat[b] != (1.0, 0.0, 0.0, 0.0))):
            return None     # it moves (a URDF root `world` with a joint to it), or sits away
        return mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b) or None

    @property
    def joint_names(self):
        """Return the actuated joints' names, in the model's order."""
        return tuple(j.name for j in self.joints)

    def joint(self, name):
        """Look up an actuated joint by name: its JointInfo (ValueError naming the others)."""
        for info in self.joints:
            if info.name == name:
                return info
        raise ValueError(f'{self.describe()} has no actuated joint {show(name)}; its actuated '
                         f'joints: {show_names(self.joint_names)}')

    def select(self, joint_names=()):
        """Return the JointInfo of ``joint_names`` (all actuated joints when empty)."""
        if not joint_names:
            return self.joints
        if len(set(joint_names)) != len(joint_names):
            raise ValueError(f'joint_names has duplicates: {show_names(joint_names)}')
        return tuple(self.joint(n) for n in joint_names)

    def describe(self):
        """Return a short text naming the model, for error messages."""
        return f'the {self.kind.upper()} model {show_path(self.source)}'

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
        raise ValueError(f'{parameter} {show(name)} is not a link, body or site of '
                         f'{self.describe()}; it has: {show_names(known)}')

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


def load_robot_model(model_file='', urdf_string=None, where=None):
    """
    Load a robot from a URDF or MJCF file, or a URDF string (ValueError with the reason).

    A file is a URDF when its root element is ``<robot>``, else MJCF.
    ``where`` names a string's origin in messages (default
    ``robot_description``).  A description beyond the size caps
    (:data:`MAX_LINKS`, :data:`MAX_JOINTS`, :data:`MAX_DEPTH`) is refused
    before MuJoCo compiles it.
    """
    mujoco = import_mujoco()
    if urdf_string is not None:
        where = where or 'robot_description'
        if not isinstance(urdf_string, str) or not urdf_string.strip():
            raise ValueError(f'{where} is empty')
        return _from_urdf(mujoco, urdf_string, where, None, where)
    if not model_file:
        raise ValueError('no model: model_file is empty')
    where = where or model_file_where(model_file)
    text = read_description_file(model_file, where)
    if _root_tag(text, where) == 'robot':
        return _from_urdf(mujoco, text, where, os.path.dirname(os.path.abspath(model_file)),
                          model_file)
    check_mjcf(model_file, text, where)
    return _from_mjcf(mujoco, model_file, where)


def model_file_where(path):
    """Return how messages name the description file ``path``: ``model_file '<path>'``."""
    return f'model_file {show_path(path)}'


def check_description_file(path, where=None):
    """
    Raise ValueError unless ``path`` could be a URDF or MJCF file, without reading it.

    The cheap check before a slow compile: :func:`~.user_text.check_text_file`
    with :data:`MAX_DESCRIPTION_CHARS`; ``where`` names the file in messages
    (default :func:`model_file_where`).
    """
    check_text_file(path, where or model_file_where(path), MAX_DESCRIPTION_CHARS)


def read_description_file(path, where=None):
    """
    Return the text of a URDF or MJCF file (ValueError with the reason).

    :func:`~.user_text.read_text_file` with :data:`MAX_DESCRIPTION_CHARS`:
    refused as by :func:`check_description_file` (a missing path, a
    directory, anything but a regular file such as ``/dev/zero`` or a named
    pipe, more than :data:`MAX_DESCRIPTION_CHARS` bytes, never read
    further), and text that is not UTF-8.  ``where`` as there.
    """
    return read_text_file(path, where or model_file_where(path), MAX_DESCRIPTION_CHARS)


def check_mjcf_size(text, where):
    """
    Refuse an MJCF text beyond the size caps before MuJoCo compiles it; return its counts.

    The counts are (bodies, joints); a ValueError past a cap.  Counted with
    ElementTree, resolving nothing: ``<body>`` elements (each times the
    ``count`` of every ``<replicate>`` around it; a
    ``<composite>`` or ``<flexcomp>`` as the product of its ``count``),
    ``<joint>`` and ``<freejoint>`` elements in bodies, and the nesting
    depth of bodies (:func:`check_mjcf_files` reads the ``<include>``
    files).  Text that ElementTree cannot parse is refused (ValueError):
    MuJoCo's parser takes some of it (``--`` in a comment), unchecked.
    """
    return _check_counts(mjcf_counts(text, where), where)


def _check_counts(counts, where, what=''):
    """Return ``counts`` (bodies, joints), or raise ValueError past the caps (``what``: whose)."""
    bodies, joints = counts
    if bodies > MAX_LINKS:
        raise ValueError(f'{where} has {bodies} bodies{what}, more than the {MAX_LINKS} '
                         'accepted')
    if joints > MAX_JOINTS:
        raise ValueError(f'{where} has {joints} joints{what}, more than the {MAX_JOINTS} '
                         'accepted')
    return counts


def check_mjcf(path, text, where):
    """
    Refuse the MJCF file ``path`` (its ``text`` read) before MuJoCo compiles it (ValueError).

    Its size (:func:`check_mjcf_size`), then the files it names and their
    size with it (:func:`check_mjcf_files`).
    """
    check_mjcf_files(path, text, where, check_mjcf_size(text, where))


def mjcf_counts(text, where):
    """
    Return (bodies, joints) of an MJCF text, as :func:`check_mjcf_size` counts them.

    A ValueError where bodies nest deeper than :data:`MAX_DEPTH`, and for
    text that ElementTree cannot parse.
    """
    bodies = joints = 0
    stack = []  # per open element: (tag, copies, body depth)
    try:
        for event, element in ET.iterparse(_Lines(text), events=('start', 'end')):
            if event == 'end':
                stack.pop()
                element.clear()
                continue
            tag = element.tag
            parent, copies, depth = stack[-1] if stack else ('', 1, 0)
            if tag == 'replicate':
                copies *= max(_count(element.get('count')), 1)
            elif tag == 'body':
                bodies += copies
                depth += 1
                if depth > MAX_DEPTH:
                    name = element.get('name')
                    body = f'body {show(name)}' if name else 'a body'
                    raise ValueError(f'{where}: {body} is {depth} bodies deep, more than the '
                                     f'{MAX_DEPTH} accepted')
            elif tag in ('composite', 'flexcomp'):
                bodies += copies * _count(element.get('count'))
            elif tag in ('joint', 'freejoint') and parent == 'body':
                joints += copies
            stack.append((tag, copies, depth))
    except ET.ParseError as exc:
        raise _not_well_formed(where, exc) from None
    return bodies, joints


def check_mjcf_files(path, text, where, counts):
    """
    Refuse an MJCF whose included files or assets MuJoCo should not open (ValueError).

    ``counts``: the (bodies, joints) of ``text`` itself (:func:`check_mjcf_size`).

    MuJoCo follows ``<include file>`` and opens every asset's ``file``
    (mesh, texture, height field, skin) itself, unchecked: a named pipe
    there blocked the node for good, a sparse 1.5 GB mesh was read whole
    (helper-36).  Each included file, relative to the main file's folder as
    MuJoCo resolves it, must be a regular file within
    :data:`MAX_DESCRIPTION_CHARS` (:func:`~.user_text.check_text_file`);
    its text is read and checked as the main one (:func:`mjcf_counts`,
    the bodies and joints of all files counted together), down to
    :data:`MAX_INCLUDE_DEPTH` levels.  Each asset file that exists must be
    a regular file of at most :data:`MAX_ASSET_BYTES` (a missing one is
    left to MuJoCo's own error).
    """
    folder = os.path.dirname(os.path.abspath(path))
    seen = {os.path.abspath(path)}
    pending = [(text, where, 0)]
    bodies, joints = counts
    while pending:
        text, source, depth = pending.pop()
        includes, assets, dirs = _mjcf_files(text, source)
        for name in includes:
            included = name if os.path.isabs(name) else os.path.join(folder, name)
            here = f'{source}: <include file={show_path(name)}>'
            if os.path.abspath(included) in seen:
                raise ValueError(f'{here} includes a file twice (or itself)')
            if depth + 1 > MAX_INCLUDE_DEPTH:
                raise ValueError(f'{here} is more than {MAX_INCLUDE_DEPTH} includes deep')
            seen.add(os.path.abspath(included))
            body = read_text_file(included, here, MAX_DESCRIPTION_CHARS)
            counted = mjcf_counts(body, here)
            bodies, joints = bodies + counted[0], joints + counted[1]
            pending.append((body, here, depth + 1))
        for tag, name in assets:
            base = dirs.get(tag) or dirs.get('asset') or ''
            asset = name if os.path.isabs(name) else os.path.join(folder, base, name)
            if os.path.lexists(asset):
                check_text_file(asset, f'{source}: <{tag} file={show_path(name)}>',
                                MAX_ASSET_BYTES)
    _check_counts((bodies, joints), where, ' with its included files')


# MJCF elements whose ``file`` MuJoCo opens, and the <compiler> folder each is in.
_ASSET_DIRS = {'mesh': 'meshdir', 'skin': 'meshdir', 'texture': 'texturedir',
               'hfield': 'assetdir'}


def _mjcf_files(text, where):
    """Return (included files, [(asset tag, file)], {tag: compiler folder}) of an MJCF text."""
    includes, assets, dirs = [], [], {}
    try:
        for _, element in ET.iterparse(_Lines(text), events=('start',)):
            name = element.get('file')
            if element.tag == 'include' and name:
                includes.append(name)
            elif element.tag in _ASSET_DIRS and name:
                assets.append((element.tag, name))
            elif element.tag == 'compiler':
                for tag, attribute in _ASSET_DIRS.items():
                    if element.get(attribute):
                        dirs[tag] = element.get(attribute)
                if element.get('assetdir'):
                    dirs['asset'] = element.get('assetdir')
    except ET.ParseError as exc:
        raise _not_well_formed(where, exc) from None
    return includes, assets, dirs


def _count(text):
    """Return the product of the integers of an MJCF ``count`` attribute (1 if none)."""
    product = 1
    for word in (text or '').split()[:3]:
        try:
            product *= max(int(word), 1)
        except ValueError:
            pass
    return product


def _root_tag(text, where):
    """
    Return the root element's tag of a description ``text``; ValueError if not well-formed.

    MuJoCo's parser takes some XML that ElementTree refuses (``--`` in a
    comment): such a file would skip every check here (the size caps, the
    included and asset files) and a URDF would go to MuJoCo as if it were
    MJCF, its velocity limits and frames dropped.  Refused instead.
    """
    try:
        for _, element in ET.iterparse(_Lines(text), events=('start',)):
            return element.tag
    except ET.ParseError as exc:
        raise _not_well_formed(where, exc) from None
    raise ValueError(f'{where} has no XML element')


def _not_well_formed(where, exc):
    """Return the ValueError of a description ElementTree cannot parse (``exc``)."""
    return ValueError(f'{where} is not well-formed XML: {exc}')


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


def _mujoco_error(exc):
    """Return MuJoCo's error message, stripped and cut short."""
    return clip(str(exc).strip(), 500)


def _from_urdf(mujoco, text, where, base_dir, source):
    description = _UrdfDescription(text, where, base_dir)
    try:
        spec = mujoco.MjSpec.from_string(description.text)
        model = spec.compile()
    except Exception as exc:  # mujoco raises ValueError or its own errors
        raise ValueError(f'MuJoCo cannot load {where}: {_mujoco_error(exc)}') from None
    for note in description.notes:
        _log_note(note)
    return RobotModel(model, 'urdf', source, description.limits, description.mimic,
                      description.notes, description.held, description.joint_names)


def _from_mjcf(mujoco, path, where):
    notes = []
    try:
        spec = mujoco.MjSpec.from_file(path)
    except Exception as exc:
        raise ValueError(f'cannot load MJCF {where}: {_mujoco_error(exc)}') from None
    try:
        model = spec.compile()
    except Exception as first:
        try:
            spec = mujoco.MjSpec.from_file(path)
            dropped = _drop_mjcf_meshes(mujoco, spec)
            model = spec.compile()
        except Exception:
            raise ValueError(f'cannot compile MJCF {where}: {_mujoco_error(first)}') from None
        notes.append(f'{where}: {dropped} mesh geom(s) dropped since the model did not '
                     f'compile with them ({_mujoco_error(first)})')
        _log_note(notes[-1])
    return RobotModel(model, 'mjcf', path, notes=notes)


def joint_ranges(joints):
    """Return the lower and upper position bounds (n,) of JointInfo ``joints``."""
    return (np.array([j.lower for j in joints], dtype=float),
            np.array([j.upper for j in joints], dtype=float))


def urdf_spec(mujoco, path, text=None):
    """
    Return an MjSpec of the URDF file ``path`` for simulation, or None when it is not a URDF.

    ``text`` is the file's text when the caller has read it (with
    :func:`read_description_file`; read here otherwise).  The URDF is
    cleaned and checked as for :func:`load_robot_model`; contacts are
    disabled (a URDF arm has no environment, and its collision meshes touch
    between links).
    """
    where = model_file_where(path)
    if text is None:
        text = read_description_file(path, where)
    if _root_tag(text, where) != 'robot':
        return None
    description = _UrdfDescription(text, where, os.path.dirname(os.path.abspath(path)))
    for note in description.notes:
        _log_note(note)
    try:
        spec = mujoco.MjSpec.from_string(description.text)
    except Exception as exc:  # mujoco raises ValueError or its own errors
        raise ValueError(f'MuJoCo cannot load {where}: {_mujoco_error(exc)}') from None
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return spec
