"""SampledTrajectory.with_start_state: where and when a new trajectory takes over."""

import numpy as np
from splines445_ros.sim.playback import MAX_MAGNITUDE, SampledTrajectory


def line(first_time=1.0):
    """One point at ``first_time`` s: joint 0 at 1, joint 1 at -2 (positions only)."""
    return SampledTrajectory(np.array([first_time]), np.array([[1.0, -2.0]]), None, None)


def test_the_state_at_the_take_over_is_kept_until_then_and_goes_straight_to_the_point():
    here = np.array([0.5, 0.0])
    for at in (0.0, 0.3, 0.9):
        taken = line().with_start_state(here, np.zeros(2), np.zeros(2), at)
        for t in (0.0, at):
            np.testing.assert_array_equal(taken.state_at(t)[0], here)
        # Straight to the point, arriving at 1 s: half the way at the midpoint.
        middle = 0.5 * (at + 1.0)
        np.testing.assert_allclose(taken.state_at(middle)[0], 0.5 * (here + [1.0, -2.0]),
                                   rtol=0.0, atol=1e-12)
        np.testing.assert_allclose(taken.state_at(middle)[1], ([1.0, -2.0] - here) / (1.0 - at),
                                   rtol=1e-12)


def test_a_take_over_after_the_first_point_starts_part_way_along():
    trajectory = SampledTrajectory(np.array([0.0, 1.0]), np.array([[0.0, 0.0], [1.0, -2.0]]),
                                   None, None)
    for at in (0.0, 0.5):
        assert trajectory.with_start_state(np.ones(2), np.zeros(2), np.zeros(2),
                                           at) is trajectory
    assert line(0.5).with_start_state(np.ones(2), np.zeros(2), np.zeros(2), 0.7).times[0] == 0.5


def test_a_start_state_beyond_the_bounds_of_a_message_is_bounded_not_refused():
    """The arm's state between fuzzed points ms apart reached 1.3e6 rad/s^2 (a fresh clone)."""
    both = SampledTrajectory(np.array([1.0]), np.array([[1.0, -2.0]]), np.zeros((1, 2)),
                             np.zeros((1, 2)))
    taken = both.with_start_state(np.zeros(2), np.array([3e6, 0.0]), np.array([0.0, -2e6]),
                                  0.5)
    assert taken.times[0] == 0.5
    np.testing.assert_array_equal(taken.velocities[0], [MAX_MAGNITUDE, 0.0])
    np.testing.assert_array_equal(taken.accelerations[0], [0.0, -MAX_MAGNITUDE])
