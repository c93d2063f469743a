"""residual_vibration: the ringing after a stop, against closed forms and an oscillator's."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.signal import lsim
from splines445_ros.planning import plan
from splines445_ros.planning.speed_profile.residual_vibration import (
    DAMPING, residual_shares, trajectory_residual)


@pytest.mark.parametrize('width', [0.05, 0.125, 0.2, 0.25, 0.4])
def test_an_acceleration_pulse_rings_as_the_closed_form_says(width):
    """A pulse of a for ``width`` s, no damping: amplitude 2 a |sin(w width / 2)| / w**2."""
    frequency, a = 4.0, 3.0
    w = 2.0 * np.pi * frequency
    t = np.linspace(0.0, 1.0, 200001)
    qdd = np.where(t < width, a, 0.0)[:, None]
    share = residual_shares(t, qdd, frequency, [a], damping=0.0)
    assert share[0] == pytest.approx(2.0 * abs(np.sin(0.5 * w * width)), abs=2e-3)


def test_shares_match_a_damped_oscillator_after_the_stop():
    """Random smooth accelerations of 3 joints: the share is the swing after the end."""
    rng = np.random.default_rng(7)
    frequency, damping = 5.0, 0.03
    w = 2.0 * np.pi * frequency
    t = np.linspace(0.0, 3.0, 30001)
    a = rng.uniform(1.0, 4.0, 3)
    qdd = np.stack([np.sin(rng.uniform(1, 9) * t + rng.uniform(0, 6)) * np.sin(np.pi * t / 3)
                    * a[k] for k in range(3)], axis=1)
    shares = residual_shares(t, qdd, frequency, a, damping=damping)
    # The test's own oscillator, run on for one period after the stop.
    after = np.linspace(3.0, 3.0 + 1.0 / frequency, 2001)[1:]
    tt = np.concatenate([t, after])
    for k in range(3):
        drive = np.concatenate([qdd[:, k], np.zeros(after.size)])
        _, y, _ = lsim(([-1.0], [1.0, 2.0 * damping * w, w * w]), drive, tt)
        swing = np.max(np.abs(y[t.size:])) * w * w / a[k]
        # The amplitude decays by exp(-zeta w / f) = 0.83 over that period at most.
        assert 0.8 * shares[k] <= swing <= 1.001 * shares[k] + 1e-6


@pytest.mark.parametrize('frequency, move', [(44.7, 1.45e-7), (10.0, 1e-6), (20.0, 3e-7)])
def test_a_plan_of_a_millisecond_reports_its_ringing(frequency, move):
    """Sampled at its ends and middle, where it does not accelerate, it reported none."""
    traj = plan(np.array([[0.0], [move]]), '555', 'optimal', speed_profile='time_optimal',
                max_velocity=[0.19], max_acceleration=[0.589],
                vibration_frequency=frequency, waypoint_tolerance=0.0)
    assert traj.duration < 0.005
    # The test's own oscillator, integrated over the plan; then its free ringing's amplitude.
    w, damping = 2.0 * np.pi * frequency, DAMPING
    damped = w * np.sqrt(1.0 - damping**2)

    def motion(t, state):
        return [state[1], -traj.evaluate(np.array([t]), 2)[0, 0] - 2.0 * damping * w * state[1]
                - w * w * state[0]]

    end = solve_ivp(motion, (0.0, traj.duration), [0.0, 0.0], rtol=1e-10, atol=1e-20,
                    max_step=traj.duration / 2000).y[:, -1]
    amplitude = np.hypot(end[0], (end[1] + damping * w * end[0]) / damped)
    swing = amplitude * w * w / traj.limits.acceleration[0]
    reported = trajectory_residual(traj, frequency, traj.limits.acceleration)
    assert swing == pytest.approx(reported, rel=0.05)
