"""
Joint limits from a robot's description: URDF ``<limit velocity>``, MoveIt's ``joint_limits.yaml``.

Pure Python (PyYAML), no rclpy.  A typical ROS set-up keeps a robot's
limits in two places: the URDF (position, velocity, effort) and MoveIt's
``joint_limits.yaml``::

    joint_limits:
      shoulder_pan_joint:
        has_velocity_limits: true
        max_velocity: 3.15
        has_acceleration_limits: true
        max_acceleration: 5.0
        has_jerk_limits: false
        max_jerk: 0.0

:func:`resolve_limits` combines them with explicitly set values, per joint
and per quantity, in this order (the first that gives a value wins):

1. the explicit value (a node parameter; 0 or an empty array = not set);
2. ``joint_limits.yaml`` (when its ``has_*_limits`` is true);
3. the URDF (velocity only: a URDF has no acceleration or jerk limits).

A joint left without a velocity or an acceleration limit is an error that
names the joint; a jerk limit is optional.  :class:`ResolvedLimits` keeps
where each value came from, for the status report (the planner's own
limits, :class:`~splines445_ros.planning.JointLimits`, are the arrays it
plans with).

Hostile or careless input (issue 22): the file is read with a size bound
and parsed without YAML anchors and aliases (an alias bomb of a few hundred
bytes would otherwise expand to billions of items when shown); every user
value in a message is shown cut short (:func:`~.user_text.show`); limits
outside :data:`LIMIT_RANGES`, where the planner is known to work, are
refused (:func:`check_limit_value`); and with ``known_joints``,
:func:`resolve_limits` refuses file entries for joints the robot does not
have (a typo would otherwise be ignored silently).
"""

from dataclasses import dataclass, field
import difflib
import math
import re
from typing import Dict, Optional, Tuple

import numpy as np
import yaml

from .user_text import clip, read_text_file, show, show_names, show_path

# MoveIt's joint_limits.yaml keys (moveit_core joint_limits): anything else is a typo.
QUANTITY_KEYS = {
    'velocity': ('has_velocity_limits', 'max_velocity'),
    'acceleration': ('has_acceleration_limits', 'max_acceleration'),
    'jerk': ('has_jerk_limits', 'max_jerk'),
}
OTHER_KEYS = {'has_position_limits', 'min_position', 'max_position', 'has_effort_limits',
              'max_effort', 'has_deceleration_limits', 'max_deceleration', 'angle_wraps',
              'has_soft_limits', 'k_position', 'k_velocity', 'soft_lower_limit',
              'soft_upper_limit'}
TOP_LEVEL_KEYS = {'joint_limits', 'default_velocity_scaling_factor',
                  'default_acceleration_scaling_factor'}
# The largest joint_limits.yaml read [bytes]: MoveIt's format takes about 170 bytes a
# joint, so some 380 joints.  It is read in the parameter callback, and PyYAML
# parses about 3 us a byte (0.2 s here; a 1 MB file blocked set_parameters for 3-9 s).
MAX_FILE_BYTES = 65_536

# The usable range of each limit [rad/s^k or m/s^k]: 434, 445 and 555 plans, uniform and
# optimal timing, of random requests (3-10 waypoints, 1-3 joints, steps of 1 mm to 3 rad)
# come out finite and within their limits at every corner of these ranges, and with
# per-joint mixtures of the corners (test_hostile_descriptions.py plans at the corners).
# The planner still works far beyond them (corners at 1e-50 and 1e50 pass; a lone
# velocity of 1e-100 gives "the plan is not finite"): they bound what a real robot, in
# rad or m, could need, so that a typo (1e-300, 1e300) is refused with this range
# instead of failing every request.
LIMIT_RANGES = {
    'velocity': (1e-6, 1e4),
    'acceleration': (1e-6, 1e6),
    'jerk': (1e-6, 1e9),
}
LIMIT_UNITS = {'velocity': 'rad/s or m/s', 'acceleration': 'rad/s^2 or m/s^2',
               'jerk': 'rad/s^3 or m/s^3'}

PARAMETER = 'parameter'
YAML = 'joint_limits_file'
URDF = 'urdf'


@dataclass(frozen=True)
class ResolvedLimits:
    """Per-joint limits in use and their sources ('parameter', 'joint_limits_file', 'urdf')."""

    joint_names: Tuple[str, ...]
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray                 # +inf where the joint has no jerk limit
    sources: Dict[str, Tuple[str, ...]]  # quantity -> per-joint source ('' = none)
    # The joint_limits_file's keys read but not applied ({key: value}, JointLimitsFile).
    unapplied: Dict[str, float] = field(default_factory=dict)

    def jerk_limits(self):
        """Return jerk limits for plan(): None when no joint has one."""
        return None if not np.any(np.isfinite(self.jerk)) else self.jerk.copy()

    def report(self):
        """Return status values: every limit with its source, joint by joint."""
        values = {}
        for quantity in ('velocity', 'acceleration', 'jerk'):
            numbers = getattr(self, quantity)
            values[f'limit_{quantity}_sources'] = ', '.join(
                f'{name}={number:.6g} ({source})' if source else f'{name}=none'
                for name, number, source in zip(self.joint_names, numbers,
                                                self.sources[quantity]))
        if self.unapplied:
            values['joint_limits_file_not_applied'] = unapplied_note(self.unapplied)
        return values


def unapplied_note(unapplied):
    """Say which of a joint_limits_file's keys are not applied, and what to do instead."""
    keys = ', '.join(f'{key} = {value:g}' for key, value in unapplied.items())
    return (f'{keys}: MoveIt scales its own requests by these; this planner plans at the '
            'full limits (lower max_velocity / max_acceleration to scale them)')


class JointLimitsFile(dict):
    """
    {joint: {quantity: value}} of a joint_limits.yaml, and what of it is not applied.

    ``unapplied``: MoveIt's ``default_velocity_scaling_factor`` and
    ``default_acceleration_scaling_factor`` other than 1 (MoveIt Setup
    Assistant writes 0.1): read and checked, but plans use the full limits;
    said on ``~/status`` and in the log, not silently dropped (helper-92).
    """

    def __init__(self, limits, unapplied=None):
        """Keep the per-joint ``limits`` and the ``unapplied`` {key: value}."""
        super().__init__(limits)
        self.unapplied = dict(unapplied or {})


def check_limit_value(quantity, value, where):
    """
    Return ``value`` as a float when it lies in ``LIMIT_RANGES[quantity]`` (else ValueError).

    ``quantity`` is 'velocity', 'acceleration' or 'jerk'; ``where`` names
    the value in the message (e.g. ``"joint 'elbow': max_velocity"``), which
    says the range that works.  NaN and infinities are outside.
    """
    low, high = LIMIT_RANGES[quantity]
    number = float(value)
    if not low <= number <= high:
        raise ValueError(f'{where} = {number:g} is outside the usable range [{low:g}, '
                         f'{high:g}] ({LIMIT_UNITS[quantity]}) of a {quantity} limit')
    return number


class _AliasError(ValueError):
    """A YAML anchor or alias, or a key given twice in one mapping: refused."""


class _Loader(yaml.SafeLoader):
    """
    PyYAML's safe loader without anchors, aliases and repeated keys, reading ``1e3`` as a number.

    MoveIt (yaml-cpp) reads ``max_jerk: 1e3`` as a number; PyYAML (YAML
    1.1) as the string '1e3'.  An alias bomb (nested aliases, each level
    repeating the one below) is refused at its first anchor, before
    anything is built.
    """

    def compose_node(self, parent, index):
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, 'anchor', None):
            mark = event.start_mark
            raise _AliasError(f'YAML anchors and aliases (&name, *name) are not accepted '
                              f'(line {mark.line + 1}, column {mark.column + 1})')
        return super().compose_node(parent, index)

    def construct_mapping(self, node, deep=False):
        """Build a mapping, refusing a key it has twice: one of the values would be ignored."""
        if isinstance(node, yaml.MappingNode):
            seen = {}
            for key_node, _ in node.value:
                line = key_node.start_mark.line + 1
                if key_node.tag == 'tag:yaml.org,2002:merge':
                    raise _AliasError(f'YAML merge keys (<<) are not accepted (line {line})')
                key = self.construct_object(key_node, deep=True)
                try:
                    if key in seen:
                        raise _AliasError(f'the key {show(key)} is given twice in one mapping '
                                          f'(lines {seen[key]} and {line})')
                    seen[key] = line
                except TypeError:   # an unhashable key: the loader refuses it below
                    continue
        return super().construct_mapping(node, deep)


_Loader.add_implicit_resolver(
    'tag:yaml.org,2002:float',
    re.compile(r'^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9][0-9_]*)[eE][-+]?[0-9]+$'),
    list('-+0123456789.'))


def load_yaml(text, where):
    """Parse YAML ``text`` with :class:`_Loader` (ValueError naming ``where``, bounded)."""
    try:
        return yaml.load(text, Loader=_Loader)  # noqa: S506 - a SafeLoader subclass
    except _AliasError as exc:
        raise ValueError(f'{where}: {exc}') from None
    except (yaml.YAMLError, ValueError, RecursionError) as exc:
        # ValueError: e.g. an integer of more than 4300 digits.
        raise ValueError(f'{where} is not readable YAML: {clip(exc, 500)}') from None


def read_joint_limits_file(path):
    """
    Read a MoveIt ``joint_limits.yaml``; return {joint: {quantity: value}}.

    Only limits whose ``has_*_limits`` is true are returned.  ValueError
    names the file and the offending joint and key: a path that is not a
    regular file or is larger than :data:`MAX_FILE_BYTES`, YAML anchors or
    aliases, unknown keys, a ``has_*`` that is not a boolean, a limit that is
    not a number in :data:`LIMIT_RANGES`, or a ``has_*: true`` without its
    ``max_*``.
    """
    where = f'joint_limits_file {show_path(path)}'
    text = read_text_file(path, where, MAX_FILE_BYTES)
    return parse_joint_limits(load_yaml(text, where), where)


def parse_joint_limits(data, where='joint limits'):
    """Check the parsed YAML of a joint_limits.yaml; see :func:`read_joint_limits_file`."""
    if not isinstance(data, dict) or 'joint_limits' not in data:
        raise ValueError(f'{where} has no top-level "joint_limits" mapping')
    unknown = [str(k) for k in data if k not in TOP_LEVEL_KEYS]
    if unknown:
        raise ValueError(f'{where} has unknown top-level key(s) {show_names(unknown)}; known: '
                         f'{sorted(TOP_LEVEL_KEYS)}')
    joints = data['joint_limits']
    if not isinstance(joints, dict):
        raise ValueError(f'{where}: "joint_limits" must map joint names to their limits')
    known = OTHER_KEYS.union(*(set(keys) for keys in QUANTITY_KEYS.values()))
    result, keys = {}, {}
    for joint, entry in joints.items():
        name = show(joint)
        first = keys.setdefault(str(joint), joint)
        if first is not joint:    # 1 and "1", true and "True": one joint name
            raise ValueError(f'{where}: joints {show(first)} and {name} are both the joint '
                             f'{show(str(joint))}')
        if not isinstance(entry, dict):
            raise ValueError(f'{where}: joint {name} must map keys to values')
        bad = [str(k) for k in entry if k not in known]
        if bad:
            raise ValueError(f'{where}: joint {name} has unknown key(s) {show_names(bad)}; MoveIt '
                             f'keys are {sorted(known)}')
        limits = {}
        for quantity, (has_key, max_key) in QUANTITY_KEYS.items():
            has = entry.get(has_key, False)
            if not isinstance(has, bool):
                raise ValueError(f'{where}: joint {name}: {has_key} must be true or false, '
                                 f'got {show(has)}')
            if not has:
                continue
            if max_key not in entry:
                raise ValueError(f'{where}: joint {name} has {has_key}: true but no {max_key}')
            value = entry[max_key]
            if isinstance(value, int) and not isinstance(value, bool):
                try:
                    float(value)
                except OverflowError:   # an integer too large for a float: refused below
                    value = math.inf
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not math.isfinite(value) or value <= 0.0):
                raise ValueError(f'{where}: joint {name}: {max_key} = {show(value)} must be a '
                                 'positive number')
            limits[quantity] = check_limit_value(quantity, value,
                                                 f'{where}: joint {name}: {max_key}')
        result[str(joint)] = limits
    unapplied = {}
    for key in ('default_velocity_scaling_factor', 'default_acceleration_scaling_factor'):
        if key not in data:
            continue
        value = data[key]
        if (isinstance(value, bool) or not isinstance(value, (int, float))
                or not 0.0 < value <= 1.0):
            raise ValueError(f'{where}: {key} = {show(value)} must be a number in (0, 1]')
        if value != 1.0:
            unapplied[key] = float(value)
    return JointLimitsFile(result, unapplied)


def _explicit(values, name, n):
    if values is None or len(values) == 0:
        return np.zeros(n)
    if len(values) != n:
        raise ValueError(f'{name} needs one value per joint ({n}) or none, got {len(values)}')
    arr = np.array(values, dtype=float)
    bad = np.flatnonzero(~np.isfinite(arr) | (arr < 0.0))
    if bad.size:
        raise ValueError(f'{name}[{bad[0]}] = {arr[bad[0]]}: must be >= 0 and finite '
                         '(0 = from the description of the robot)')
    return arr


def check_known_joints(file_limits, known_joints):
    """
    Refuse limits of a joint that is not in ``known_joints`` (ValueError naming the closest).

    ``file_limits`` is the result of :func:`read_joint_limits_file`.
    """
    known = set(known_joints)
    for joint in file_limits:
        if joint in known:
            continue
        close = difflib.get_close_matches(joint, sorted(known), n=1)
        hint = (f'did you mean {show(close[0])}?' if close else
                f'its joints: {show_names(sorted(known))}')
        raise ValueError(f'the joint_limits_file gives limits for joint {show(joint)}, but '
                         f'the robot model has no joint of that name ({hint})')


def resolve_limits(joint_names, urdf_velocity=None, file_limits=None, max_velocity=None,
                   max_acceleration=None, max_jerk=None, *, known_joints=None):
    """
    Return the :class:`ResolvedLimits` of ``joint_names`` (ValueError naming a joint without).

    ``urdf_velocity``: {joint: velocity or None}; ``file_limits``: the result
    of :func:`read_joint_limits_file`; ``max_*``: explicit per-joint values
    (0 entries or an empty sequence = not set).  ``known_joints``: every
    joint of the robot model (planned or not, e.g. a gripper's); when given,
    a file entry for any other joint is refused, naming the closest known
    name (a typo would otherwise leave the joint at its URDF limit).  The
    value that wins for each joint and quantity must lie in
    :data:`LIMIT_RANGES` (a URDF ``velocity`` of 0 or none is "no URDF
    limit"; one that is overridden is not checked).
    """
    names = tuple(joint_names)
    n = len(names)
    urdf_velocity = urdf_velocity or {}
    file_limits = {} if file_limits is None else file_limits
    if known_joints is not None:
        check_known_joints(file_limits, known_joints)
    explicit = {'velocity': _explicit(max_velocity, 'max_velocity', n),
                'acceleration': _explicit(max_acceleration, 'max_acceleration', n),
                'jerk': _explicit(max_jerk, 'max_jerk', n)}
    values, sources = {}, {}
    for quantity in ('velocity', 'acceleration', 'jerk'):
        numbers, origin = np.full(n, math.inf), [''] * n
        for i, name in enumerate(names):
            shown = show(name)
            candidates = [(explicit[quantity][i] or None, PARAMETER,
                           f'max_{quantity}[{i}] (joint {shown})'),
                          (file_limits.get(name, {}).get(quantity), YAML,
                           f'joint {shown}: max_{quantity} of the joint_limits_file')]
            if quantity == 'velocity':
                candidates.append((_positive(urdf_velocity.get(name)), URDF,
                                   f"joint {shown}: the URDF's <limit velocity>"))
            for value, source, where in candidates:
                if value is not None:
                    numbers[i] = check_limit_value(quantity, value, where)
                    origin[i] = source
                    break
            if quantity != 'jerk' and not origin[i]:
                where = ('the URDF, ' if quantity == 'velocity' else '')
                raise ValueError(f'joint {shown} has no {quantity} limit: give it in '
                                 f'{where}the joint_limits_file or max_{quantity}')
        values[quantity], sources[quantity] = numbers, tuple(origin)
    return ResolvedLimits(names, values['velocity'], values['acceleration'], values['jerk'],
                          sources, dict(getattr(file_limits, 'unapplied', {})))


def _positive(value: Optional[float]):
    """Return a URDF limit when it is a usable limit (> 0 and finite), else None."""
    if value is None or not math.isfinite(value) or value <= 0.0:
        return None
    return value
