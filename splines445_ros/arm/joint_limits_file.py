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
names the joint; a jerk limit is optional.  :class:`JointLimits` keeps where
each value came from, for the status report.
"""

from dataclasses import dataclass
import math
import os
from typing import Dict, Optional, Tuple

import numpy as np
import yaml

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
MAX_FILE_BYTES = 1_000_000

PARAMETER = 'parameter'
YAML = 'joint_limits_file'
URDF = 'urdf'


@dataclass(frozen=True)
class JointLimits:
    """Per-joint limits in use and their sources ('parameter', 'joint_limits_file', 'urdf')."""

    joint_names: Tuple[str, ...]
    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray                 # +inf where the joint has no jerk limit
    sources: Dict[str, Tuple[str, ...]]  # quantity -> per-joint source ('' = none)

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
        return values


def read_joint_limits_file(path):
    """
    Read a MoveIt ``joint_limits.yaml``; return {joint: {quantity: value}}.

    Only limits whose ``has_*_limits`` is true are returned.  ValueError
    names the file and the offending joint and key: unknown keys, a
    ``has_*`` that is not a boolean, a limit that is not a positive number, or
    a ``has_*: true`` without its ``max_*``.
    """
    where = f'joint_limits_file {path!r}'
    if not os.path.isfile(path):
        raise ValueError(f'{where}: no such file')
    if os.path.getsize(path) > MAX_FILE_BYTES:
        raise ValueError(f'{where} is larger than {MAX_FILE_BYTES} bytes')
    try:
        with open(path, encoding='utf-8') as stream:
            data = yaml.safe_load(stream)
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as exc:
        raise ValueError(f'{where} is not readable YAML: {exc}') from None
    return parse_joint_limits(data, where)


def parse_joint_limits(data, where='joint limits'):
    """Check the parsed YAML of a joint_limits.yaml; see :func:`read_joint_limits_file`."""
    if not isinstance(data, dict) or 'joint_limits' not in data:
        raise ValueError(f'{where} has no top-level "joint_limits" mapping')
    unknown = sorted(str(k) for k in data if k not in TOP_LEVEL_KEYS)
    if unknown:
        raise ValueError(f'{where} has unknown top-level key(s) {unknown}; known: '
                         f'{sorted(TOP_LEVEL_KEYS)}')
    joints = data['joint_limits']
    if not isinstance(joints, dict):
        raise ValueError(f'{where}: "joint_limits" must map joint names to their limits')
    known = OTHER_KEYS.union(*(set(keys) for keys in QUANTITY_KEYS.values()))
    result = {}
    for joint, entry in joints.items():
        if not isinstance(entry, dict):
            raise ValueError(f'{where}: joint {joint!r} must map keys to values')
        bad = sorted(str(k) for k in entry if k not in known)
        if bad:
            raise ValueError(f'{where}: joint {joint!r} has unknown key(s) {bad}; MoveIt keys '
                             f'are {sorted(known)}')
        limits = {}
        for quantity, (has_key, max_key) in QUANTITY_KEYS.items():
            has = entry.get(has_key, False)
            if not isinstance(has, bool):
                raise ValueError(f'{where}: joint {joint!r}: {has_key} must be true or false, '
                                 f'got {has!r}')
            if not has:
                continue
            if max_key not in entry:
                raise ValueError(f'{where}: joint {joint!r} has {has_key}: true but no '
                                 f'{max_key}')
            value = entry[max_key]
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not math.isfinite(value) or value <= 0.0):
                raise ValueError(f'{where}: joint {joint!r}: {max_key} = {value!r} must be a '
                                 'positive number')
            limits[quantity] = float(value)
        result[str(joint)] = limits
    return result


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


def resolve_limits(joint_names, urdf_velocity=None, file_limits=None, max_velocity=None,
                   max_acceleration=None, max_jerk=None):
    """
    Return the :class:`JointLimits` of ``joint_names`` (ValueError naming a joint without).

    ``urdf_velocity``: {joint: velocity or None}; ``file_limits``: the result
    of :func:`read_joint_limits_file`; ``max_*``: explicit per-joint values
    (0 entries or an empty sequence = not set).
    """
    names = tuple(joint_names)
    n = len(names)
    urdf_velocity = urdf_velocity or {}
    file_limits = file_limits or {}
    explicit = {'velocity': _explicit(max_velocity, 'max_velocity', n),
                'acceleration': _explicit(max_acceleration, 'max_acceleration', n),
                'jerk': _explicit(max_jerk, 'max_jerk', n)}
    values, sources = {}, {}
    for quantity in ('velocity', 'acceleration', 'jerk'):
        numbers, origin = np.full(n, math.inf), [''] * n
        for i, name in enumerate(names):
            candidates = [(explicit[quantity][i] or None, PARAMETER),
                          (file_limits.get(name, {}).get(quantity), YAML)]
            if quantity == 'velocity':
                candidates.append((_positive(urdf_velocity.get(name)), URDF))
            for value, source in candidates:
                if value is not None:
                    numbers[i], origin[i] = float(value), source
                    break
            if quantity != 'jerk' and not origin[i]:
                where = ('the URDF, ' if quantity == 'velocity' else '')
                raise ValueError(f'joint {name!r} has no {quantity} limit: give it in '
                                 f'{where}the joint_limits_file or max_{quantity}')
        values[quantity], sources[quantity] = numbers, tuple(origin)
    return JointLimits(names, values['velocity'], values['acceleration'], values['jerk'],
                       sources)


def _positive(value: Optional[float]):
    """Return a URDF limit when it is a usable limit (> 0 and finite), else None."""
    if value is None or not math.isfinite(value) or value <= 0.0:
        return None
    return value
