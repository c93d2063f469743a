"""
Two-segment optimal timing by batched search (ratio_search): against a dense search of our own.

The restored total of a rest-to-rest request, ``sum(T) * max (peak / limit)
** (1 / q)``, is computed here from the dense global system of every joint
and numpy's polynomial roots (reference_spline), on a grid of duration
ratios; the planned optimum must be feasible and not longer than the best
of that grid, and the search may give up only on a total it cannot beat.
"""

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest
from reference_spline import exact_peaks, global_coefficients
from scipy.interpolate import PPoly
from splines445_ros.planning import plan
from splines445_ros.planning.durations.ratio_search import GIVE_UP_DIP, RatioSearch
from splines445_ros.planning.path_following.inner_knots import plan_with_inner_knots
from splines445_ros.planning.plan_options import DEFAULT_INNER_KNOTS
from splines445_ros.planning.spline.limits import JointLimits


def request(seed):
    """Return a random 3-waypoint request: points, v, a, j (or None); a fifth near-duplicate."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 5))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (3, n)), axis=0)
    if rng.random() < 0.2:
        # Near, but 10-100 times the merging tolerance away (a nearer one is merged).
        step = rng.uniform(-1.0, 1.0, n)
        points[2] = points[1] + step / np.max(np.abs(step)) * 10.0 ** rng.uniform(-2.0, -1.0)
    vmax, amax = rng.uniform(0.5, 3.0, n), rng.uniform(1.0, 20.0, n)
    jmax = rng.uniform(5.0, 100.0, n) * amax if rng.random() < 0.7 else None
    return points, vmax, amax, jmax


def reference_total(method, points, durations, vmax, amax, jmax):
    """Return the restored total of ``durations`` from the dense global system, numpy roots."""
    coeffs = np.stack([global_coefficients(method, points[:, j], durations, 0.0, 0.0, 0.0, 0.0)
                       for j in range(points.shape[1])],
                      axis=-1)                                  # (S, 6, n) ascending
    ppoly = PPoly(coeffs[:, ::-1].transpose(1, 0, 2),
                  np.concatenate([[0.0], np.cumsum(durations)]))
    factor = 0.0
    for q, limit in enumerate((vmax, amax, jmax)):
        if limit is not None:
            ratio = exact_peaks(ppoly, q + 1).max(axis=0) / limit
            factor = max(factor, float(np.max(ratio)) ** (1.0 / (q + 1)))
    return float(np.sum(durations)) * factor


def dense_minimum(method, points, vmax, amax, jmax):
    """Return the smallest reference total over 120 ratios, then 60 around the best."""
    chords = np.linalg.norm(np.diff(points, axis=0), axis=1)
    centre = np.log(chords[0] / chords[1])

    def totals(x):
        share = 1.0 / (1.0 + np.exp(-x))
        return [reference_total(method, points, np.array([f, 1.0 - f]), vmax, amax, jmax)
                for f in share]

    coarse = np.linspace(centre - 5.0, centre + 5.0, 120)
    values = totals(coarse)
    best = int(np.argmin(values))
    fine = np.linspace(coarse[max(best - 1, 0)], coarse[min(best + 1, coarse.size - 1)], 60)
    return min(min(values), min(totals(fine)))


@pytest.mark.parametrize('method', ['555', '445', '434'])
@settings(max_examples=examples(6))
@given(seed=st.integers(0, 2**32 - 1))
def test_RatioSearch_is_no_longer_than_a_dense_search(method, seed):
    points, vmax, amax, jmax = request(seed)
    traj = plan(points, method, 'optimal', inner_knots=0, max_velocity=vmax,
                max_acceleration=amax, max_jerk=jmax)
    for q, limit in enumerate((vmax, amax, jmax)):
        if limit is not None:
            assert np.all(exact_peaks(traj.ppoly, q + 1).max(axis=0) <= limit * (1 + 1e-9))
    np.testing.assert_allclose(traj.evaluate(traj.breakpoints), points, atol=1e-9)
    # The grid's spacing ends below 1e-4 in log(T_1 / T_2): within 1e-4 of the best.
    assert traj.duration <= dense_minimum(method, points, vmax, amax, jmax) * (1 + 1e-4)


@settings(max_examples=examples(20))
@given(seed=st.integers(0, 2**32 - 1), excess=st.floats(0.0, 0.05))
def test_the_search_gives_up_only_on_a_total_it_cannot_beat(seed, excess):
    points, vmax, amax, jmax = request(seed)
    limits = JointLimits.from_user(points.shape[1], vmax, amax, jmax)
    start = np.linalg.norm(np.diff(points, axis=0), axis=1)
    durations, log_factor = RatioSearch('555', points, start, limits).result()
    optimum = float(np.sum(durations)) * np.exp(log_factor)
    # A total above the optimum is beaten: the search runs to its end.
    search = RatioSearch('555', points, start, limits)
    assert not search.cannot_beat(optimum * (1 + excess))
    np.testing.assert_allclose(search.result()[0], durations, rtol=1e-12)
    # One below it by more than the dip allowed for is given up.
    assert RatioSearch('555', points, start, limits).cannot_beat(
        optimum / (1.0 + GIVE_UP_DIP + 0.01))


@settings(max_examples=examples(25))
@given(seed=st.integers(0, 2**32 - 1))
def test_a_two_segment_plan_is_the_shorter_of_the_construction_and_the_knots_only_optimum(seed):
    """
    The construction stops once it cannot beat the search: never where it would have won.

    Against the construction run to its end (no total to beat) and the
    knots-only optimum of plan(inner_knots=0), the same search.
    """
    points, vmax, amax, jmax = request(seed)
    kwargs = {'max_velocity': vmax, 'max_acceleration': amax, 'max_jerk': jmax}
    traj = plan(points, '555', 'optimal', **kwargs)
    knots_only = plan(points, '555', 'optimal', inner_knots=0, **kwargs)
    zero = np.zeros(points.shape[1])
    whole = plan_with_inner_knots(points, [zero] * 4,
                                  JointLimits.from_user(points.shape[1], vmax, amax, jmax),
                                  DEFAULT_INNER_KNOTS, knots_only=False)
    best = min(knots_only.duration, np.inf if whole is None else whole.duration)
    assert traj.duration <= best * (1 + 1e-9)
    assert traj.within_limits(rtol=1e-9)
