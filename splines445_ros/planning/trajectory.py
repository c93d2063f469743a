"""The planned trajectory: one scipy PPoly for all joints, plus what limits it met."""

from dataclasses import replace
from typing import NamedTuple

import numpy as np
from scipy.interpolate import PPoly

from .limits import binding_limit, limit_ratios, QUANTITIES
from .peaks import segment_peaks


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

    """

    def __init__(self, method, timing, waypoints, durations, coefficients,
                 boundary, limits=None, scale=None, dropped_waypoints=(), ratios=None):
        """
        Wrap ascending per-segment ``coefficients`` (S, 6, n) into a PPoly.

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
        self._ratios = ratios
        self._derivatives = {0: self.ppoly}
        self._segment_peaks = {}

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

    def sample(self, period):
        """
        Sample every ``period`` seconds; the last sample is exactly the last waypoint.

        A regular sample closer than ``period / 2`` to the end is dropped so
        that the final interval is never tiny.
        """
        period = float(period)
        if not np.isfinite(period) or period <= 0.0:
            raise ValueError(f'sample period must be positive and finite, got {period}')
        count = int(np.floor(self.duration / period))
        times = np.arange(count + 1) * period
        keep = times < self.duration - 0.5 * period
        keep[0] = True  # t = 0 always, even for a trajectory shorter than period / 2
        times = np.append(times[keep], self.duration)
        positions = self.evaluate(times, 0)
        velocities = self.evaluate(times, 1)
        accelerations = self.evaluate(times, 2)
        positions[-1] = self.waypoints[-1]
        velocities[-1] = self.end_velocity
        accelerations[-1] = self.end_acceleration
        return Samples(times, positions, velocities, accelerations)

    def segment_peaks(self, derivative):
        """Exact per-segment peak |derivative| (S, n); 1 = velocity, 2 = acc, 3 = jerk."""
        if derivative not in self._segment_peaks:
            self._segment_peaks[derivative] = segment_peaks(
                self.coefficients, self.durations, derivative)
        return self._segment_peaks[derivative]

    def peaks(self):
        """Return a dict quantity -> (n,) peak |value| over the whole trajectory."""
        return {name: self.segment_peaks(d + 1).max(axis=0) for d, name in enumerate(QUANTITIES)}

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
