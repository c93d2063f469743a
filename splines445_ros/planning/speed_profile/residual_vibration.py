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
# Samples a period of the mode in spline_content: its trapezoid rule (1 ms apart at most),
# as the moves of position_limit_knots and residual_knots see the content.
SPLINE_SAMPLES_PER_PERIOD = 40
# ... and at most this many values (samples times splines): 32 MB.  A plan of
# 1e5 s with a mode at 1000 Hz asked for 7.6 GiB (helper-37).
MAX_SPLINE_SAMPLE_VALUES = 4e6
# Time constants 1 / (zeta w) of the mode per block of content_envelope's sums:
# exp(30) keeps them within floating point with room to spare.
ENVELOPE_DECAYS = 30.0


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


def _piece_counts(knots, step, least):
    """Return (S,) the steps :func:`spline_samples` cuts each piece of ``knots`` into."""
    return np.maximum(least, np.ceil(np.diff(knots) / step)).astype(int)


def spline_sample_count(knots, step, least=2):
    """Return how many samples :func:`spline_samples` takes on ``knots`` (S + 1,)."""
    return int(_piece_counts(knots, step, least).sum()) + 1


def spline_samples(coefficients, knots, step, least=2):
    """
    Return (steps (T - 1,), accelerations (T, m)) of ``m`` quintic splines, sampled for a mode.

    ``coefficients`` (S, 6, m) are the pieces' power-basis terms in local
    time on the ``knots`` (S + 1,) from 0 to the stop; each piece is cut in
    equal steps of at most ``step`` [s] (at least ``least``), and the
    pieces' ends are samples.  Linear in the terms: samples of unit splines give them
    as a function of knot moves (:mod:`position_limit_knots`,
    :mod:`residual_knots`).
    """
    counts = _piece_counts(knots, step, least)
    if (counts.sum() + 1.0) * coefficients.shape[2] > MAX_SPLINE_SAMPLE_VALUES:
        raise ValueError(f'{counts.sum() + 1} samples of {coefficients.shape[2]} splines '
                         f'for a mode: more than {MAX_SPLINE_SAMPLE_VALUES:.0e} values')
    t, accelerations = [], []
    last = knots.size - 2
    for piece, (start, end) in enumerate(zip(knots[:-1], knots[1:])):
        count = counts[piece]
        tau = np.linspace(0.0, end - start, count + 1)[:-1 if piece < last else None]
        powers = tau[:, None] ** np.arange(4)
        second = coefficients[piece, 2:] * np.array([2.0, 6.0, 12.0, 20.0])[:, None]  # (4, m)
        t.append(start + tau)
        accelerations.append(powers @ second)
    return np.diff(np.concatenate(t)), np.concatenate(accelerations)


def spline_content(coefficients, knots, frequencies, damping=DAMPING):
    """
    Return (2 k, m): Re and Im of each mode's content ``Z`` in each of ``m`` quintic splines.

    ``Z = int qdd(t) exp(lambda (T - t)) dt`` (module docstring) of the
    modes at ``frequencies`` (k; rows 2 i and 2 i + 1 are mode i's), by
    the trapezoid rule (:func:`content_weights`) on the samples of
    :func:`spline_samples`, :data:`SPLINE_SAMPLES_PER_PERIOD` a period of
    the fastest mode and 1 ms apart at most.
    """
    step = min(1e-3, 1.0 / (SPLINE_SAMPLES_PER_PERIOD * max(frequencies)))
    return sampled_content(*spline_samples(coefficients, knots, step), frequencies, damping)


def sampled_content(steps, accelerations, frequencies, damping=DAMPING):
    """
    Return (2 k, m): Re and Im of each mode's ``Z`` of accelerations (T, m) ``steps`` apart.

    :func:`spline_content` on samples the caller has (:func:`spline_samples`).
    """
    rows = []
    for frequency in frequencies:
        content = content_weights(steps, frequency, damping) @ accelerations
        rows += [content.real, content.imag]
    return np.stack(rows)


def content_envelope(steps, accelerations, frequency, damping=DAMPING):
    """
    Return (T, m): ``|Z(t)|`` at every sample, the mode's content up to each time ``t``.

    ``steps`` and ``accelerations`` from :func:`spline_samples`.  ``|Z(t)|
    / wd`` is the amplitude the mode would ring with were the motion to stop
    at ``t``: an envelope of its deflection during the motion (the last is
    the ringing after the stop).  Trapezoid rule, as :func:`content_weights`:
    ``Z(t_k) = exp(lambda t_k) sum_i w_i exp(-lambda t_i) qdd_i``, summed in
    blocks of :data:`ENVELOPE_DECAYS` time constants, so that the factors
    stay within floating point.
    """
    exponent, _ = mode_exponent(frequency, damping)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    half = 0.5 * np.concatenate([[0.0], steps])          # the step before each sample
    after = 0.5 * np.append(steps, 0.0)                  # and after it
    span = ENVELOPE_DECAYS / max(-exponent.real, 1e-300)
    envelope = np.empty(accelerations.shape)
    carried = np.zeros(accelerations.shape[1], dtype=complex)
    start = 0
    while start < t.size:
        stop = int(np.searchsorted(t, t[start] + span, side='right'))
        stop = max(stop, start + 1)
        local = t[start:stop] - t[start]
        phase = np.exp(-exponent * local)[:, None]
        a = accelerations[start:stop]
        # Z(t_k) = e^{lambda (t_k - t_s)} (Z(t_s) + sum_{s < i <= k} (h_i a_{i-1} e^{-lambda
        # (t_{i-1} - t_s)} + h_i a_i e^{-lambda (t_i - t_s)})), h_i half the step before t_i.
        terms = half[start:stop, None] * a * phase
        terms[1:] += half[start + 1:stop, None] * a[:-1] * phase[:-1]
        terms[0] = 0.0
        if start > 0:
            # The step into the block, from the last sample of the one before.
            terms[0] = after[start - 1] * (accelerations[start - 1] * np.exp(
                exponent * (t[start] - t[start - 1])) + accelerations[start])
        inner = carried + np.cumsum(terms, axis=0)
        values = np.exp(exponent * local)[:, None] * inner
        envelope[start:stop] = np.abs(values)
        start = stop
        if start < t.size:
            # The next block starts from this one's last value, carried over the step.
            carried = values[-1] * np.exp(exponent * (t[start] - t[start - 1]))
    return envelope


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
# Steps over the plan at least: a plan of a millisecond sampled at its ends and
# middle, where its acceleration is about 0, reported no ringing (1e-16 for a
# true 0.019 share, helper-41).
MIN_STEPS = 100
MAX_SAMPLES = 1000000


def trajectory_residual(traj, frequency, max_acceleration, period=1e-3, damping=DAMPING):
    """Return the largest residual share over the joints of a plan (None: too many samples)."""
    period = min(period, 1.0 / (SAMPLES_PER_PERIOD * frequency))
    steps = max(MIN_STEPS, int(np.ceil(traj.duration / period)))
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
