"""
The limits of the path-velocity step as constraint objects (issues 24 and 25).

Along a gridded joint path ``q(s)`` traversed at path speed ``sdot``, with
``x = sdot**2`` and ``u = sddot`` (:mod:`path_velocity`), every limit this
package holds is one of two kinds at each grid point ``i``:

* first order, a bound on the squared path speed alone: ``x <= x_max_i``
  (joint velocity ``|q'_j| sdot <= v_j``; tool speed ``|p'(s)| sdot <= v``);
* second order, rows ``lo <= a u + b x <= hi`` (joint acceleration
  ``q' u + q'' x``; tool acceleration ``|p' u + p'' x| <= A``, held by a
  polygon of such rows; joint torque ``M q' u + (M q'' + C(q, q') q') x + g``,
  whose constant ``g`` is moved into ``lo`` and ``hi``).

Both are the canonical forms of Pham & Pham's TOPP-RA (their "first-order"
and "canonical linear second-order" constraints); each object here gives its
bounds per grid point and knows nothing of the solver.  Rows must allow rest
(``lo <= 0 <= hi``): a path that needs more than the limit to be held still
at some point (a torque that gravity alone exceeds) cannot be traversed at
any speed, and the object says so with a ValueError naming the grid point.

A time scaling by the local factor ``lambda`` (velocity limits times
``lambda``, accelerations times ``lambda**2``) multiplies ``x_max``, ``lo``
and ``hi`` by ``lambda**2``; :class:`path_velocity.PathLimits` applies it.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np


@dataclass(frozen=True)
class GriddedPath:
    """
    A joint path ``q(s)`` on a grid: what every constraint reads.

    ``s`` (M + 1,) grid, ``steps`` (M,) its spacing, ``positions``,
    ``first``, ``second`` (M + 1, n): ``q``, ``q'`` and ``q''`` at the grid
    points; ``third``, ``q'''``, only where a third-order constraint needs it
    (else None).
    """

    s: np.ndarray
    positions: np.ndarray
    first: np.ndarray
    second: np.ndarray
    third: Optional[np.ndarray] = None

    @property
    def steps(self):
        """Grid spacing (M,)."""
        return np.diff(self.s)

    @classmethod
    def of_ppoly(cls, ppoly, s, third=False):
        """Sample a piecewise polynomial path (scipy ``PPoly``) and its derivatives at ``s``."""
        return cls(s, ppoly(s), ppoly(s, 1), ppoly(s, 2), ppoly(s, 3) if third else None)


class SpeedConstraint:
    """A first-order constraint: ``x <= squared_speed_limit(path)`` at every grid point."""

    order = 1

    def squared_speed_limit(self, path):
        """Return the largest squared path speed (M + 1,) at every grid point (inf: none)."""
        raise NotImplementedError


class AccelerationConstraint:
    """A second-order constraint: rows ``lo <= a u + b x <= hi`` at every grid point."""

    order = 2
    # Whether the rows also hold at the end of each grid step with its path
    # acceleration (path_velocity._interpolated), not only at the grid points.
    interpolated = False

    def rows(self, path):
        """Return ``(a, b, lo, hi)``, each (M + 1, k), with ``lo <= 0 <= hi``."""
        raise NotImplementedError


class JerkConstraint:
    """
    A third-order constraint: ``|sdot (c_x x + c_u u + c_du du/ds)| <= bound`` at every grid point.

    The time derivative of a second-order row's ``a u + b x`` along the
    path, with ``du/dt = sdot du/ds`` and ``dx/dt = 2 sdot u``; a time
    scaling by ``lambda`` multiplies ``bound`` by ``lambda**3``.
    """

    order = 3

    def terms(self, path):
        """Return ``(c_x, c_u, c_du, bound)``, each (M + 1, k), ``bound > 0`` (inf: none)."""
        raise NotImplementedError


class JointJerk(JerkConstraint):
    """
    ``|d/dt (q' u + q'' x)| = |sdot (q''' x + 3 q'' u + q' du/ds)| <= j_j`` per joint.

    Joints without a jerk limit (inf) are left out; the path needs ``third``.
    """

    def __init__(self, max_jerk):
        """Take the jerk limit per joint (n,), inf for none."""
        self.max_jerk = np.asarray(max_jerk, float)

    def terms(self, path):
        """Return ``(q''', 3 q'', q', j)`` of the joints with a jerk limit."""
        limited = np.isfinite(self.max_jerk)
        bound = np.broadcast_to(self.max_jerk[limited], (path.s.size, int(limited.sum())))
        return (path.third[:, limited], 3.0 * path.second[:, limited], path.first[:, limited],
                bound)


class JointVelocity(SpeedConstraint):
    """``|q'_j(s)| sdot <= v_j``: ``x <= (v_j / |q'_j|)**2``."""

    def __init__(self, max_velocity):
        """Take the velocity limit per joint (n,)."""
        self.max_velocity = np.asarray(max_velocity, float)

    def squared_speed_limit(self, path):
        """Return ``min_j (v_j / |q'_j|)**2`` (inf where no joint moves)."""
        speed = np.abs(path.first)
        with np.errstate(divide='ignore', over='ignore'):
            return np.min((self.max_velocity[None, :] / speed) ** 2, axis=1)


class JointAcceleration(AccelerationConstraint):
    """``|q'_j u + q''_j x| <= a_j``: eqs. of :mod:`path_velocity`'s docstring."""

    def __init__(self, max_acceleration):
        """Take the acceleration limit per joint (n,)."""
        self.max_acceleration = np.asarray(max_acceleration, float)

    def rows(self, path):
        """Return ``(q', q'', -a, a)``."""
        bound = np.broadcast_to(self.max_acceleration, path.first.shape)
        return path.first, path.second, -bound, bound


class ToolSpeed(SpeedConstraint):
    """
    The linear (or angular) speed of a tool frame: ``|p'(s)| sdot <= v``.

    ``tangent(path)`` returns the tool's velocity per unit path speed,
    ``dp/ds`` (M + 1, 3), e.g. the frame's Jacobian times ``q'``.
    """

    def __init__(self, max_speed, tangent):
        """Take the speed limit (> 0) and the function giving ``dp/ds`` along a path."""
        self.max_speed = float(max_speed)
        self.tangent = tangent

    def squared_speed_limit(self, path):
        """Return ``(v / |dp/ds|)**2`` (inf where the tool does not move)."""
        rate = np.linalg.norm(self.tangent(path), axis=1)
        with np.errstate(divide='ignore', over='ignore'):
            return (self.max_speed / rate) ** 2


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


class JointTorque(AccelerationConstraint):
    """
    Joint torques of the rigid-body dynamics within ``|tau_j| <= max_torque_j``.

    ``inverse_dynamics(q, qd, qdd)`` (each (N, n), returning (N, n)) is
    ``M(q) qdd + c(q, qd) + g(q)``.  Along the path ``qd = q' sdot`` and
    ``qdd = q' u + q'' x``, so (Pham & Pham's canonical form)::

        tau = a u + b x + g,  a = ID(q, 0, q') - g,  b = ID(q, q', q'') - g,  g = ID(q, 0, 0)

    (``c`` is quadratic in ``qd``, so ``c(q, q') = c(q, q' sdot) / x``).
    Only the torques of the planned joints are limited.  ``interpolated``:
    the rows also hold at the end of every grid step
    (:attr:`AccelerationConstraint.interpolated`).  ``gravity(q)``, when
    given (else ``inverse_dynamics.gravity`` if it is callable), is ``g``:
    ``ID(q, 0, 0)`` by a cheaper route.
    """

    def __init__(self, max_torque, inverse_dynamics, interpolated=False, gravity=None):
        """Take the torque limit per joint (n,), the vectorised inverse dynamics and g(q)."""
        self.max_torque = np.asarray(max_torque, float)
        self.inverse_dynamics = inverse_dynamics
        self.interpolated = bool(interpolated)
        if gravity is None:
            gravity = getattr(inverse_dynamics, 'gravity', None)
        self.gravity = gravity if callable(gravity) else None

    def rows(self, path):
        """Return ``(a, b, -tau_max - g, tau_max - g)``; refuse a pose gravity alone overloads."""
        q, first, second = path.positions, path.first, path.second
        zero = np.zeros_like(q)
        if self.gravity is None:
            gravity = self.inverse_dynamics(q, zero, zero)
        else:
            gravity = self.gravity(q)
        a = self.inverse_dynamics(q, zero, first) - gravity
        b = self.inverse_dynamics(q, first, second) - gravity
        if self.gravity is not None:
            # Where the path stops (q' = 0) a is 0 (b too where q'' = 0 as well), not
            # the round-off between g(q) and ID(q, 0, 0).
            still = ~np.any(first, axis=1)
            a[still] = 0.0
            b[still & ~np.any(second, axis=1)] = 0.0
        limit = np.broadcast_to(self.max_torque, gravity.shape)
        refuse_gravity_overload(q, gravity, limit)
        return a, b, -limit - gravity, limit - gravity


# Gravity is refused only beyond its limit by more than this (relative): a
# waypoint where it is exactly at the limit came back 4e-16 over it from the
# path's spline.
GRAVITY_RTOL = 1e-12


class GravityOverload(ValueError):
    """Gravity alone needs more torque than a joint's limit at some point of the path."""

    def __init__(self, index, joint, pose, torque, limit):
        """Record grid point ``index``, joint column ``joint``, the ``pose`` and the torque."""
        self.index, self.joint, self.pose = index, joint, np.array(pose)
        self.torque, self.limit = torque, limit
        # Enough digits to tell the two apart (a torque a hair over its limit).
        digits = 4
        while digits < 17 and f'{abs(torque):.{digits}g}' == f'{limit:.{digits}g}':
            digits += 1
        super().__init__(f'joint {joint}: gravity alone needs {torque:.{digits}g} N m at the '
                         f'pose {np.array2string(self.pose, precision=4)}, beyond its limit '
                         f'of {limit:.{digits}g} N m: no speed along this path holds it')


def refuse_gravity_overload(q, gravity, limit):
    """
    Raise :class:`GravityOverload` for the worst pose where gravity alone exceeds a limit.

    ``q``, ``gravity`` and ``limit`` (N, n): the poses, their gravity
    torques and the limits.  The worst is the largest ``|gravity| / limit``
    (the first of equal ones, in sample then joint order).
    """
    over = np.abs(gravity) > limit * (1.0 + GRAVITY_RTOL)
    if np.any(over):
        ratio = np.where(over, np.abs(gravity) / limit, 0.0)
        i, j = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
        raise GravityOverload(int(i), int(j), q[i], float(gravity[i, j]), float(limit[i, j]))
