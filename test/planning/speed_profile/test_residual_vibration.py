"""residual_vibration: the ringing after a stop, against closed forms and an oscillator's."""

import numpy as np
import pytest
from scipy.signal import lsim
from splines445_ros.planning.speed_profile.residual_vibration import residual_shares


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
