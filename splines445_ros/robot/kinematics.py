"""
Kinematics of the paper's planar 3-DOF arm (Section III); no ROS imports.

Joint 1 and 2 are revolute joints with links ``d1`` and ``d2``; joint 3 sets the
tool orientation ``O = q1 + q2 + q3``.
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PlanarArm:
    """Link lengths of the planar arm (paper: d1 = 1.1, d2 = 0.9)."""

    d1: float = 1.1
    d2: float = 0.9

    def __post_init__(self):
        """Reject non-positive or non-finite link lengths."""
        for name in ('d1', 'd2'):
            value = getattr(self, name)
            try:
                number = float(value)
            except (TypeError, ValueError):
                raise ValueError(f'link length {name} must be a number, got {value!r}') from None
            if not np.isfinite(number) or number <= 0.0:
                raise ValueError(f'link length {name} must be positive and finite, got {value}')

    def forward(self, joints):
        """Tool pose (..., 3) = (X, Y, O) of joint angles (..., 3)."""
        q = np.asarray(joints, dtype=float)
        q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2]
        x = self.d1 * np.cos(q1) + self.d2 * np.cos(q1 + q2)
        y = self.d1 * np.sin(q1) + self.d2 * np.sin(q1 + q2)
        return np.stack([x, y, q1 + q2 + q3], axis=-1)

    def inverse(self, poses, elbow=1.0):
        """
        Joint angles (K, 3) for tool poses (K, 3) = (X, Y, O), continuous along K.

        ``q2 = elbow * arccos((X^2 + Y^2 - d1^2 - d2^2) / (2 d1 d2))``,
        ``q1 = atan2((d1 + d2 cos q2) Y - d2 sin q2 X, (d1 + d2 cos q2) X + d2 sin q2 Y)``,
        ``q3 = O - q1 - q2``.  Each angle is unwrapped so consecutive waypoints
        never jump by 2*pi.  Raises ValueError for an unreachable pose.
        """
        p = np.atleast_2d(np.asarray(poses, dtype=float))
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f'poses must be (K, 3) = (X, Y, O) rows, got shape {p.shape}')
        x, y, o = p[:, 0], p[:, 1], p[:, 2]
        cos_q2 = (x**2 + y**2 - self.d1**2 - self.d2**2) / (2.0 * self.d1 * self.d2)
        unreachable = np.abs(cos_q2) > 1.0 + 1e-12
        if np.any(unreachable):
            k = int(np.argwhere(unreachable)[0][0])
            raise ValueError(f'pose {k} ({x[k]}, {y[k]}) is out of reach of the arm')
        q2 = elbow * np.arccos(np.clip(cos_q2, -1.0, 1.0))
        a = self.d1 + self.d2 * np.cos(q2)
        b = self.d2 * np.sin(q2)
        q1 = np.arctan2(a * y - b * x, a * x + b * y)
        q1 = np.unwrap(q1)
        q3 = np.unwrap(o - q1 - q2)
        return np.stack([q1, q2, q3], axis=1)
