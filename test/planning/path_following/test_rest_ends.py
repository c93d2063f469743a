"""
A knots-only plan turned at its rest ends (``rest_ends.along_chords``): properties.

Checked on the trajectories alone, against scipy's PPoly of the result and
of the knots-only plan it starts from: the waypoints at their times, C4 at
every knot, the rest ends, the end jerks' signs, the v/a/j limits, and for
a joint that already starts and stops along its chords, the very plan it
was, slowed down.
"""

from example_counts import examples
from hypothesis import assume, given, settings, strategies as st
import numpy as np
from splines445_ros.planning import plan
from splines445_ros.planning.path_following.rest_ends import along_chords


@st.composite
def knots_only_plans(draw):
    """Knots-only 555 optimal plans rest to rest: 2-8 waypoints, 1-5 joints, v/a/j limits."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n_points, n_joints = draw(st.integers(2, 8)), draw(st.integers(1, 5))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (n_points, n_joints)), axis=0)
    assume(np.all(np.linalg.norm(np.diff(points, axis=0), axis=1) > 0.05))
    amax = rng.uniform(2.0, 10.0, n_joints)
    return plan(points, '555', 'optimal', inner_knots=0, max_velocity=rng.uniform(
        0.5, 3.0, n_joints), max_acceleration=amax, max_jerk=rng.uniform(5.0, 30.0) * amax)


def end_jerks(traj):
    """(2, n): the jerk at the start and at the end, from scipy's PPoly."""
    return traj.ppoly(np.array([0.0, traj.duration]), 3)


def chord_signs(traj):
    """(2, n): the direction of each joint's first and last chord."""
    points = traj.waypoints
    return np.sign(np.stack([points[1] - points[0], points[-1] - points[-2]]))


@settings(max_examples=examples(30), deadline=None)
@given(knots_only_plans())
def test_the_first_turn_zeroes_the_jerks_against_the_chords_and_keeps_the_rest(free):
    turned = along_chords(free, lambda t: True)
    assume(turned is not None)
    # Two knots more, one inside the first segment and one inside the last.
    assert turned.breakpoints.size == free.breakpoints.size + 2
    inner = np.setdiff1d(turned.breakpoints, turned.waypoint_times)
    assert inner.size == 2
    assert turned.waypoint_times[0] < inner[0] < turned.waypoint_times[1]
    assert turned.waypoint_times[-2] < inner[1] < turned.waypoint_times[-1]
    # Every waypoint at its time, rest at both ends, within the limits.
    np.testing.assert_allclose(turned.ppoly(turned.waypoint_times), free.waypoints, atol=1e-9)
    ends = np.array([0.0, turned.duration])
    for d in (1, 2):
        np.testing.assert_allclose(turned.ppoly(ends, d), 0.0, atol=1e-9)
    assert turned.within_limits(rtol=1e-9)
    # C4 at every knot: the jumps of velocity to snap are round-off.
    knots = turned.breakpoints[1:-1]
    step = 1e-9 * turned.duration
    for d in range(1, 5):
        scale = np.max(np.abs(turned.ppoly(np.linspace(0.0, turned.duration, 2001), d)))
        jump = turned.ppoly(knots + step, d) - turned.ppoly(knots - step, d)
        assert np.max(np.abs(jump)) <= 1e-5 * scale + 1e-9, d
    # A jerk against its chord is now 0; one along it keeps its sign.
    before, after, sign = end_jerks(free), end_jerks(turned), chord_signs(free)
    tiny = 1e-7 * (np.max(np.abs(before)) + 1.0)
    against = before * sign < -tiny
    assert np.all(np.abs(after[against]) <= 1e-6 * (np.max(np.abs(after)) + 1.0))
    along = before * sign > tiny
    assert np.all(after[along] * sign[along] > 0.0)
    # A joint along both chords is the plan it was, slowed down uniformly.
    kept = ~np.any(before * sign < 0.0, axis=0)
    factor = turned.duration / free.duration
    assert factor >= 1.0 - 1e-9
    times = np.linspace(0.0, free.duration, 501)
    np.testing.assert_allclose(turned.ppoly(times * factor)[:, kept], free.ppoly(times)[:, kept],
                               atol=1e-7 * (1.0 + np.max(np.abs(free.waypoints))))


@settings(max_examples=examples(20), deadline=None)
@given(knots_only_plans())
def test_the_first_accepted_turn_is_returned_and_none_when_none_is(free):
    assert along_chords(free, lambda t: False) is None
    tried = []
    turned = along_chords(free, lambda t: tried.append(t) or len(tried) == 2)
    assume(turned is not None)
    assert turned is tried[-1]
    # The first turn, turned down here, is the one an accept-all returns.
    first = along_chords(free, lambda t: True)
    np.testing.assert_array_equal(first.ppoly.c, tried[0].ppoly.c)
    # The second turn pushes every end jerk along its chord, none against it.
    sign = chord_signs(free)
    jerks = end_jerks(turned)
    assert np.all(jerks * sign >= -1e-9 * np.max(np.abs(jerks)))
    assert np.all(jerks[sign != 0.0] * sign[sign != 0.0] > 0.0)
