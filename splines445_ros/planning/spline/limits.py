"""Per-joint velocity, acceleration and jerk limits and what binds against them."""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .peaks import segment_peaks_of
from ..validation import positive_array

QUANTITIES = ('velocity', 'acceleration', 'jerk')


@dataclass(frozen=True)
class JointLimits:
    """Limits per joint; ``jerk`` entries may be +inf (no jerk limit on that joint)."""

    velocity: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray

    @classmethod
    def from_user(cls, n_joints, max_velocity, max_acceleration, max_jerk=None):
        """Validate user limits; jerk is optional (None = unlimited)."""
        velocity = positive_array('max_velocity', max_velocity, n_joints)
        acceleration = positive_array('max_acceleration', max_acceleration, n_joints)
        if max_jerk is None:
            jerk = np.full(n_joints, np.inf)
        else:
            jerk = positive_array('max_jerk', max_jerk, n_joints, allow_inf=True)
        return cls(velocity, acceleration, jerk)

    def as_array(self):
        """Limits stacked as (3, n): velocity, acceleration, jerk."""
        return np.stack([self.velocity, self.acceleration, self.jerk])

    @cached_property
    def bounds(self):
        """
        :meth:`as_array`, stacked once and read-only.

        The peak ratios of every spline read it: a 3 x 3 request stacked it
        about 14 times (5 us each).
        """
        bounds = self.as_array()
        bounds.flags.writeable = False
        return bounds


@dataclass(frozen=True)
class BindingLimit:
    """The limit closest to (or furthest past) its bound: ratio = peak / limit."""

    joint: int
    quantity: str
    segment: int
    ratio: float


def limit_ratios(coeffs, durations, limits, velocity=True, peaks_of=segment_peaks_of):
    """
    Peak / limit for every segment, joint and quantity: shape (S, n, 3).

    ``velocity`` False leaves the velocity ratios at 0 (a caller that bounds
    them otherwise: :func:`inner_knots.exact_factors`).  ``peaks_of``
    :func:`peaks.sampled_segment_peaks_of` gives lower bounds of the ratios
    without root finding (:func:`timing.rest_to_rest_lower_bound`).
    """
    bounds = limits.bounds
    ratios = np.zeros(np.shape(coeffs)[:1] + (bounds.shape[1], 3))
    derivatives = (1, 2, 3) if velocity else (2, 3)
    if np.isinf(bounds[2]).all():
        derivatives = derivatives[:-1]
    # All peaks in one pass: segment_peaks_of gives segment_peaks' values.
    for peaks, derivative in zip(peaks_of(coeffs, durations, derivatives), derivatives):
        ratios[..., derivative - 1] = peaks / bounds[derivative - 1][None, :]
    return ratios


def binding_limit(ratios):
    """Return the :class:`BindingLimit` with the largest ratio in (S, n, 3) ``ratios``."""
    segment, joint, q = np.unravel_index(int(np.argmax(ratios)), ratios.shape)
    return BindingLimit(int(joint), QUANTITIES[q], int(segment), float(ratios[segment, joint, q]))


def rest_to_rest_times(distance, v, a, j):
    """
    Time of the fastest rest-to-rest move over ``distance`` (>= 0), arrays that broadcast.

    Under the limits ``v``, ``a`` and ``j`` (jerk may be inf): the classic
    jerk-limited profile (jerk ramps of ``a / j``, constant acceleration,
    cruise); with no jerk limit the v/a one, ``2 sqrt(d / a)`` short of
    ``v``, else ``d / v + v / a``; 0 for no move.
    """
    d = distance
    ramp = a / j  # 0 without a jerk limit

    def accelerate(peak):
        # Time to reach the speed ``peak`` from rest (a full acceleration
        # phase once peak >= a^2 / j; always without a jerk limit).
        full = peak * j >= a * a
        return np.where(full, peak / a + ramp, 2.0 * np.sqrt(peak / j))

    with np.errstate(invalid='ignore', divide='ignore', over='ignore'):
        time_to_v = accelerate(v)
        cruising = d >= v * time_to_v
        # Peak speed below v: with a full acceleration phase it solves
        # peak^2 / a + peak * ramp = d, otherwise peak^1.5 * 2 / sqrt(j) = d.
        peak_full = 0.5 * (-a * ramp + np.sqrt((a * ramp) ** 2 + 4.0 * a * d))
        peak_short = np.cbrt((0.5 * d * np.sqrt(j)) ** 2)
        peak = np.where(peak_full * j >= a * a, peak_full, peak_short)
        times = np.where(cruising, time_to_v + d / v, 2.0 * accelerate(peak))
    return np.where(d > 0.0, times, 0.0)


def check_boundary_feasible(limits, start_velocity, start_acceleration,
                            end_velocity, end_acceleration, joint_names=None):
    """
    Raise ValueError when a boundary value is above its joint's limit (infeasible).

    The error names the joint by its index, and by its name from
    ``joint_names`` when given (as ``planner.joint_label`` does).
    """
    for name, value, bound in (
            ('start_velocity', start_velocity, limits.velocity),
            ('start_acceleration', start_acceleration, limits.acceleration),
            ('end_velocity', end_velocity, limits.velocity),
            ('end_acceleration', end_acceleration, limits.acceleration)):
        over = np.abs(value) > bound
        if np.any(over):
            i = int(np.argwhere(over)[0][0])
            label = f'joint {i}' if joint_names is None else f'joint {i} ({joint_names[i]})'
            raise ValueError(f'infeasible: |{name}[{i}]| = {abs(value[i])} exceeds the '
                             f'limit {bound[i]} of {label}')
