"""
Pruned velocity peaks decide what the full computation decides, bit for bit.

``peaks.velocity_ratios_above`` skips the root finding of a segment's
velocity peak where a bound shows that it cannot exceed a floor, and
``knot_pieces.exact_factors`` uses it from :data:`knot_pieces.PRUNE_ROWS`
pieces times joints on.  Both promise the values of the full computation
(every velocity peak, ``limits.limit_ratios``); here that is checked on
random 555 splines, with floors and limits drawn so that velocity, and
acceleration or jerk, each decide some segments, and the full values
against numpy.roots (``exact_peaks``).
"""

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from reference_spline import exact_peaks
from splines445_ros.planning import JointLimits, plan
from splines445_ros.planning.path_following.knot_pieces import exact_factors, PRUNE_ROWS
from splines445_ros.planning.spline.limits import limit_ratios
from splines445_ros.planning.spline.peaks import segment_peaks, velocity_ratios_above


def random_555(rng, n_segments, n_joints):
    """Return a fixed-timing 555 spline through a random walk, with random boundary values."""
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_segments + 1, n_joints)), axis=0)
    v0, a0, ve, ae = (rng.uniform(-1.0, 1.0, n_joints) for _ in range(4))
    return plan(points, '555', 'fixed', durations=rng.uniform(0.05, 2.0, n_segments),
                start_velocity=v0, start_acceleration=a0, end_velocity=ve, end_acceleration=ae)


@settings(max_examples=examples(60))
@given(seed=st.integers(0, 2**32 - 1), n_segments=st.integers(1, 12),
       n_joints=st.integers(1, 4))
def test_velocity_ratios_above_a_floor_give_each_segments_largest_exactly(seed, n_segments,
                                                                          n_joints):
    rng = np.random.default_rng(seed)
    traj = random_555(rng, n_segments, n_joints)
    coeffs, durations = traj.coefficients, traj.durations
    bounds = rng.uniform(0.5, 3.0, n_joints)
    full = segment_peaks(coeffs, durations, 1) / bounds[None, :]
    # The full peaks are the exact ones (numpy.roots on every segment).
    np.testing.assert_allclose(full, exact_peaks(traj.ppoly, 1) / bounds[None, :], rtol=1e-9)
    # Floors around each segment's largest velocity ratio: some above it
    # (pruned), some below it (the peak decides), some exactly on it.
    largest = full.max(axis=1)
    floor = largest * rng.uniform(0.6, 1.4, n_segments)
    on = rng.random(n_segments) < 0.2
    floor[on] = largest[on]
    got = velocity_ratios_above(coeffs, durations, bounds, floor)
    assert got.shape == full.shape
    assert np.all(got <= full)  # values of the velocity: never above its peak
    np.testing.assert_array_equal(np.maximum(got, floor[:, None]).max(axis=1),
                                  np.maximum(full, floor[:, None]).max(axis=1))


def factors_of(ratios):
    """Largest ``max(r_v, r_a**(1/2), r_j**(1/3))`` of every segment from (S, n, 3) ratios."""
    powered = ratios ** (1.0 / np.arange(1, 4))[None, None, :]
    return powered.reshape(powered.shape[0], -1).max(axis=1)


@pytest.mark.parametrize('rows', ['below PRUNE_ROWS', 'above PRUNE_ROWS'])
@settings(max_examples=examples(8))
@given(seed=st.integers(0, 2**32 - 1), n_joints=st.integers(1, 4), jerk=st.booleans())
def test_exact_factors_are_those_of_the_limit_ratios(rows, seed, n_joints, jerk):
    rng = np.random.default_rng(seed)
    least = -(-PRUNE_ROWS // n_joints)  # the fewest segments that are pruned
    n_segments = (int(rng.integers(1, min(least, 40))) if rows.startswith('below')
                  else least + int(rng.integers(0, 20)))
    traj = random_555(rng, n_segments, n_joints)
    coeffs, durations = traj.coefficients, traj.durations
    # Limits on the scale of the spline's own peaks, so that velocity and
    # acceleration (or jerk) each give the largest factor of some segments.
    peaks = [exact_peaks(traj.ppoly, d).max(axis=0) for d in (1, 2, 3)]
    velocity = peaks[0] * rng.uniform(0.5, 1.5, n_joints)
    acceleration = peaks[1] * rng.uniform(0.5, 1.5, n_joints) ** 2
    jerk_limit = peaks[2] * rng.uniform(0.5, 1.5, n_joints) ** 3 if jerk else None
    limits = JointLimits.from_user(n_joints, velocity, acceleration, jerk_limit)
    ratios = limit_ratios(coeffs, durations, limits)
    expected = factors_of(ratios)
    factors, full = exact_factors(coeffs, durations, limits)
    np.testing.assert_array_equal(factors, expected)
    if rows.startswith('below'):
        np.testing.assert_array_equal(full, ratios)
    else:
        assert full is None
    # And the limit ratios are the exact peaks over the limits (numpy.roots).
    bounds = [velocity, acceleration, jerk_limit]
    independent = np.stack([exact_peaks(traj.ppoly, d) / bounds[d - 1] if bounds[d - 1]
                            is not None else np.zeros((n_segments, n_joints))
                            for d in (1, 2, 3)], axis=-1)
    np.testing.assert_allclose(ratios, independent, rtol=1e-9, atol=1e-12)
