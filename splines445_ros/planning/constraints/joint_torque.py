"""Joint torques along a path (rigid body, damping, dry friction): a second-order constraint."""

import numpy as np

from .canonical_forms import AccelerationConstraint


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

    Joint damping, when the inverse dynamics counts it (``D qd``, ``c sdot``
    with ``c = D q'``: not linear in ``x``), enters the rows as ``c x``, as
    ``b`` takes it from ``ID(q, q', q'')``: exact at ``sdot = 1``, the
    path's own timing (rest-to-rest v/a durations), whose speeds the
    profile's are near.  On the damped vendor arms this gave the default
    profile shorter plans (bench_torque's random walks, 12 an arm, seed 31,
    at 0.9 of the efforts, the friction then counted on both sides) than
    the damping's chord up to the velocity limits (median 1.037 against
    1.045 times the rigid-body plan, xArm7; 1.106 against 1.174, TALOS arm)
    or no damping in the rows (1.095, 1.201).  :meth:`speed_terms` gives
    ``c`` itself (with ``viscous``), which the sequential LPs of
    :mod:`~..speed_profile.smooth_profile` linearise at each profile
    instead (``time_optimal``, the same walks: 1.058 and 1.096 times its
    rigid-body plan; 1.141 and 1.309 with ``c x`` and the friction on both
    sides).  The
    rows are the speed profile's reference: the plan's own torque, damping
    in full (``1 / f`` under a slow-down), is checked after and the plan
    slowed where it needs (:class:`~.torque.TorqueLimit`).  Dry friction,
    when ``dry_friction(q)`` is given, lowers the side of a moving joint's
    limit it moves to (:func:`friction_on_sides`, with the sign of ``q'``;
    as far as rest stays allowed there).
    """

    def __init__(self, max_torque, inverse_dynamics, interpolated=False, gravity=None,
                 dry_friction=None, viscous=None):
        """Take the torque limit per joint (n,), the vectorised inverse dynamics and g(q)."""
        self.max_torque = np.asarray(max_torque, float)
        self.inverse_dynamics = inverse_dynamics
        self.interpolated = bool(interpolated)
        if gravity is None:
            gravity = getattr(inverse_dynamics, 'gravity', None)
        self.gravity = gravity if callable(gravity) else None
        self.dry_friction = dry_friction
        self.viscous = viscous

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
        if self.dry_friction is None:
            return a, b, -limit - gravity, limit - gravity
        # The friction the motor overcomes, on the side each joint moves to (q' has
        # sdot's sign), as far as rest stays allowed (a joint the friction leaves no
        # room is refused by the plan's own check).
        up, down = friction_on_sides(self.dry_friction(q), first)
        return (a, b, np.minimum(-(limit - down) - gravity, 0.0),
                np.maximum(limit - up - gravity, 0.0))

    def speed_terms(self, path):
        """
        Return ``c`` (M + 1, n) of the rows' term ``c sdot`` (the damping ``viscous(q, q')``).

        None without ``viscous``.  :meth:`rows` holds it in ``b``, as ``c x``.
        """
        if self.viscous is None:
            return None
        return self.viscous(path.positions, path.first)


def friction_sides(qd, neighbours=True):
    """
    Return (ahead, back) (N, n): where each joint moves forward, backward, at a sample or next.

    Samples in time order: a joint breaking away from rest needs its
    friction at its start, a jump no later sample sees.  Both where it
    reverses among the three (the friction turns over between two samples).
    ``neighbours`` False: at the sample alone (what any check of the
    trajectory counts at least there).
    """
    ahead, back = qd > 0.0, qd < 0.0
    if not neighbours:
        return ahead, back
    near_ahead, near_back = ahead.copy(), back.copy()
    for near, moving in ((near_ahead, ahead), (near_back, back)):
        near[1:] |= moving[:-1]
        near[:-1] |= moving[1:]
    return near_ahead, near_back


def friction_on_sides(friction, qd, neighbours=True):
    """
    Return (up, down) (N, n): the dry ``friction`` that lowers each side of the limits.

    Dry friction opposes the motion with up to ``F``: the motor gives up to
    ``F`` more the way a joint moves (the upper side of ``-L <= tau <= L``
    moving forward, the lower backward; both where it reverses), and is not
    counted on to help it the other way (a model's friction is smooth or
    soft at low speeds, a real one varies).  Like gravity a constant: it
    does not scale with a slow-down.  See :func:`friction_sides`.
    """
    ahead, back = friction_sides(qd, neighbours)
    return np.where(ahead, friction, 0.0), np.where(back, friction, 0.0)


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
