"""The acceleration of a tool frame along a path: second-order rows of a polygon."""

import numpy as np

from .canonical_forms import AccelerationConstraint


# Sides of the regular polygon that holds the tool acceleration (ToolAcceleration):
# inscribed in the circle of the limit, it gives away at most 1 - cos(pi / 16) = 1.9 %
# (none along the path, nor across it), for 8 rows per grid point.
TOOL_ACCELERATION_SIDES = 16


class ToolAcceleration(AccelerationConstraint):
    """
    The acceleration of a tool frame's origin: ``|w| <= A``, ``w = p'(s) u + p''(s) x``.

    ``derivatives(path)`` returns the tool position's ``p'`` and ``p''``
    along the path (each (M + 1, d), d = 2 or 3).  ``w`` lies in the plane
    of ``p'`` and ``p''``: with ``e1 = p' / |p'|`` and ``e2`` the unit part
    of ``p''`` across ``e1``, ``w = (|p'| u + (p''.e1) x, (p''.e2) x)``.
    The disk ``|w| <= A`` is held by the regular
    :data:`TOOL_ACCELERATION_SIDES`-gon inscribed in it, linear rows
    ``|cos(t_k) w1 + sin(t_k) w2| <= A cos(pi / K)`` for the K / 2 side
    normals ``t_k = (2 k + 1) pi / K``: conservative, and with vertices on
    both axes (K a multiple of 4) exact for an acceleration along the path
    (a straight line) or across it.  Where the tool does not move
    (``p' = 0``) the plane is that of ``p''`` alone; where ``p''`` is
    parallel to ``p'`` (or 0) its part across is 0.
    """

    def __init__(self, max_acceleration, derivatives):
        """Take the acceleration limit (> 0) and the function giving ``(p', p'')`` along a path."""
        self.max_acceleration = float(max_acceleration)
        self.derivatives = derivatives

    def rows(self, path):
        """Return ``(cos(t_k) |p'|, cos(t_k) c1 + sin(t_k) c2, -A cos(pi / K), A cos(pi / K))``."""
        first, second = (np.asarray(v, float) for v in self.derivatives(path))
        speed = np.linalg.norm(first, axis=1)
        moving = speed > 0.0
        # The unit tangent; where the tool stands still, the direction of p''.
        along = np.where(moving, speed, 1.0)[:, None]
        unit = np.where(moving[:, None], first / along, 0.0)
        curvature = np.linalg.norm(second, axis=1)
        still = ~moving & (curvature > 0.0)
        unit[still] = second[still] / curvature[still, None]
        c1 = np.sum(second * unit, axis=1)
        c2 = np.linalg.norm(second - c1[:, None] * unit, axis=1)
        sides = TOOL_ACCELERATION_SIDES
        normal = (2.0 * np.arange(sides // 2) + 1.0) * np.pi / sides
        cosine, sine = np.cos(normal)[None, :], np.sin(normal)[None, :]
        a = cosine * speed[:, None]
        b = cosine * c1[:, None] + sine * c2[:, None]
        bound = np.full(a.shape, self.max_acceleration * np.cos(np.pi / sides))
        return a, b, -bound, bound
