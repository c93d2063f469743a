"""
The residual vibration of a lightly damped mode after a stop (issue 38, ``vibration_frequency``).

A structural mode of frequency ``f`` and damping ratio ``zeta`` on a joint
(a link, a gearbox, a tool on a spring), base-excited by the joint's
acceleration ``qdd(t)``::

    y'' + 2 zeta w y' + w**2 y = -qdd(t),      w = 2 pi f,  wd = w sqrt(1 - zeta**2)

rings freely once the motion stops at ``T``.  With the impulse response
``h(t) = exp(-zeta w t) sin(wd t) / wd``, the state at ``T`` is one complex
number, the mode's content of the acceleration::

    Z = int_0^T qdd(t) exp(lambda (T - t)) dt,      lambda = -zeta w + i wd

``y(T) = -Im Z / wd`` and ``y'(T) + zeta w y(T) = -Re Z``, so the ringing
after the stop has the amplitude ``|Z| / wd``.  Over the static deflection
at the joint's acceleration limit ``a / w**2`` (what a trajectory that
never accelerates more than ``a`` and never rings reaches) that is the
*residual share* ``|Z| w**2 / (wd a)``.  A time-optimal profile stops with
jerk ramps far shorter than a period and leaves a share of about 0.5-1.5
at 4 Hz; TOPP-RA's bang-bang stop about 1-1.5.

``Z`` is linear in ``qdd``: :class:`~smooth_profile.SmoothProfile` bounds
it with linear rows (the phases from its last profile), which is input
shaping done by the profile itself.  It cancels the ringing of the mode
it is given; as every cancellation, it is narrow: a mode 10 % off in
frequency is left 0.4-0.8 of TOPP-RA's ringing, one with a damping of
0.01 or 0.05 instead of :data:`DAMPING` is left 0.13-0.25
(``benchmarks/bench_vibration_residual.py``, doc/inner_knots.md).  The
mode is taken at rest when the plan starts: replanning from a moving
state does not know what the motion before left ringing.
"""

import numpy as np

# The mode's damping ratio assumed by the cancellation (the user gives only
# its frequency): a lightly damped structural mode, 1-5 % in arms' links
# and gearboxes; the benchmarks' oscillator uses the same.
DAMPING = 0.02


def mode_exponent(frequency, damping=DAMPING):
    """Return ``lambda = -zeta w + i wd`` and ``wd`` [rad/s] of the mode at ``frequency`` [Hz]."""
    w = 2.0 * np.pi * frequency
    damped = w * np.sqrt(1.0 - damping * damping)
    return complex(-damping * w, damped), damped


def static_scale(frequency, max_acceleration, damping=DAMPING):
    """Return (n,) the factor from ``|Z|`` to the residual share, ``w**2 / (wd a)``, per joint."""
    w = 2.0 * np.pi * frequency
    _, damped = mode_exponent(frequency, damping)
    return w * w / (damped * np.asarray(max_acceleration, float))


def content_weights(steps, frequency, damping=DAMPING):
    """
    Return (len(steps) + 1,) the weights of ``Z = sum_k w_k qdd_k`` on samples ``steps`` apart.

    The trapezoid rule's weight of each sample times its phase
    ``exp(lambda (T - t_k))``, ``t`` from 0 to the stop ``T`` (the last).
    """
    steps = np.asarray(steps, float)
    exponent, _ = mode_exponent(frequency, damping)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    weight = np.zeros(t.size)
    weight[:-1] += 0.5 * steps
    weight[1:] += 0.5 * steps
    return weight * np.exp(exponent * (t[-1] - t))


def residual_shares(times, accelerations, frequency, max_acceleration, damping=DAMPING):
    """
    Return (n,) each joint's residual share after a motion sampled at ``times``.

    ``times`` (T,) increasing from the start to the stop (the last one),
    ``accelerations`` (T, n) the joints' accelerations there (trapezoid
    rule: sample a plan's polynomials at 1 ms or finer).
    """
    t = np.asarray(times, float)
    qdd = np.asarray(accelerations, float).reshape(t.size, -1)
    content = content_weights(np.diff(t), frequency, damping) @ qdd
    return np.abs(content) * static_scale(frequency, max_acceleration, damping)


# Samples a period of the mode at least, in trajectory_residual (and 1 ms apart at most),
# and samples at most (a mode of 1 kHz on a plan of 50 s; more: no figure).
SAMPLES_PER_PERIOD = 20
MAX_SAMPLES = 1000000


def trajectory_residual(traj, frequency, max_acceleration, period=1e-3, damping=DAMPING):
    """Return the largest residual share over the joints of a plan (None: too many samples)."""
    period = min(period, 1.0 / (SAMPLES_PER_PERIOD * frequency))
    steps = max(2, int(np.ceil(traj.duration / period)))
    if steps > MAX_SAMPLES:
        return None
    t = np.linspace(0.0, traj.duration, steps + 1)
    return float(np.max(residual_shares(t, traj.evaluate(t, 2), frequency, max_acceleration,
                                        damping)))


def report_residual(traj, frequency):
    """
    Set ``traj.optimizer``'s 'vibration_residual' at ``frequency`` and its 'vibration_frequency'.

    :func:`trajectory_residual` on the plan's own acceleration limits: the
    figure of :mod:`time_optimal`'s plans, measured again after a uniform
    slow-down (``path_timing.rescaled``).
    """
    traj.optimizer['vibration_frequency'] = float(frequency)
    traj.optimizer['vibration_residual'] = trajectory_residual(traj, frequency,
                                                               traj.limits.acceleration)


def remeasure_residual(traj):
    """
    Measure a slowed-down plan's residual share again, where its ``optimizer`` reports one.

    A mode's ringing after the stop moves with the time scale; the plan's
    'vibration_residual' (time_optimal's, copied from the faster plan) is
    measured again at its 'vibration_frequency' (:func:`report_residual`).
    """
    if traj.optimizer is not None and traj.optimizer.get('vibration_residual') is not None:
        report_residual(traj, traj.optimizer['vibration_frequency'])
