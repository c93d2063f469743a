"""
Unit quaternions (w, x, y, z), vectorised over leading axes; numpy only.

The convention is MuJoCo's (scalar first).  ROS messages carry (x, y, z, w):
convert at the node's border.
"""

import numpy as np


def _cross(a, b):
    """Cross products of (..., 3) arrays, by components (faster than np.cross for small K)."""
    ax, ay, az = a[..., 0], a[..., 1], a[..., 2]
    bx, by, bz = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx], axis=-1)


def multiply(a, b):
    """Return the products a * b (..., 4) of quaternions (..., 4)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    w = aw * bw - np.sum(av * bv, axis=-1, keepdims=True)
    v = aw * bv + bw * av + _cross(av, bv)
    return np.concatenate([w, v], axis=-1)


def conjugate(q):
    """Return the conjugates (inverse rotations) of unit quaternions (..., 4)."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., :1], -q[..., 1:]], axis=-1)


def rotate(q, v):
    """Return the vectors v (..., 3) rotated by unit quaternions q (..., 4)."""
    q = np.asarray(q, dtype=float)
    v = np.asarray(v, dtype=float)
    w, u = q[..., :1], q[..., 1:]
    t = 2.0 * _cross(u, v)
    return v + w * t + _cross(u, t)


def from_axis_angle(axis, angle):
    """Return the rotations by ``angle`` (...) about unit ``axis`` (3,) or (..., 3)."""
    half = 0.5 * np.asarray(angle, dtype=float)[..., None]
    return np.concatenate([np.cos(half), np.sin(half) * np.asarray(axis, dtype=float)],
                          axis=-1)


def normalize(q):
    """Return unit quaternions (..., 4) (ValueError for a zero one)."""
    q = np.asarray(q, dtype=float)
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise ValueError('a quaternion is zero')
    return q / norm


def angle_between(a, b):
    """Return the rotation angles [rad] (...) between orientations a and b (..., 4)."""
    d = multiply(conjugate(a), b)
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))


def rotation_vector(q):
    """Return the rotation vectors (axis * angle, ..., 3) of unit quaternions, angle <= pi."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0.0, -q, q)
    s = np.linalg.norm(q[..., 1:], axis=-1)
    angle = 2.0 * np.arctan2(s, q[..., 0])
    scale = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return q[..., 1:] * scale[..., None]


def slerp(a, b, s):
    """
    Return the spherical interpolation from a to b (..., 4) at fractions s (...).

    Takes the short way (b's sign is flipped when the dot product is negative).
    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    s = np.asarray(s, dtype=float)[..., None]
    dot = np.sum(a * b, axis=-1, keepdims=True)
    b = np.where(dot < 0.0, -b, b)
    dot = np.abs(dot)
    omega = np.arccos(np.clip(dot, -1.0, 1.0))
    small = omega < 1e-9
    sin_omega = np.where(small, 1.0, np.sin(omega))
    wa = np.where(small, 1.0 - s, np.sin((1.0 - s) * omega) / sin_omega)
    wb = np.where(small, s, np.sin(s * omega) / sin_omega)
    return normalize(wa * a + wb * b)


def to_matrix(q):
    """Return the rotation matrices (..., 3, 3) of unit quaternions (..., 4)."""
    q = np.asarray(q, dtype=float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=-2)


def from_matrix(mat):
    """Return unit quaternions (..., 4), w >= 0, of rotation matrices (..., 3, 3)."""
    m = np.asarray(mat, dtype=float)
    m00, m11, m22 = m[..., 0, 0], m[..., 1, 1], m[..., 2, 2]
    # Shepperd: the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2 gives the stable formula.
    candidates = np.stack([1.0 + m00 + m11 + m22, 1.0 + m00 - m11 - m22,
                           1.0 - m00 + m11 - m22, 1.0 - m00 - m11 + m22], axis=-1)
    pick = np.argmax(candidates, axis=-1)
    root = np.sqrt(np.maximum(np.take_along_axis(candidates, pick[..., None], -1)[..., 0],
                              1e-300))
    half = 0.5 / root
    d21, d02, d10 = m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], \
        m[..., 1, 0] - m[..., 0, 1]
    s21, s02, s10 = m[..., 2, 1] + m[..., 1, 2], m[..., 0, 2] + m[..., 2, 0], \
        m[..., 1, 0] + m[..., 0, 1]
    options = np.stack([
        np.stack([0.5 * root, d21 * half, d02 * half, d10 * half], -1),
        np.stack([d21 * half, 0.5 * root, s10 * half, s02 * half], -1),
        np.stack([d02 * half, s10 * half, 0.5 * root, s21 * half], -1),
        np.stack([d10 * half, s02 * half, s21 * half, 0.5 * root], -1),
    ], axis=-2)
    q = np.take_along_axis(options, pick[..., None, None], -2)[..., 0, :]
    q = np.where(q[..., :1] < 0.0, -q, q)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def continuous(q):
    """Return quaternions (N, 4) with signs flipped so neighbours have dot products >= 0."""
    q = np.array(q, dtype=float)
    for k in range(1, len(q)):
        if np.dot(q[k], q[k - 1]) < 0.0:
            q[k] = -q[k]
    return q
