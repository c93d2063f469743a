"""
How much a trajectory shakes a flexible arm: a lightly damped oscillator on every joint.

Each joint carries a mass-spring-damper of natural frequency ``f`` and
damping ratio :data:`ZETA` (a structural mode: a link, a gearbox, a tool
on a spring), base-excited by the joint's acceleration ``qdd(t)``::

    x'' + 2 zeta w x' + w**2 x = -qdd(t),      w = 2 pi f

``x`` is the mode's deflection.  Two figures per joint, in units of the
static deflection at the joint's acceleration limit ``a / w**2`` (so
joints and requests of every size compare, and a trajectory that never
accelerates more than ``a`` and never rings reaches at most 1):

* peak: the largest ``|x|`` while the trajectory moves;
* residual: the largest ``|x|`` over the :data:`RESIDUAL_PERIODS` periods
  after the end, where the trajectory is at rest and the mode rings freely.

The largest over the joints is the trajectory's figure.  The response is
exact for an input that is constant over each sample (zero-order hold),
sampled at :data:`RATE`; trajectories are compared at the same rate.
"""

import numpy as np
from scipy.signal import cont2discrete, lfilter

ZETA = 0.02
RATE = 1000.0
RESIDUAL_PERIODS = 2.0
FREQUENCIES = (4.0, 8.0)


def oscillator(acceleration, frequency, zeta=ZETA, rate=RATE):
    """Return the deflection (T, n) driven by ``acceleration`` (T, n) sampled at ``rate``."""
    w = 2.0 * np.pi * frequency
    num, den, _ = cont2discrete(([-1.0], [1.0, 2.0 * zeta * w, w * w]), 1.0 / rate,
                                method='zoh')
    return lfilter(np.ravel(num), den, acceleration, axis=0)


def shaking(acceleration_of, duration, max_acceleration, frequency, rate=RATE, zeta=ZETA):
    """
    Return (peak, residual) of one trajectory at one ``frequency`` (module docstring).

    ``acceleration_of(t)`` gives the joint accelerations (T, n) at the times
    ``t``; ``duration`` is the trajectory's; ``max_acceleration`` (n,) the
    limits; ``zeta`` the mode's damping ratio.
    """
    moving = np.arange(0.0, duration, 1.0 / rate)
    after = int(np.ceil(RESIDUAL_PERIODS * rate / frequency))
    acc = np.vstack([acceleration_of(moving), np.zeros((after, len(max_acceleration)))])
    x = np.abs(oscillator(acc, frequency, zeta, rate))
    static = np.asarray(max_acceleration, float) / (2.0 * np.pi * frequency) ** 2
    peak = np.max(x[:moving.size] / static)
    residual = np.max(x[moving.size:] / static)
    return float(peak), float(residual)


def shaking_figures(acceleration_of, duration, max_acceleration, frequencies=FREQUENCIES):
    """``{f: (peak, residual)}`` for every frequency."""
    return {f: shaking(acceleration_of, duration, max_acceleration, f) for f in frequencies}


def shaking_ratios(traj, reference, max_acceleration):
    """
    Return [4 Hz peak, 4 Hz residual, 8 Hz peak, 8 Hz residual] of ``traj`` / ``reference``'s.

    ``traj`` is a splines445 Trajectory, ``reference`` the
    :func:`shaking_figures` of the rival (TOPP-RA) on the same request.
    """
    ours = shaking_figures(of_trajectory(traj), traj.duration, max_acceleration)
    return [ours[f][k] / reference[f][k] for f in FREQUENCIES for k in (0, 1)]


def shaking_header():
    """Return the column names of :func:`shaking_ratios`, as a Markdown row's middle."""
    return ' | '.join(f'{f:g} Hz {kind}' for f in FREQUENCIES for kind in ('peak', 'residual'))


def of_trajectory(traj):
    """``acceleration_of`` for a splines445 Trajectory."""
    return lambda t: traj.evaluate(np.minimum(t, traj.duration), 2)


def of_toppra(trajectory):
    """``acceleration_of`` for a toppra trajectory."""
    return lambda t: trajectory.evaldd(np.minimum(t, trajectory.duration))
