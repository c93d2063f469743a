"""The planned trajectory: one scipy PPoly for all joints, plus what limits it met."""

from dataclasses import replace
from math import comb, perm
from typing import NamedTuple

import numpy as np
from scipy.interpolate import PPoly

from .continuity_system import spline_coefficients
from .limits import binding_limit, limit_ratios, QUANTITIES, rest_to_rest_times
from .peaks import position_extrema, segment_peaks
from .segments import falling_factors

# Most samples ``sample()`` returns: a period that would give more is a
# mistake (1e-12 s on a 4 s trajectory would need 44 TiB), not a request.
MAX_SAMPLES = 10_000_000
# Relative difference between a duration and its PPoly width above which the
# spline is solved again on the width (below it, the difference is round-off).
REBUILD_RTOL = 1e-12
# Stretches of a rebuilt "uniform" or "optimal" trajectory back to its limits.
REBUILD_STRETCHES = 3
# Smallest relative stretch of such a rebuild.  Far along the time axis a
# stretch by a ratio of 1 + 1e-15 moved no breakpoint: 555 uniform timing of
# a 1000-waypoint single-joint random walk (5000 s) failed with "exceeds a
# limit by a factor 1"; 1e-9 of the duration is below any servo period.
MIN_STRETCH = 1e-9


def representable_durations(durations):
    """
    Return the segment widths that a PPoly on ``cumsum(durations)`` really has.

    Breakpoints are rounded sums, so a short segment after a long total gets a
    width that differs from its duration by up to the total's round-off.
    Coefficients must be built on these widths, or positions at the knots
    jump and peaks are not those of the evaluated polynomials.
    """
    d = np.asarray(durations, dtype=float)
    return np.diff(np.concatenate([[0.0], np.cumsum(d)], axis=-1), axis=-1)


class Samples(NamedTuple):
    """A trajectory sampled at fixed times: arrays of shape (K,) and (K, n)."""

    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    accelerations: np.ndarray


class Trajectory:
    """
    A piecewise-polynomial joint trajectory through waypoints.

    Attributes
    ----------
    durations : (N-1,) segment durations in seconds (one per piece when the
        trajectory has inner knots, see :mod:`inner_knots`).
    breakpoints : (N,) waypoint times, starting at 0.0 (with inner knots:
        every knot's time).
    waypoint_times : (N,) the time at which each waypoint is passed.
    duration : total time.
    ppoly : ``scipy.interpolate.PPoly``; ``x = breakpoints``, values of shape (n,).
    waypoints : (N, n) the waypoints it passes through (after merging duplicates).
    method, timing : how it was planned.
    scale : the common factor applied to the chord durations (uniform timing) or None.
    dropped_waypoints : indices (in the caller's numbering) of consecutive
        duplicate waypoints that were merged away before planning.
    limits : the :class:`JointLimits` it was planned against, or None.
    optimizer : dict or None
        How optimal timing found it (iterations, message, inner knots, ...;
        what ``~/status`` reports), None for the other timings.
    torque_ratios : (n,) or None
        With torque limits: each joint's peak torque over its limit (the
        1 kHz check), else None.
    torque_factor : float or None
        With torque limits: the slow-down that check still asks (<= 1: the
        limits hold), else None.

    """

    def __init__(self, method, timing, waypoints, durations, coefficients,
                 boundary, limits=None, scale=None, dropped_waypoints=(), ratios=None):
        """
        Wrap ascending per-segment ``coefficients`` (S, 6, n) into a PPoly.

        The coefficients are used on the PPoly's own widths, so they must be
        built on :func:`representable_durations` (:meth:`build` does that).
        ``ratios`` (S, n, 3), when the caller already has them, are the exact
        peak / limit ratios of these coefficients (they are computed otherwise).
        """
        self.method = method
        self.timing = timing
        self.waypoints = waypoints
        self.durations = np.asarray(durations, dtype=float)
        self.breakpoints = np.concatenate([[0.0], np.cumsum(self.durations)])
        self.duration = float(self.breakpoints[-1])
        self.waypoint_times = self.breakpoints
        self.coefficients = coefficients
        self.ppoly = PPoly(coefficients[:, ::-1].transpose(1, 0, 2), self.breakpoints,
                           extrapolate=True)
        self.start_velocity, self.start_acceleration, self.end_velocity, \
            self.end_acceleration = boundary
        self.limits = limits
        self.scale = scale
        self.dropped_waypoints = tuple(dropped_waypoints)
        # Set by the planner where they apply (see the class docstring).
        self.optimizer = None
        self.torque_ratios = None
        self.torque_factor = None
        self._ratios = ratios
        self._derivatives = {0: self.ppoly}
        self._segment_peaks = {}
        self._position_extrema = None

    @classmethod
    def build(cls, method, timing, points, durations, boundary, limits=None, coefficients=None,
              ratios=None, **extra):
        """
        Return the Trajectory of ``method`` through ``points`` for ``durations``, checked.

        ``coefficients`` (and their ``ratios``), when the caller has them for
        ``durations``, are kept unless the PPoly's widths
        (:func:`representable_durations`) differ from the durations by more
        than round-off (:data:`REBUILD_RTOL`); then the spline is solved again
        on the widths, and for "uniform" and "optimal" timing, which promise
        the limits, all durations are stretched by the largest ratio while
        one exceeds 1 (exact for rest-to-rest requests).  Raises ValueError
        when a segment is below the resolution of the time axis or the
        result is not finite (absurd limits or durations overflow).
        """
        durations = np.asarray(durations, dtype=float)
        for _ in range(REBUILD_STRETCHES + 1):
            widths = representable_durations(durations)
            if not np.all(widths > 0.0):
                k = int(np.flatnonzero(~(widths > 0.0))[0])
                raise ValueError(f'segment {k} ({durations[k]:.3g} s) is shorter than the '
                                 'resolution of the time axis at its start time')
            mismatch = np.max(np.abs(widths - durations) / durations)
            if coefficients is None or not mismatch <= REBUILD_RTOL:
                coefficients, ratios = spline_coefficients(method, points, widths, boundary), None
            traj = cls(method, timing, points, widths, coefficients, boundary, limits,
                       ratios=ratios, **extra)
            require_finite(traj)
            if timing == 'fixed' or ratios is not None or traj.within_limits(rtol=0.0):
                return traj
            # At least MIN_STRETCH: a ratio within round-off of 1 would leave
            # the rounded widths, and the excess, as they are.
            durations = widths * max(float(np.max(traj.limit_ratios())), 1.0 + MIN_STRETCH)
            coefficients = None
        raise ValueError(f'the {timing} plan exceeds a limit by a factor '
                         f'{traj.binding.ratio:.6g} after solving it on the widths of the '
                         'time axis, and stretching did not restore the limits')

    @property
    def n_joints(self):
        """Return the number of joints."""
        return self.waypoints.shape[1]

    def _derivative(self, derivative):
        if derivative not in self._derivatives:
            self._derivatives[derivative] = self.ppoly.derivative(derivative)
        return self._derivatives[derivative]

    def evaluate(self, t, derivative=0):
        """
        Position (0), velocity (1), acceleration (2) or jerk (3) at times ``t``: (len(t), n).

        Times outside [0, duration] are clamped to it (the robot holds its end states).
        """
        if derivative not in (0, 1, 2, 3):
            raise ValueError(f'derivative must be 0, 1, 2 or 3, got {derivative!r}')
        t = np.clip(np.atleast_1d(np.asarray(t, dtype=float)), 0.0, self.duration)
        return self._derivative(derivative)(t)

    def sample(self, period, resolution=0.0):
        """
        Sample every ``period`` seconds and at every knot (waypoints exactly).

        Every breakpoint of :attr:`ppoly` is a sample: the waypoints (at them
        exactly), the inner knots and a replanning start.  Between two knots
        the spline is one quintic, so a controller that interpolates the
        samples by quintics through their positions, velocities and
        accelerations (JTC, ``arm_sim_node``) plays it exactly, however
        coarse ``period`` is.  Otherwise it would pass a waypoint that falls
        between two samples only approximately, skip one where a segment is
        shorter than ``period``, and leave the spline that a replanning or a
        stop starts from (a ``time_optimal`` plan sampled every 0.5 s was
        played at 1.08 times the acceleration limit).  A regular sample
        closer than ``period / 2`` to a knot is dropped, so that no interval
        is tiny but those between knots closer than that; none is two
        periods or longer.  ``resolution`` > 0 (a message's
        nanosecond): a sample whose time rounds onto the one before it is
        dropped (the last one stays, the one before it goes), so the times
        stay strictly increasing once rounded, and the samples are taken at
        the rounded times: an inner waypoint's sample is the spline there,
        within ``|v| resolution / 2`` of the waypoint (the waypoint itself at
        a rounded time was a step of ~6e-10 rad, which a controller's quintic
        to a neighbour 0.2 ms away played at 37-159 times the jerk limit,
        helper-92), the waypoint at its exact time; the first and the last
        sample are the first and the last waypoint (where the arm starts and
        rests).
        """
        times, at_waypoint = self.sample_times(period, resolution)
        positions = self.evaluate(times, 0)
        velocities = self.evaluate(times, 1)
        accelerations = self.evaluate(times, 2)
        exact = np.flatnonzero(at_waypoint >= 0)
        exact = exact[(times[exact] == self.waypoint_times[at_waypoint[exact]])
                      | (exact == 0) | (exact == times.size - 1)]
        positions[exact] = self.waypoints[at_waypoint[exact]]
        velocities[-1] = self.end_velocity
        accelerations[-1] = self.end_acceleration
        return Samples(times, positions, velocities, accelerations)

    def sample_times(self, period, resolution=0.0):
        """
        Return the times of :meth:`sample` and, per time, its waypoint's index (-1: none).

        Cheap (no evaluation): for counting the samples before taking them.
        """
        try:
            period, resolution = float(period), float(resolution)
        except (TypeError, ValueError):
            raise ValueError(f'sample period must be a number, got {period!r}') from None
        if not np.isfinite(period) or period <= 0.0:
            raise ValueError(f'sample period must be positive and finite, got {period}')
        count = np.floor(self.duration / period)
        if count + 2 > MAX_SAMPLES:
            raise ValueError(f'sample period {period:g} s gives about {count:.3g} samples of '
                             f'this {self.duration:.6g} s trajectory, more than {MAX_SAMPLES}')
        regular = np.arange(int(count) + 1) * period
        knots = np.asarray(self.ppoly.x, dtype=float)
        # Each knot's waypoint (the waypoint times are knots, exactly), else -1.
        waypoint = np.full(knots.size, -1)
        waypoint[np.searchsorted(knots, self.waypoint_times)] = np.arange(
            len(self.waypoint_times))
        # The nearest knot of every regular sample (the times are sorted).
        after = np.clip(np.searchsorted(knots, regular), 1, knots.size - 1)
        nearest = np.minimum(np.abs(regular - knots[after - 1]), np.abs(knots[after] - regular))
        regular = regular[(nearest >= 0.5 * period) & (regular < self.duration)]
        times = np.concatenate([regular, knots])
        index = np.concatenate([np.full(regular.size, -1), waypoint])
        order = np.argsort(times, kind='stable')
        times, index = times[order], index[order]
        if resolution > 0.0:
            ticks = np.round(times / resolution)
            keep = np.append(ticks[1:] > ticks[:-1], True)   # the last of each tick,
            keep[ticks == ticks[0]] = False                  # but the first tick's first:
            keep[0] = True                                   # t = 0, the start
            # On the grid: the state is then the spline's at the time published.
            times, index = ticks[keep] * resolution, index[keep]
        return times, index

    def knots(self, resolution=0.0):
        """
        Return the state at every breakpoint of ``ppoly`` (every knot, inner knots too).

        A quintic Hermite interpolation between consecutive knots through their
        positions, velocities and accelerations (what ros2_control's
        joint_trajectory_controller does) reproduces this trajectory exactly:
        every segment is a polynomial of degree <= 5, fixed by those six values.

        The state at a knot is the start of the segment that begins there (its
        coefficients, no evaluation round-off); the last knot is the last
        waypoint with the end velocity and acceleration.  ``resolution`` > 0
        [s] rounds the knot times to multiples of it (1e-9 for
        ``time_from_start`` of a ROS message) and moves each state along its
        polynomial to the rounded time (the last one along the last segment
        beyond the end), so that the interpolation between the rounded times
        still reproduces the spline: to round-off where the jerk is
        continuous (445, 555); where it jumps (434) the interpolation before a
        knot is off by the jump times the rounding (in acceleration).  Raises
        ValueError when two knots round to the same time.
        """
        resolution = float(resolution)
        if not np.isfinite(resolution) or resolution < 0.0:
            raise ValueError(f'resolution must be >= 0 and finite, got {resolution}')
        times = self.breakpoints
        if resolution > 0.0:
            times = np.round(times / resolution) * resolution
            close = np.flatnonzero(np.diff(times) <= 0.0)
            if close.size:
                k = int(close[0])
                raise ValueError(f'knots {k} and {k + 1} are {self.durations[k]:.3g} s apart: '
                                 f'closer than the time resolution {resolution:g} s of the '
                                 'output')
        # Taylor coefficients (K, 6, n) of the state at every knot: each segment's
        # own at its start, the last segment's at its end for the last knot.
        last = self.coefficients[-1]
        h = self.durations[-1]
        end = np.array([sum(comb(m, i) * last[m] * h ** (m - i) for m in range(i, 6))
                        for i in range(6)])
        end[:3] = self.waypoints[-1], self.end_velocity, 0.5 * self.end_acceleration
        taylor = np.concatenate([self.coefficients, end[None]])
        tau = (times - self.breakpoints)[:, None]
        states = []
        for d in range(3):
            value = np.zeros_like(taylor[:, 0])
            for i in range(5, d - 1, -1):  # Horner in tau of the d-th derivative
                value = value * tau + perm(i, d) * taylor[:, i]
            states.append(value)
        return Samples(times.copy(), *states)

    def segment_peaks(self, derivative):
        """Exact per-segment peak |derivative| (S, n); 1 = velocity, 2 = acc, 3 = jerk."""
        if derivative not in self._segment_peaks:
            self._segment_peaks[derivative] = segment_peaks(
                self.coefficients, self.durations, derivative)
        return self._segment_peaks[derivative]

    def peaks(self):
        """Return a dict quantity -> (n,) peak |value| over the whole trajectory."""
        return {name: self.segment_peaks(d + 1).max(axis=0) for d, name in enumerate(QUANTITIES)}

    def position_extrema(self):
        """
        Exact position range: ``(low, high, low_time, high_time)``, each (n,).

        From the polynomials (segment ends and roots of the velocity), like
        the peaks; the times are in seconds from the start.
        """
        if self._position_extrema is None:
            # Each segment ends exactly at the next knot (its constant term).
            ends = np.concatenate([self.coefficients[1:, 0, :], self.waypoints[-1:]])
            low, high, t_low, t_high = position_extrema(self.coefficients, self.durations, ends)
            i_low, i_high = np.argmin(low, axis=0), np.argmax(high, axis=0)
            joints = np.arange(self.n_joints)
            self._position_extrema = (
                low[i_low, joints], high[i_high, joints],
                self.breakpoints[i_low] + t_low[i_low, joints],
                self.breakpoints[i_high] + t_high[i_high, joints])
        return self._position_extrema

    def excursion(self):
        """
        How far each joint goes beyond the range of its waypoints: (n,), >= 0.

        A spline may overshoot between waypoints; a large excursion means an
        absurd plan (e.g. near-duplicate waypoints next to a rest end).
        """
        low, high = self.position_extrema()[:2]
        return np.maximum.reduce([high - self.waypoints.max(axis=0),
                                  self.waypoints.min(axis=0) - low,
                                  np.zeros(self.n_joints)])

    def duration_lower_bound(self):
        """
        Return a lower bound of the duration: no trajectory through the waypoints is shorter.

        Within the velocity and acceleration limits; None without limits.
        The larger of two bounds:

        * every segment at its slowest joint's top speed: sum over segments
          of max_j |dq_j| / v_j;
        * each joint at rest at both ends reaches its highest position, at
          least its highest waypoint M, and its lowest, at most its lowest
          m, at rest there (an extremum, or an end), in one order or the
          other: at least the rest-to-rest v/a times from its start q_0 to
          M, M to m and m to its end q_N, or the same through m first, the
          shorter of the two (a joint's 1-3 moves; 2 sqrt(d / a) for a
          move too short to reach v).  Short moves, whose time the
          acceleration sets, are far above the first bound (helper-74: a
          0.1 rad move took 24 times it).
        """
        if self.limits is None:
            return None
        v, a = self.limits.velocity, self.limits.acceleration
        steps = np.abs(np.diff(self.waypoints, axis=0)) / v[None, :]
        cruise = float(np.sum(np.max(steps, axis=1)))
        resting = (self.start_velocity == 0.0) & (self.end_velocity == 0.0)
        if not np.any(resting):
            return cruise
        first, last = self.waypoints[0], self.waypoints[-1]
        high, low = self.waypoints.max(axis=0), self.waypoints.min(axis=0)

        def rest_to_rest(d):
            return rest_to_rest_times(d, v, a, np.inf)  # the v/a bang-bang profile
        spread = rest_to_rest(high - low)
        high_first = rest_to_rest(high - first) + spread + rest_to_rest(last - low)
        low_first = rest_to_rest(first - low) + spread + rest_to_rest(high - last)
        joints = np.where(resting, np.minimum(high_first, low_first), 0.0)
        return max(cruise, float(np.max(joints)))

    def limit_ratios(self):
        """Peak / limit per segment, joint and quantity (S, n, 3); needs limits."""
        if self.limits is None:
            raise ValueError('this trajectory was planned without limits')
        if self._ratios is None:
            self._ratios = limit_ratios(self.coefficients, self.durations, self.limits)
        return self._ratios

    @property
    def binding(self):
        """Return the :class:`BindingLimit` with the largest peak/limit ratio, or None."""
        if self.limits is None:
            return None
        return binding_limit(self.limit_ratios())

    def segment_bindings(self):
        """Return the :class:`BindingLimit` of every segment (its largest ratio)."""
        ratios = self.limit_ratios()
        return [replace(binding_limit(ratios[s:s + 1]), segment=s)
                for s in range(ratios.shape[0])]

    def within_limits(self, rtol=1e-9):
        """Return True when every peak is within its limit (relative tolerance ``rtol``)."""
        return self.limits is None or bool(np.all(self.limit_ratios() <= 1.0 + rtol))

    def knot_jumps(self, derivative):
        """Largest |jump| of the d-th derivative across interior waypoints, per joint (n,)."""
        if self.durations.size < 2:
            return np.zeros(self.n_joints)
        c = self._derivative(derivative).c  # (order, S, n), descending powers
        ends = self.durations[:-1, None]
        left = np.zeros_like(c[0, :-1])
        for row in c[:, :-1]:
            left = left * ends + row  # Horner: segment k at its end
        right = c[-1, 1:]  # segment k + 1 at its start
        return np.max(np.abs(right - left), axis=0)


# require_finite's falling factors and exponents of position to jerk (4, 6).
_CHECK_FALLING = np.array([falling_factors(d)[0] for d in range(4)])
_CHECK_EXPONENT = np.array([falling_factors(d)[1] for d in range(4)])


def require_finite(traj):
    """
    Raise ValueError unless ``traj`` is finite: breakpoints, coefficients and values.

    Finite coefficients can still overflow when evaluated (``c5 * T**5`` with
    T = 1e62 s), so position to jerk are evaluated at every segment's middle
    and end too; and so can the derivative's own coefficients, which
    ``ppoly.derivative`` (``evaluate``, ``sample``) builds first (``60 c5``
    with T = 1e-61 s: an infinite jerk and NaN at the knots), so those are
    checked as well.
    """
    if not np.all(np.isfinite(traj.breakpoints)):
        raise ValueError('the segment durations overflow: the plan is not finite')
    ok = np.all(np.isfinite(traj.coefficients * _CHECK_FALLING.max(axis=0)[None, :, None]))
    if ok:
        # Both times and all four derivatives in one product (8 einsums
        # before: 77 -> 28 us on a 3 x 3 plan).  Its summation order may
        # differ from theirs, which can only matter within an ulp of overflow.
        tau = np.stack([0.5 * traj.durations, traj.durations])
        weights = _CHECK_FALLING * tau[:, :, None, None] ** _CHECK_EXPONENT
        ok = np.all(np.isfinite(np.einsum('hsdi,sin->hsdn', weights, traj.coefficients)))
    if not ok:
        raise ValueError('the plan is not finite (the limits, durations or waypoints are too '
                         'extreme for floating point)')
