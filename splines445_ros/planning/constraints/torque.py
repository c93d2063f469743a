"""
Joint torque limits along a trajectory (issue 25): the rigid-body torque within each joint's limit.

The caller gives the limits ``max_torque`` (n,) and the inverse dynamics
``inverse_dynamics(q, qd, qdd)`` (each (N, n) -> (N, n)), ``M(q) qdd +
c(q, qd) + g(q)`` with the payload (e.g. :class:`splines445_ros.robot.dynamics.
ArmDynamics`); the planning core never sees the model.  About half the
samples it asks for are at rest, ``inverse_dynamics(q, 0, 0)``, the torque
that gravity alone needs: when ``inverse_dynamics`` has a callable
attribute ``gravity``, ``gravity(q)`` ((N, n) -> (N, n), the same values) is
called for those instead (ArmDynamics' own pass: 3 times less than its
``torques``).

A rest-to-rest spline slowed down uniformly by ``f`` (every duration times
``f``) has the same path, velocities ``/ f`` and accelerations ``/ f**2``, so
its torque is ``g + d / f**2`` with ``d = tau - g`` the dynamic part at
``f = 1``: at every sample and joint, ``|g + d / f**2| <= tau_max`` holds for

    f**2 >= d / (sign(d) tau_max - g)      (gravity alone within the limit)

and the smallest common factor is the largest of those (:meth:`TorqueLimit.
time_factor`).  A pose where gravity alone exceeds a limit holds it at no
speed: :class:`constraints.GravityOverload`.

Joint damping and dry friction, when the inverse dynamics counts them
(callable attributes ``viscous(q, qd)``, the damping part of its torques,
and ``dry_friction(q)``, the friction a moving joint overcomes: ArmDynamics
with ``include_damping``): the damping ``v`` falls as ``1 / f`` only, so the
torque is ``g + v / f + d / f**2``, and with ``y = 1 / f`` each side of the
limit is a quadratic ``v y + d y**2 <= room``; the slow-down a sample needs
is ``1 / y`` at its first positive root (every slower ``f`` holds too),
``y = 2 room / (v + sqrt(v**2 + 4 d room))``.  Dry friction opposes the
motion with up to ``F`` (a model's friction is smoothed or soft below some
speed, a real joint's varies): the motor gives up to ``F`` more the way
the joint moves, and nothing is counted on to help it the other way, so
the limit on the side the joint moves to is lowered by ``F`` (like gravity
a constant, it does not scale with a slow-down), from the sample where the
joint breaks away from rest (it needs ``g + F`` to start) to the one where
it stops; where the joint reverses (a sample and its neighbours moving
both ways) both sides are; a joint still there and at both neighbours is
held by its friction, and keeps the whole limit.

The check of a finished trajectory samples it every :data:`CHECK_PERIOD`
(1 kHz; :data:`MIN_CHECK_SAMPLES` times at least).  Between two samples the
torque is a smooth function of time; the largest it can exceed the larger
sampled neighbour by is ``h**2 / 8`` times its second derivative (h the
period), which the check estimates from the samples' second differences and
adds (:meth:`TorqueLimit.time_factor`).  A 434 plan's jerk jumps at its
knots, so its torque has a kink there, which
no curvature bounds: its knots are samples too (the spacing uneven then).
"""

import math

import numpy as np

from .joint_torque import (friction_on_sides, GRAVITY_RTOL, GravityOverload, JointTorque,
                           refuse_gravity_overload)
from ..spline.segments import sample_segments

# Period [s] of the dense checks of a plan: the torque here, the tool speed in
# cartesian.tool_lines, the demos' deviations (1 kHz, a servo rate).
CHECK_PERIOD = 1e-3
# Samples of a dense check at least, however short the plan: a plan of a few
# milliseconds sampled 2-3 times at 1 kHz left the curvature estimate nothing
# to work with, and its torque peaked 2 % over the limit between them
# (helper-41).  Denser than 1 kHz only below 0.1 s.
MIN_CHECK_SAMPLES = 100
# Period [s] of TorqueLimit.factor_at_least's samples.
COARSE_PERIOD = 1e-2
# Most samples of one check (an hour at 1 kHz): a longer plan is refused
# before anything is allocated for it.
MAX_CHECK_SAMPLES = 3_600_000
# A plan slowed down uniformly for a dense check (torque, tool speed) gets this
# much more than the factor the check says, against round-off: the slowed-down
# plan is not checked again (its check is the same samples rescaled).
SLOW_DOWN_ROUNDOFF = 1.0 + 1e-9
# A check probes the inverse dynamics at this many moving samples a limited
# joint (those with the largest dynamic torque over its limit), slowed down by
# SCALING_PROBE_FACTOR, against the torque the rescaled check assumes, g + v / f
# + d / f**2 (module docstring): a function with a term it does not expose
# (damping without ``viscous``: a plan at 1.88 times its limit, helper-89)
# fails it, and its slowed-down plans are checked again (checked_slow_down).
# Relative to each joint's limit: round-off is ~1e-12 of the torques.
SCALING_PROBES_PER_JOINT = 2
SCALING_PROBE_FACTOR = 2.0
SCALING_RTOL = 1e-6
# Rounds of checking a slowed-down plan again (dynamics that failed the probe):
# each slows it down by what its own 1 kHz check asks, from the torque at its
# speed; a damping term alone is held after one.
RECHECK_ROUNDS = 8
# Samples per spline piece of the inner-knot iteration's torque factor, both
# knots included (each knot sampled once, shared by its two pieces): few, since
# the 1 kHz check and its slow-down hold the limits whatever the count.  The
# measurements behind it are in doc/methods.md ("Where the constants come from").
TORQUE_PIECE_SAMPLES = 5


class TorqueLimit:
    """Per-joint torque limits and the inverse dynamics that gives the torques."""

    def __init__(self, max_torque, inverse_dynamics, n_joints):
        """Validate ``max_torque`` (n,) > 0 (inf: no limit) and the callable."""
        try:
            limit = np.array(max_torque, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise ValueError('max_torque must be numbers, one per joint [N m]') from None
        if limit.size != n_joints:
            raise ValueError(f'max_torque needs one value per joint ({n_joints}), '
                             f'got {limit.size}')
        bad = np.flatnonzero(~(limit > 0.0))
        if bad.size:
            raise ValueError(f'max_torque[{int(bad[0])}] = {limit[bad[0]]:.6g}: '
                             'must be > 0 (inf: no limit)')
        if not callable(inverse_dynamics):
            raise ValueError('inverse_dynamics must be a function tau(q, qd, qdd)')
        self.max_torque = limit
        self.inverse_dynamics = inverse_dynamics
        gravity = getattr(inverse_dynamics, 'gravity', None)
        #: ``inverse_dynamics.gravity`` (q -> the torques at rest) when callable, else None.
        self.gravity = gravity if callable(gravity) else None
        viscous = getattr(inverse_dynamics, 'viscous', None)
        #: ``inverse_dynamics.viscous`` ((q, qd) -> the damping part of its torques) when
        #: callable, else None (no damping counted).
        self.viscous = viscous if callable(viscous) else None
        friction = getattr(inverse_dynamics, 'dry_friction', None)
        #: ``inverse_dynamics.dry_friction`` (q -> the dry friction a moving joint
        #: overcomes) when callable, else None (none counted).
        self.friction = friction if callable(friction) else None
        self.n_joints = n_joints

    def constraint(self, interpolated=False):
        """
        Return the path-velocity constraint object (:class:`constraints.JointTorque`).

        ``interpolated``: its rows also hold at the end of every grid step.
        The damping is in the rows at the path's own speed, and apart
        (:meth:`JointTorque.speed_terms`); the plan's checks hold it in full.
        """
        return JointTorque(self.max_torque, self._torques, interpolated,
                           None if self.gravity is None else self._gravity,
                           None if self.friction is None else self._friction,
                           None if self.viscous is None else self._viscous)

    def _viscous(self, q, qd):
        """Return the damping part (N, n) of the torques at ``q``, ``qd`` (N, n)."""
        return _checked(self.viscous(q, qd), q, 'inverse_dynamics.viscous')

    def _friction(self, q):
        """Return the dry friction (N, n) a moving joint overcomes at ``q`` (N, n)."""
        friction = _checked(self.friction(q), q, 'inverse_dynamics.dry_friction')
        if np.any(friction < 0.0):
            raise ValueError('inverse_dynamics.dry_friction returned negative friction')
        return friction

    def _parts(self, q, qd, neighbours=True):
        """
        Return (viscous, friction) of samples: the damping part and the friction counted.

        Each None when not counted.  ``friction``: (up, down) (N, n), the
        friction that lowers the upper and the lower side of each sample's
        limit: the side a joint moves to at the sample or next to it, both
        where it reverses there (:func:`friction_on_sides`: the samples are in
        time order; ``neighbours`` False: at the sample alone).
        """
        viscous = None if self.viscous is None else self._viscous(q, qd)
        if self.friction is None:
            return viscous, None
        return viscous, friction_on_sides(self._friction(q), qd, neighbours)

    def _torques(self, q, qd, qdd):
        return _checked(self.inverse_dynamics(q, qd, qdd), q, 'inverse_dynamics')

    def _gravity(self, q):
        """Return the torques (N, n) at rest at ``q`` (N, n): gravity's alone."""
        if self.gravity is None:
            zero = np.zeros_like(q)
            return self._torques(q, zero, zero)
        return _checked(self.gravity(q), q, 'inverse_dynamics.gravity')

    def _whole(self, q, qd, qdd, gravity):
        """
        Return the torques (N, n) at the samples, ``gravity`` where at rest.

        ``gravity(q)`` agrees with ``inverse_dynamics(q, 0, 0)`` to round-off
        only: at a sample at rest (the ends of a rest-to-rest plan) the torque
        is taken as ``gravity`` itself, so its dynamic part is exactly 0 (no
        slow-down needed, no excess between samples counted there) as when
        one function gives both.
        """
        tau = self._torques(q, qd, qdd)
        if self.gravity is not None:
            rest = ~(np.any(qd, axis=1) | np.any(qdd, axis=1))
            if np.any(rest):
                tau = np.where(rest[:, None], gravity, tau)
        return tau

    def squared_factors(self, q, qd, qdd, refuse=True, neighbours=True):
        """
        Return per sample and joint (N, n) the squared slow-down each needs, ``f**2`` above.

        Raises :class:`GravityOverload` where gravity alone exceeds a limit;
        with ``refuse`` False the need is infinite there instead (no
        slow-down holds the torque).  ``neighbours``: the friction of a
        joint moving at a neighbouring sample counts too (samples in order).
        """
        if self.gravity is None:
            # One inverse-dynamics call for both: a call costs about as much as
            # 200 samples (ArmDynamics: 100 us, 0.5 us a sample in bulk).
            zero = np.zeros_like(q)
            both = self._torques(np.concatenate([q, q]), np.concatenate([zero, qd]),
                                 np.concatenate([zero, qdd]))
            gravity, tau = both[:len(q)], both[len(q):]
        else:
            gravity = self._gravity(q)
            tau = self._whole(q, qd, qdd, gravity)
        full = np.broadcast_to(self.max_torque, gravity.shape)
        if refuse:
            refuse_gravity_overload(q, gravity, full)
        viscous, friction = self._parts(q, qd, neighbours)
        dynamic = tau - gravity if viscous is None else tau - gravity - viscous
        limit = full if friction is None else (full - friction[0], full - friction[1])
        need = _squared_needs(gravity, dynamic, limit, viscous)
        return need if refuse else np.where(np.abs(gravity) > full * (1.0 + GRAVITY_RTOL),
                                            np.inf, need)

    def piece_factors(self, coeffs, pieces):
        """
        Return per piece (P, 1) the slow-down its :data:`TORQUE_PIECE_SAMPLES` samples need.

        A candidate spline of the construction (not the path) that strays
        into a pose where gravity alone exceeds a limit needs an infinite
        factor there: that candidate is not taken, and the path itself,
        checked when its constraints are built, is not refused for it.
        """
        count = TORQUE_PIECE_SAMPLES
        samples = sample_segments(coeffs, pieces, count, (0, 1, 2))
        n = coeffs.shape[2]
        # A knot ends one piece and starts the next (the spline is C4): sampled once.
        q, qd, qdd = (np.concatenate([a[:, :-1].reshape(-1, n), a[-1, -1:]]) for a in samples)
        need = np.max(self.squared_factors(q, qd, qdd, refuse=False), axis=1)
        inner = np.max(need[:-1].reshape(pieces.size, count - 1), axis=1)
        return np.sqrt(np.maximum(inner, need[count - 1::count - 1]))[:, None]

    def time_factor(self, traj, period=CHECK_PERIOD):
        """
        Return (factor, ratios): the slow-down ``traj`` needs and its peak torque / limit (n,).

        Sampled every ``period``, each sample's dynamic torque raised by the
        estimated excess between samples (module docstring).  A factor at
        most 1 means the torque is within its limits.  A pose where gravity
        alone exceeds a limit raises :class:`GravityOverload` even when the
        motion happens to hold the torque there: no slower timing would.
        """
        return self.check(traj, period).needs()

    def check(self, traj, period=CHECK_PERIOD):
        """
        Return the :class:`TorqueCheck` of the rest-to-rest ``traj``, sampled every ``period``.

        Raises :class:`GravityOverload` as :meth:`time_factor` does.
        """
        q, qd, qdd, steps = _samples(traj, period, spacing=True)
        gravity = self._gravity(q)
        refuse_gravity_overload(q, gravity, np.broadcast_to(self.max_torque, gravity.shape))
        tau = self._whole(q, qd, qdd, gravity)
        viscous, friction = self._parts(q, qd)
        check = TorqueCheck(gravity, tau, self.max_torque, steps, viscous, friction,
                            traj.duration)
        check.scales = self._scales(q, qd, qdd, check)
        return check

    def _scales(self, q, qd, qdd, check):
        """
        Whether the torque slowed down by ``f`` is ``g + v / f + d / f**2`` (probed; bool).

        At each limited joint's :data:`SCALING_PROBES_PER_JOINT` moving samples
        of ``check`` with the largest dynamic torque over its limit, the
        inverse dynamics at ``qd / f``, ``qdd / f**2`` (``f`` =
        :data:`SCALING_PROBE_FACTOR`) against what the rescaled check assumes
        there, each joint within :data:`SCALING_RTOL` of its limit (a term
        that small moves no ratio the check reports).  Per joint: probed at
        the heaviest joint's peak only, a light joint's hidden damping went
        unseen and its plan peaked at 1.15 times its limit (helper-91).
        True with nothing moving.
        """
        moving = np.flatnonzero(np.any(qd, axis=1) | np.any(qdd, axis=1))
        limited = np.flatnonzero(np.isfinite(self.max_torque))
        if not moving.size or not limited.size:
            return True
        share = (np.abs(check.tau[moving] - check.gravity[moving])[:, limited]
                 / self.max_torque[limited])
        top = np.argsort(share, axis=0, kind='stable')[-SCALING_PROBES_PER_JOINT:]
        at = moving[np.unique(top)]
        f = SCALING_PROBE_FACTOR
        probed = self._torques(q[at], qd[at] / f, qdd[at] / (f * f))
        assumed = check.gravity[at] + check.dynamic[at] / (f * f)
        if check.viscous is not None:
            assumed = assumed + check.viscous[at] / f
        error = np.max(np.abs(probed - assumed)[:, limited], axis=0)
        return bool(np.all(error <= SCALING_RTOL * self.max_torque[limited]))

    def factor_at_least(self, traj, period=COARSE_PERIOD):
        """
        Return a lower bound of the slow-down ``traj`` needs: the need at samples every ``period``.

        Without the excess between samples that :meth:`time_factor` adds,
        the largest need at any points of the trajectory is at most the
        largest need anywhere, so at most the factor the 1 kHz check finds.
        A caller that only wants to know whether a slowed-down plan is
        longer than another spares the check (10 ms samples: a tenth of it).
        The friction counts at a sample on the side its joint moves to there
        alone: its neighbours 10 ms away count more than the check's 1 ms
        ones (helper-87: 18 % above the check's need where joints reverse).
        """
        return math.sqrt(float(np.max(self.squared_factors(*_samples(traj, period),
                                                           neighbours=False))))


def _checked(tau, q, what):
    """Return ``tau``, what the function ``what`` gave, as floats: shaped as ``q``, finite."""
    if np.iscomplexobj(tau):
        # As float it would drop the imaginary part with a warning only (helper-89).
        raise ValueError(f'{what} returned complex torques: they must be real')
    tau = np.asarray(tau, dtype=float)
    if tau.shape != q.shape or not np.all(np.isfinite(tau)):
        raise ValueError(f'{what} returned {tau.shape} or non-finite torques for {q.shape} '
                         'samples')
    return tau


def _bend(tau, steps=None):
    """
    Return the excess of ``tau`` (N, n) between samples: h**2 / 8 |tau''| (module docstring).

    ``steps`` (N - 1,): the samples' spacing where it is not even (the
    knots of a 434 plan among them), None where it is.
    """
    bend = np.zeros_like(tau)
    if steps is None:
        bend[1:-1] = np.abs(tau[2:] - 2.0 * tau[1:-1] + tau[:-2]) / 8.0
    else:
        slopes = np.diff(tau, axis=0) / steps[:, None]
        second = 2.0 * np.diff(slopes, axis=0) / (steps[1:] + steps[:-1])[:, None]
        # Each sample's curvature, over the longer step next to it.
        step = np.maximum(steps[1:], steps[:-1])[:, None]
        bend[1:-1] = np.abs(second) * step * step / 8.0
    bend[:-1] = np.maximum(bend[:-1], bend[1:])
    return bend


def _sides(limit):
    """Return (upper, lower) of a limit: the same array twice, or the pair it is."""
    return limit if isinstance(limit, tuple) else (limit, limit)


def _squared_needs(gravity, dynamic, limit, viscous=None):
    """
    Return per sample and joint the squared slow-down ``|g + d / f**2| <= limit`` needs.

    ``limit``: an array, or (upper, lower) arrays for ``-lower <= torque <=
    upper`` (the friction on the side a joint moves to).  No room (gravity
    at the limit, or beyond a ``limit`` lowered by an excess between
    samples, on either side: slowed down, the torque tends to ``g``) and
    motion: no slow-down holds the torque there (infinite need).  With the
    damping part ``viscous`` (not None), the torque is ``g + v / f + d /
    f**2``: :func:`_viscous_needs`.
    """
    if viscous is not None:
        return _viscous_needs(gravity, viscous, dynamic, limit)
    upper, lower = _sides(limit)
    room = np.where(dynamic >= 0.0, upper - gravity, -lower - gravity)
    some = np.where(dynamic >= 0.0, room > 0.0, room < 0.0) & \
        (gravity <= upper * (1.0 + GRAVITY_RTOL)) & (-gravity <= lower * (1.0 + GRAVITY_RTOL))
    with np.errstate(divide='ignore', invalid='ignore'):
        need = np.where(some, dynamic / room, np.inf)
    return np.where(dynamic == 0.0, 0.0, need)


def _viscous_needs(gravity, viscous, dynamic, limit, bend_viscous=0.0, bend_dynamic=0.0):
    """
    Return per sample and joint the squared slow-down ``|g + v / f + d / f**2| <= limit`` needs.

    ``bend_viscous`` and ``bend_dynamic`` (>= 0): the excesses between
    samples of the two parts at ``f = 1``, added on either side (``v / f``'s
    falls as ``1 / f``, ``d / f**2``'s as ``1 / f**2``).  With ``y = 1 / f``
    each side is ``p(y) = v y + d y**2 <= room`` (the lower side with ``-v``,
    ``-d``; each with its excesses): :func:`_first_root` gives the first
    ``y > 0`` where it fails, and the need is ``1 / y**2`` at the smaller
    of the two sides' (0 when neither side ever fails).  A side whose room
    is gone (gravity at or beyond a ``limit`` lowered by friction or an
    excess between samples; within :data:`GRAVITY_RTOL` of the limit counts
    as at it) fails at once wherever the motion pushes into it: infinite
    need.
    """
    upper, lower = _sides(limit)
    need = np.zeros(gravity.shape)
    for side, room, v, d in (
            (upper, upper - gravity, viscous + bend_viscous, dynamic + bend_dynamic),
            (lower, lower + gravity, bend_viscous - viscous, bend_dynamic - dynamic)):
        slack = GRAVITY_RTOL * np.abs(side)
        room = np.where((room < 0.0) & (room >= -slack), 0.0, room)
        need = np.maximum(need, _first_root(room, v, d))
    return need


def _first_root(room, v, d):
    """
    Return ``1 / y**2`` for the first ``y > 0`` with ``v y + d y**2 > room`` beyond it (0: none).

    ``y = 2 room / (v + sqrt(v**2 + 4 d room))`` (the root nearer 0, in the
    form that stays exact for ``d`` near 0), so the squared need is
    ``((v + sqrt(v**2 + 4 d room)) / (2 room))**2``; it exists where the
    discriminant is not negative and ``v + sqrt(...) > 0``.  With no room
    (``room = 0``) the root is ``y = -v / d`` where the damping pulls away
    and the rest pushes in (``v < 0 < d``); infinite where the motion pushes
    into it at once (``v > 0``, or ``v = 0 < d``), and where ``room < 0``
    and anything moves.  No limit (``room`` infinite): 0.
    """
    with np.errstate(invalid='ignore', divide='ignore'):
        disc = v * v + 4.0 * d * room
        s = v + np.sqrt(np.maximum(disc, 0.0))
        need = np.where((disc >= 0.0) & (s > 0.0), (s / (2.0 * room)) ** 2, 0.0)
        later = np.where((v < 0.0) & (d > 0.0), (d / v) ** 2, 0.0)
    pushes = (v > 0.0) | ((v == 0.0) & (d > 0.0))
    moves = (v != 0.0) | (d != 0.0)
    gone = ((room == 0.0) & pushes) | ((room < 0.0) & moves)
    need = np.where(np.isinf(room), 0.0, np.where(room > 0.0, need, 0.0))
    return np.where(gone, np.inf, np.where(room == 0.0, later, need))


class TorqueCheck:
    """
    The 1 kHz torque check of a rest-to-rest trajectory, and of the same slowed down uniformly.

    Slowed down by ``f``, the trajectory passes the same path points at the
    samples' times times ``f``, with the torque ``g + d / f**2`` there (module
    docstring): its check is this one's samples, rescaled, with no inverse
    dynamics.  Their spacing is then ``f`` times the period, and the excess
    between them ``h**2 / 8`` times the second time derivative of ``g`` and
    of ``d / f**2``, each of which is this check's divided by ``f**2``: at most
    the gravity's excess plus the dynamic part's over ``f**2``.  With the
    damping part ``viscous`` (the torque ``g + v / f + d / f**2``) its excess
    is this check's over ``f``.  The dry friction (module docstring), when
    given: ``friction`` (up, down) (N, n), what lowers the upper and the
    lower side of each sample's limit; the peak ratios count it as torque.
    ``duration`` [s], when given, bounds the slow-down
    (:meth:`required_slow_down`).
    """

    def __init__(self, gravity, tau, limit, steps=None, viscous=None, friction=None,
                 duration=None):
        """Keep the samples' gravity and whole torques (N, n), the limits (n,), the spacing."""
        self.gravity, self.tau, self.limit = gravity, tau, limit
        self.duration = duration    # the trajectory's [s], when known
        self.steps = steps      # (N - 1,) where the samples are not evenly spaced
        self.viscous = viscous
        self.dynamic = tau - gravity if viscous is None else tau - gravity - viscous
        # The friction on each side, and the limits (upper, lower) each sample holds.
        zero = np.zeros(tau.shape)
        self.up, self.down = (zero, zero) if friction is None else friction
        full = np.broadcast_to(limit, tau.shape)
        self.limits = (full - self.up, full - self.down)
        # Per joint: whether its friction was counted anywhere (said in a refusal).
        self.counts_friction = np.any(self.up, axis=0) | np.any(self.down, axis=0)
        self._split = None
        # Whether the inverse dynamics scales as the rescaled checks assume
        # (TorqueLimit.check probes it; checked_slow_down): True unless shown not.
        self.scales = True

    def _peaks(self, torque, *bends):
        """Return per joint the peak over the samples of the motor torque and friction / limit."""
        peak = np.maximum(torque + self.up, self.down - torque)     # |torque| without friction
        for bend in bends:
            peak = peak + bend
        return np.max(peak / self.limit, axis=0)

    def _lowered(self, bend):
        """Return the limits (upper, lower) lowered by ``bend`` (N, n)."""
        return self.limits[0] - bend, self.limits[1] - bend

    def needs(self, factor=1.0):
        """
        Return (factor, ratios) of the trajectory slowed down by ``factor``: as ``time_factor``.

        At ``factor`` 1 the excess between samples is that of the torque
        itself; slowed down, the parts' excesses bound it (class
        docstring), and the factor is :meth:`slow_down` over ``factor``.
        """
        bend_gravity, bend_viscous, bend_dynamic, split = self._split_needs()
        if factor == 1.0:
            bend = _bend(self.tau, self.steps)
            if self.viscous is None:
                need = _squared_needs(self.gravity, self.dynamic + np.sign(self.dynamic) * bend,
                                      self.limits)
            else:
                # At f = 1 the whole torque's excess, exact there.
                need = _viscous_needs(self.gravity, self.viscous, self.dynamic, self.limits,
                                      0.0, bend)
            # Where gravity with its own excess between samples leaves no room
            # (on either side), no slow-down holds the torque: none does here.
            need = np.where(np.isinf(split), np.inf, need)
            ratios = self._peaks(self.tau, bend)
            if self.viscous is not None:
                # A sample within its limit at f = 1 needs no slow-down, though a
                # slower plan might not hold it (a gap: slow_down() is past it).
                within = ((self.tau + bend <= self.limits[0])
                          & (bend - self.tau <= self.limits[1]))
                need = np.where(within, np.minimum(need, 1.0), need)
            return math.sqrt(float(np.max(need))), ratios
        scale = 1.0 / (factor * factor)
        if self.viscous is None:
            peaks = self._peaks(self.gravity + self.dynamic * scale, bend_gravity,
                                bend_dynamic * scale)
        else:
            peaks = self._peaks(self.gravity + self.viscous / factor + self.dynamic * scale,
                                bend_gravity, bend_viscous / factor, bend_dynamic * scale)
        return self.slow_down() / factor, peaks

    def slow_down(self):
        """
        Return the smallest ``f`` for which :meth:`needs` ``(f)`` holds the limits (inf: none).

        Infinite where gravity plus its excess between samples leaves no room.
        """
        return math.sqrt(float(np.max(self._split_needs()[3])))

    def slow_down_with(self, factor=1.0, torque_need=None):
        """
        Return the uniform slow-down (>= 1) that holds the torque and another ``factor``.

        ``factor``: what another check of the same trajectory asks (a tool
        speed's; 1 = nothing); ``torque_need``: ``needs()[0]`` when the caller
        has it.  When either needs more than 1, the larger of ``factor`` and
        :meth:`required_slow_down` (ValueError where none holds), through
        :func:`uniform_slow_down`; 1.0 otherwise.
        """
        need = self.needs()[0] if torque_need is None else torque_need
        if need > 1.0 or factor > 1.0:
            factor = max(factor, self.required_slow_down())
        return uniform_slow_down(factor)

    def required_slow_down(self):
        """
        Return :meth:`slow_down`, or raise :class:`NoRoomToMove` where none holds the torque.

        None holds it where the need is infinite, nor where the plan slowed
        down would last longer than a check takes (an hour): gravity and
        friction leave a joint almost no room (a 6e6 s plan was returned,
        helper-86).
        """
        slow = self.slow_down()
        need = self._split_needs()[3]
        if not math.isfinite(slow):
            j = int(np.argmax(np.any(np.isinf(need), axis=0)))
            raise NoRoomToMove(j, bool(self.counts_friction[j]))
        longest = MAX_CHECK_SAMPLES * CHECK_PERIOD
        if self.duration is not None and self.duration * slow > longest:
            j = int(np.argmax(np.max(need, axis=0)))
            raise NoRoomToMove(j, bool(self.counts_friction[j]), self.duration * slow, longest)
        return slow

    def _split_needs(self):
        """Return the excesses of gravity, damping and the rest, and the needs they bound."""
        if self._split is None:
            bend_gravity = _bend(self.gravity, self.steps)
            bend_dynamic = _bend(self.dynamic, self.steps)
            if self.viscous is None:
                bend_viscous = None
                need = _squared_needs(self.gravity,
                                      self.dynamic + np.sign(self.dynamic) * bend_dynamic,
                                      self._lowered(bend_gravity))
            else:
                bend_viscous = _bend(self.viscous, self.steps)
                need = _viscous_needs(self.gravity, self.viscous, self.dynamic,
                                      self._lowered(bend_gravity), bend_viscous, bend_dynamic)
            self._split = (bend_gravity, bend_viscous, bend_dynamic, need)
        return self._split


class NoRoomToMove(ValueError):
    """Gravity (with a moving joint's dry friction) leaves a joint no torque to move with."""

    def __init__(self, joint, friction, duration=None, longest=None):
        """
        Record the joint's column and whether its friction was counted there.

        ``duration``: what the slowed-down plan would last [s], when that is
        beyond ``longest`` (else None: no speed holds it at all).
        """
        self.joint, self.friction = joint, friction
        self.duration, self.longest = duration, longest
        super().__init__(f'joint {joint}: {self.what()} {self.how()} (lower the payload or raise '
                         'the limit)')

    def how(self):
        """Return how little room it leaves: none, or too little for a plan within the hour."""
        if self.duration is None:
            return ('uses its whole torque limit where the plan moves (with its change between '
                    '1 ms samples): no speed holds it')
        return (f'leaves it almost no torque to move with: the plan would last '
                f'{self.duration:.4g} s, more than {self.longest:g} s')

    def what(self):
        """Return what uses the limit: 'gravity', or 'gravity with its dry friction'."""
        return 'gravity with its dry friction' if self.friction else 'gravity'


def checked_slow_down(torque, check, traj, slow, slower):
    """
    Return ``traj`` slowed down by ``slow`` or more, the factor, and its (factor, ratios).

    ``check``: ``torque.check(traj)``; ``slower(traj, f)``: ``traj`` with
    every duration times ``f``.  Where the inverse dynamics scales as the
    check assumes (``check.scales``), the slowed-down plan's (factor, ratios)
    are ``check.needs(slow)``, with no second 1 kHz check.  Otherwise (a
    term it does not expose, e.g. damping without ``viscous``) the slowed-down
    plan is checked again and, where it still exceeds a limit, slowed down
    further as if its dynamic torque fell as ``1 / f`` only (the factor
    squared: a damping term's, where ``1 / f**2`` would take a round per
    halving of its excess; slower than needed where the rest is inertial,
    which exposing the damping as ``viscous`` avoids), for at most
    :data:`RECHECK_ROUNDS` rounds (ValueError if it still exceeds a limit),
    each from ``traj``.
    """
    slowed = slower(traj, slow)
    if check.scales:
        return slowed, slow, check.needs(slow)
    for _ in range(RECHECK_ROUNDS):
        again = torque.check(slowed)
        factor, ratios = again.needs()
        if factor <= 1.0:
            return slowed, slow, (factor, ratios)
        slow *= uniform_slow_down(factor * factor)
        slowed = slower(traj, slow)
    j = int(np.argmax(ratios))
    raise ValueError(f'inverse_dynamics does not scale as M(q) qdd + c(q, qd) + g(q) under a '
                     f'slow-down (damping or friction inside? give them as its attributes '
                     f'viscous(q, qd) and dry_friction(q)), and {RECHECK_ROUNDS} slow-downs '
                     f'left joint {j} at {ratios[j]:.4g} times its torque limit')


def uniform_slow_down(factor):
    """Return the slow-down for a check's ``factor``: 1.0, or above 1 with SLOW_DOWN_ROUNDOFF."""
    return factor * SLOW_DOWN_ROUNDOFF if factor > 1.0 else 1.0


def _samples(traj, period, spacing=False):
    """
    Return the positions, velocities and accelerations of ``traj`` every ``period``.

    A rest-to-rest plan's first and last samples are at rest exactly (the
    polynomials give round-off there: a dynamic part of 1e-16 at a goal
    where gravity is at a limit asked for an infinite slow-down).  A 434
    plan's jerk jumps at its knots, so its torque has a kink there, which
    no curvature between samples bounds (4 times the estimate: 0.8 % over
    a limit, helper-37): its knots are samples too.  ``spacing``: also
    return the steps between the samples (None where they are even).
    """
    t = check_times(traj.duration, period, 'the torque')
    steps = None
    if traj.method == '434':
        t = np.union1d(t, traj.breakpoints[(traj.breakpoints > 0.0)
                                           & (traj.breakpoints < traj.duration)])
        steps = np.diff(t)
    q, qd, qdd = (traj.evaluate(t, d) for d in range(3))
    if not any(np.any(v) for v in (traj.start_velocity, traj.start_acceleration,
                                   traj.end_velocity, traj.end_acceleration)):
        qd[[0, -1]] = 0.0
        qdd[[0, -1]] = 0.0
    return (q, qd, qdd, steps) if spacing else (q, qd, qdd)


def check_times(duration, period, what):
    """
    Return the sample times of a check every ``period`` over ``duration``; ValueError if too many.

    At least :data:`MIN_CHECK_SAMPLES` steps (denser on a short plan), at
    most :data:`MAX_CHECK_SAMPLES`: ``what`` (e.g. "the torque") names
    the check in the error.
    """
    if not math.isfinite(duration) or duration / period > MAX_CHECK_SAMPLES:
        raise ValueError(f'the trajectory lasts {duration:.4g} s: {what} is checked every '
                         f'{period * 1e3:g} ms for at most {MAX_CHECK_SAMPLES * period:g} s')
    return np.linspace(0.0, duration,
                       max(MIN_CHECK_SAMPLES, int(math.ceil(duration / period))) + 1)


__all__ = ['check_times', 'CHECK_PERIOD', 'checked_slow_down', 'GravityOverload', 'NoRoomToMove',
           'SLOW_DOWN_ROUNDOFF', 'TorqueCheck', 'TorqueLimit', 'uniform_slow_down']
