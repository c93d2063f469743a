"""
Where the inner knots go and what each piece needs (steps 3 and 5 of :mod:`inner_knots`).

Every segment between waypoints is cut into pieces at equal time fractions,
as many as the segment's length allows (a piece lasts a few jerk ramp
times); a piece's exact factor is the uniform slow-down its own peaks ask
for (the ratios of :mod:`peaks`, ``max(r_v, r_a**(1/2), r_j**(1/3))``).
"""

import numpy as np

from ..speed_profile.path_velocity import joint_acceleration_peaks
from ..spline.limits import limit_ratios
from ..spline.peaks import row_max, velocity_ratios_above

# Each constant with its reason in one line; the measurements behind them are
# in doc/inner_knots.md ("Where the constants come from").
# A piece lasts at least this many jerk ramp times a / j (step 3).
RAMP_PIECES = 1.5
# From this many pieces times joints on, exact_factors skips the velocity
# peaks that cannot decide a piece's factor (below, the bound costs more than
# it saves).
PRUNE_ROWS = 512


def knots_per_segment(segment_times, limits, most, min_piece=0.0, ramp_pieces=RAMP_PIECES,
                      acceleration=None):
    """
    Inner knots of every segment (S,): ``most``, fewer where pieces would be short (step 3).

    A segment of duration ``T`` gets at most ``T / piece - 1`` inner knots
    and at least one, ``piece`` the larger of ``min_piece`` and
    ``ramp_pieces`` times the longest jerk ramp ``a_j / j_j`` of the joints
    (0 without jerk limits; then ``most`` when ``min_piece`` is 0 too).
    ``acceleration`` (n,) replaces the limits' in that ramp: the joints'
    accelerations when the torque limits them
    (:func:`ramp_accelerations`).
    """
    piece = shortest_piece(limits, min_piece, ramp_pieces, acceleration)
    counts = np.full(segment_times.size, most)
    if piece > 0.0:
        fit = np.floor(segment_times / piece) - 1
        # np.clip(np.nan_to_num(fit, nan=1.0), 1, most)'s values (infinities
        # clip to the same ends) in a quarter of its time.
        fit = np.where(np.isnan(fit), 1.0, fit)
        counts = np.minimum(np.maximum(fit, 1), most).astype(int)
    return counts


def shortest_piece(limits, min_piece=0.0, ramp_pieces=RAMP_PIECES, acceleration=None):
    """
    Return step 3's shortest piece [s]: ``min_piece`` or ``ramp_pieces`` longest jerk ramps.

    The jerk ramp of a joint is ``a_j / j_j`` (0 without a jerk limit);
    ``acceleration`` (n,) replaces the limits' (:func:`ramp_accelerations`).
    """
    if acceleration is None:
        acceleration = limits.acceleration
    return max(ramp_pieces * float(np.max(acceleration / limits.jerk)), min_piece)


def equal_fractions(counts):
    """Return per segment the time fractions of its waypoint and ``counts`` inner knots."""
    return [np.arange(c + 1) / (c + 1) for c in counts]


def knot_times(passed, fractions):
    """Return the knot times: per segment its ``fractions`` of the way between ``passed``."""
    return np.concatenate([passed[k] + f * (passed[k + 1] - passed[k])
                           for k, f in enumerate(fractions)] + [passed[-1:]])


def equal_knot_times(passed, counts):
    """
    Return :func:`knot_times` of :func:`equal_fractions` ``(counts)``: the same values.

    Every knot at once, segment ``k``'s ``j``-th at ``passed[k] + j / (c + 1)
    * (passed[k + 1] - passed[k])`` as there: a few numpy calls for any
    number of segments, where the lists cost a few a segment.
    """
    per = counts + 1
    segment = np.repeat(np.arange(per.size), per)
    j = np.arange(segment.size) - np.repeat(np.cumsum(per) - per, per)
    start = passed[segment]
    return np.concatenate([start + j / per[segment] * (passed[segment + 1] - start),
                           passed[-1:]])


def exact_factors(coeffs, pieces, limits):
    """
    Exact restoring factor per piece (P,): ``max(r_v, r_a**(1/2), r_j**(1/3))``, worst joint.

    The ratios are exact peaks from the polynomials, as in
    :func:`limits.limit_ratios`; a rest-to-rest spline whose durations are
    all multiplied by ``f`` has ratios ``r_v / f``, ``r_a / f**2``,
    ``r_j / f**3``.  Steps 5-7 use only the largest factor of a piece, so
    the peaks are found in fewer passes: all of them in one
    (:func:`peaks.segment_peaks_of`) for fewer than :data:`PRUNE_ROWS`
    pieces times joints; above, the acceleration and jerk peaks in one and
    the velocity peaks, which need the roots of a cubic, only where a bound
    shows that they can be the piece's largest
    (:func:`peaks.velocity_ratios_above`: about 1 in 10 on long random
    paths).  The factors are those of :func:`limits.limit_ratios`' ratios,
    bit for bit.  Also returns the exact ratios (P, n, 3) when it has all of
    them (below :data:`PRUNE_ROWS`), or None.
    """
    bounds = limits.bounds
    prune = np.shape(coeffs)[0] * bounds.shape[1] >= PRUNE_ROWS
    ratios = limit_ratios(coeffs, pieces, limits, velocity=not prune)
    powered = ratios ** (1.0 / np.arange(1, 4))[None, None, :]
    # Maxima over short axes, element-wise (numpy's reductions over them are slow).
    factors = np.maximum(np.maximum(powered[..., 0], powered[..., 1]), powered[..., 2])
    if prune:
        velocity = velocity_ratios_above(coeffs, pieces, bounds[0], row_max(factors))
        factors = np.maximum(factors, velocity)
        return row_max(factors), None
    return row_max(factors), ratios


def ramp_accelerations(path_limits, gridded, limits, torque_limited):
    """
    Return the accelerations (n,) of step 3's jerk ramp, or None for the limits' own.

    With torque limits the acceleration limits are a stand-in (a URDF has
    none; the node puts 1000 rad/s^2) and the torque sets the accelerations:
    then each joint's largest acceleration on the fastest profile
    (:func:`path_velocity.joint_acceleration_peaks`), at most its limit.
    With the stand-in's a / j the pieces had to last seconds, and a segment
    got one inner knot.
    """
    if not torque_limited:
        return None
    x = path_limits.profile(np.ones(gridded.s.size))
    return np.minimum(limits.acceleration, joint_acceleration_peaks(gridded, x))
