"""
Golden-section search for the maxima of a vectorised function, one bracket per row.

Used to refine the largest tool deviations (:mod:`tool_paths`), tool
speeds (:mod:`tool_lines`) and tool accelerations (:mod:`tool_acceleration`)
between the samples that bracket them: each step
keeps the inner point with the larger value and evaluates one new point per
bracket, so ``steps`` steps shrink every bracket to ``0.618**steps`` of its
width with ``steps + 2`` calls of ``value``.
"""

import math

import numpy as np

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
# The 1 kHz checks (tool speed, tool acceleration): golden-section steps on a
# sampled local maximum's 2 ms bracket, down to 2 ms * 0.618**10 = 16 us, where
# a speed whose second time derivative is below 1e3 m/s^3 is within 1.3e-7
# m/s of its peak; and how many of the largest local maxima are refined.
CHECK_STEPS = 10
CHECK_MAXIMA = 8


def golden_maxima(value, lo, hi, steps):
    """
    Return (x, f): where in each bracket ``[lo, hi]`` (K,) ``value`` is largest, and that value.

    ``value`` maps points (K,) to values (K,), one per bracket; it is
    assumed unimodal in each bracket (a sampled local maximum).
    """
    x1, x2 = hi - GOLDEN * (hi - lo), lo + GOLDEN * (hi - lo)
    f1, f2 = value(x1), value(x2)
    for _ in range(steps):
        right = f2 > f1  # the maximum lies in [x1, hi]
        lo, hi = np.where(right, x1, lo), np.where(right, hi, x2)
        keep_x, keep_f = np.where(right, x2, x1), np.where(right, f2, f1)
        x_new = np.where(right, lo + GOLDEN * (hi - lo), hi - GOLDEN * (hi - lo))
        f_new = value(x_new)
        x1, f1 = np.where(right, keep_x, x_new), np.where(right, keep_f, f_new)
        x2, f2 = np.where(right, x_new, keep_x), np.where(right, f_new, keep_f)
    return np.where(f1 >= f2, x1, x2), np.maximum(f1, f2)


def sampled_maxima(sampled, count=CHECK_MAXIMA):
    """
    Return the brackets of the ``count`` largest local maxima of ``sampled`` (K,): (lo, hi).

    Indices into the samples: a local maximum at sample ``i`` (not an end)
    is bracketed by its neighbours ``i - 1`` and ``i + 1``.
    """
    mid = sampled[1:-1]
    peak = np.flatnonzero((mid >= sampled[:-2]) & (mid >= sampled[2:]))
    top = peak[np.argsort(mid[peak])[-count:]]
    return top, top + 2


def refined_peak(value, t, sampled, count=CHECK_MAXIMA, steps=CHECK_STEPS):
    """
    Return the largest of ``sampled`` (K,) at times ``t`` and of its local maxima refined.

    The ``count`` largest local maxima (:func:`sampled_maxima`) are refined
    by ``steps`` golden-section steps of ``value`` in their brackets.
    """
    lo, hi = sampled_maxima(sampled, count)
    peak = float(np.max(sampled))
    if lo.size == 0:
        return peak
    _, best = golden_maxima(value, t[lo], t[hi], steps)
    return max(peak, float(np.max(best)))
