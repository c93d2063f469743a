"""
Exact per-segment peaks of |velocity|, |acceleration| and |jerk|.

A polynomial's extreme values on ``[0, T]`` are at the ends or at the real roots
of its next derivative inside the interval.  Here those roots are computed
directly: the next derivative of a quintic's velocity is a cubic (closed
form, polished by Newton steps; eigenvalues of the companion matrix for
nearly degenerate cubics), everything else is at most quadratic and solved
in closed form for all segments and joints at once.  No sampling is involved.
"""

from math import comb

import numpy as np

from .segments import falling_factors

# Relative size below which a leading coefficient counts as zero (in the
# interval-normalised variable x = tau / T, where all terms are comparable).
_DEGENERATE = 1e-13
# Scaled leading coefficient below which a cubic's roots come from eigenvalues.
_SMALL_CUBIC = 1e-6
# velocity_ratios_above: relative margin of its Bernstein bound against round-off.
PRUNE_MARGIN = 1e-9
# Power to Bernstein basis of a quartic on [0, 1]: b_k = sum_i C(k, i) / C(4, i) p_i.
_BERNSTEIN = np.array([[comb(k, i) / comb(4, i) for i in range(5)] for k in range(5)])


def derivative_coefficients(coeffs, derivative):
    """Ascending coefficients of the ``derivative``-th derivative, shape (S, 6-d, m)."""
    c = np.asarray(coeffs, dtype=float)
    degree = c.shape[1] - 1
    powers = np.arange(derivative, degree + 1)
    factor = np.ones(powers.size)
    for j in range(derivative):
        factor = factor * (powers - j)
    return c[:, derivative:] * factor[None, :, None]


def _row_max(x):
    """
    Return the largest entry of every row of ``x`` (K, r): ``np.max(x, axis=1)``, the same values.

    A reduction over a short last axis is several times slower in numpy
    than ``r - 1`` element-wise maxima of its columns (NaN propagates in both).
    """
    out = x[:, 0].copy()
    for k in range(1, x.shape[1]):
        np.maximum(out, x[:, k], out=out)
    return out


def _horner(coeffs, x):
    """Evaluate ascending ``coeffs`` (K, n) at ``x`` (K, r): returns (K, r)."""
    out = np.zeros_like(x)
    for i in range(coeffs.shape[1] - 1, -1, -1):
        out = out * x + coeffs[:, i:i + 1]
    return out


def _companion_roots(q):
    """Real roots (K, 3) of ascending cubics ``q`` (K, 4) from companion-matrix eigenvalues."""
    companion = np.zeros((q.shape[0], 3, 3))
    companion[:, 1, 0] = 1.0
    companion[:, 2, 1] = 1.0
    companion[:, :, 2] = -q[:, :3] / q[:, 3:4]
    eig = np.linalg.eigvals(companion)
    real = np.abs(eig.imag) <= 1e-9 * np.maximum(1.0, np.abs(eig.real))
    return np.where(real, eig.real, np.nan)


def _cubic_roots(q):
    """
    Real roots (K, 3) of ascending cubics ``q`` (K, 4), NaN where a root is not real.

    Closed form (trigonometric for three real roots, Cardano for one), then
    two Newton steps on the original cubic; cubics whose leading coefficient
    is small next to the others (scaled, below :data:`_SMALL_CUBIC`) use
    companion-matrix eigenvalues instead.
    """
    roots = np.full((q.shape[0], 3), np.nan)
    small = np.abs(q[:, 3]) < _SMALL_CUBIC
    if np.any(small):
        roots[small] = _companion_roots(q[small])
    ok = ~small
    a = q[ok, 3]
    B, C, D = q[ok, 2] / a, q[ok, 1] / a, q[ok, 0] / a
    # Depressed cubic t^3 + p t + r = 0 with x = t - B / 3.
    p = C - B * B / 3.0
    r = (2.0 * B * B - 9.0 * C) * B / 27.0 + D
    disc = 0.25 * r * r + p * p * p / 27.0
    three = disc <= 0.0
    t = np.full((a.size, 3), np.nan)
    with np.errstate(invalid='ignore', divide='ignore'):
        m = 2.0 * np.sqrt(np.maximum(-p[three], 0.0) / 3.0)
        cos_arg = np.clip(np.where(m > 0.0, 3.0 * r[three] / (p[three] * m), 0.0), -1.0, 1.0)
        theta = np.arccos(cos_arg) / 3.0
        t[three] = m[:, None] * np.cos(theta[:, None] -
                                       2.0 * np.pi / 3.0 * np.arange(3)[None, :])
        one = ~three
        u = np.cbrt(-0.5 * r[one] - np.copysign(np.sqrt(disc[one]), r[one]))
        t[one, 0] = np.where(u != 0.0, u - p[one] / (3.0 * u), 0.0)
    x = t - B[:, None] / 3.0
    c0, c1, c2, c3 = (q[ok, i][:, None] for i in range(4))
    for _ in range(2):
        value = ((c3 * x + c2) * x + c1) * x + c0
        slope = (3.0 * c3 * x + 2.0 * c2) * x + c1
        with np.errstate(invalid='ignore', divide='ignore'):
            x = np.where(slope != 0.0, x - value / slope, x)
    roots[ok] = x
    return roots


def _unit_interval_roots(q, out):
    """
    Write the real roots in (0, 1) of ascending polynomials ``q`` (K, <=4) into ``out``.

    ``out`` is (K, 3); slots without such a root are left at 0 (an interval
    end, which is a candidate anyway).
    """
    K, width = q.shape
    scale = _row_max(np.abs(q))
    scale[scale == 0.0] = 1.0
    q = q / scale[:, None]
    cubic = (np.abs(q[:, 3]) > _DEGENERATE) if width == 4 else np.zeros(K, dtype=bool)
    roots = np.full((K, 3), np.nan)
    if np.any(cubic):
        roots[cubic] = _cubic_roots(q[cubic])
        rest = ~cubic
        a, b, c = q[rest, 2], q[rest, 1], q[rest, 0]
    else:
        rest = slice(None)
        a = q[:, 2] if width > 2 else np.zeros(K)
        b, c = q[:, 1], q[:, 0]
    quad = np.abs(a) > _DEGENERATE
    with np.errstate(invalid='ignore', divide='ignore'):
        sq = np.sqrt(b * b - 4.0 * a * c)  # NaN when there is no real root
        half = -0.5 * (b + np.copysign(sq, b))
        roots[rest, 0] = np.where(quad, half / a,
                                  np.where(np.abs(b) > _DEGENERATE, -c / b, np.nan))
        roots[rest, 1] = np.where(quad & (half != 0.0), c / half, np.nan)
    inside = (roots > 0.0) & (roots < 1.0)
    out[:] = np.where(inside, roots, 0.0)


def _normalised(coeffs, durations, derivative):
    """
    Return the d-th derivative and the next one in ``x = tau / T``, a row per segment and joint.

    Returns ascending coefficients (S*m, 6-d) and (S*m, 5-d): coefficient
    ``i`` of the derivative is multiplied by ``T**i``, so that every term is
    comparable on ``x in [0, 1]``.
    """
    T = np.asarray(durations, dtype=float)
    S, _, m = np.shape(coeffs)
    p = derivative_coefficients(coeffs, derivative)
    p = p * (T[:, None, None] ** np.arange(p.shape[1])[None, :, None])
    dp = p[:, 1:] * np.arange(1, p.shape[1])[None, :, None]
    return p.transpose(0, 2, 1).reshape(S * m, -1), dp.transpose(0, 2, 1).reshape(S * m, -1)


def _candidates(coeffs, durations, derivative):
    """Candidate points x in [0, 1] (S*m, 5) and the |d-th derivative| there."""
    flat_p, flat_dp = _normalised(coeffs, durations, derivative)
    candidates = np.zeros((flat_p.shape[0], 5))
    candidates[:, 1] = 1.0
    _unit_interval_roots(flat_dp, candidates[:, 2:])
    return candidates, np.abs(_horner(flat_p, candidates))


def segment_peaks(coeffs, durations, derivative):
    """
    Max |d-th derivative| of every segment and joint: shape (S, m).

    ``coeffs`` are ascending polynomial coefficients (S, 6, m) in local time
    ``tau in [0, T_s]``; ``derivative`` is 1 (velocity), 2 (acceleration) or
    3 (jerk).
    """
    S, _, m = np.shape(coeffs)
    _, values = _candidates(coeffs, durations, derivative)
    return _row_max(values).reshape(S, m)


def segment_peaks_of(coeffs, durations, derivatives):
    """
    :func:`segment_peaks` of several ``derivatives`` at once: shape (len(derivatives), S, m).

    One root finding and one evaluation for all of them instead of one per
    derivative (the per-call cost dominates on the short splines of
    :mod:`inner_knots`).  The polynomials of lower degree are padded with
    zero terms, which leave every step of the root finding and of the
    evaluation unchanged, so the peaks are those of :func:`segment_peaks`,
    bit for bit.
    """
    S, _, m = np.shape(coeffs)
    rows = S * m
    width = 6 - min(derivatives)
    flat_p = np.zeros((len(derivatives) * rows, width))
    flat_dp = np.zeros((len(derivatives) * rows, width - 1))
    for k, derivative in enumerate(derivatives):
        p, dp = _normalised(coeffs, durations, derivative)
        flat_p[k * rows:(k + 1) * rows, :p.shape[1]] = p
        flat_dp[k * rows:(k + 1) * rows, :dp.shape[1]] = dp
    candidates = np.zeros((flat_p.shape[0], 5))
    candidates[:, 1] = 1.0
    _unit_interval_roots(flat_dp, candidates[:, 2:])
    return _row_max(np.abs(_horner(flat_p, candidates))).reshape(len(derivatives), S, m)


def velocity_ratios_above(coeffs, durations, bounds, floor):
    """
    |velocity| peaks over ``bounds`` (m,): (S, m), exact where they can decide a segment's largest.

    For callers that need, per segment, only the largest of these ratios and
    of their own values, which are at least ``floor`` (S,): a segment's
    largest of ``max(result, floor)`` over its joints is the same, bit for
    bit, as with the exact ratios (``segment_peaks(..., 1) / bounds``).
    The velocity of a quintic is a quartic, whose peak inside the segment
    needs the roots of a cubic; its Bernstein coefficients on ``[0, 1]``
    bound it (a polynomial lies within the convex hull of its Bernstein
    coefficients).  The floor is first raised to the segment's largest
    ratio at the segment ends (values the exact peaks include); where a
    joint's bound, plus :data:`PRUNE_MARGIN` of the sum of its quartic's
    |terms| (far above the round-off of evaluating it), stays below that
    (times 1 - :data:`PRUNE_MARGIN`), its peak cannot exceed it, and the
    ratio at the larger end is returned without root finding.  Everywhere
    else the ratio is the exact one.
    """
    S, _, m = np.shape(coeffs)
    flat_p, flat_dp = _normalised(coeffs, durations, 1)
    candidates = np.zeros((S * m, 5))
    candidates[:, 1] = 1.0
    # The ends exactly as segment_peaks evaluates them (two of its candidates).
    peaks = _row_max(np.abs(_horner(flat_p, candidates[:, :2])))
    ratios = peaks.reshape(S, m) / bounds[None, :]
    floor = np.maximum(np.asarray(floor, dtype=float), _row_max(ratios))
    # Terms in rows (5, S*m), then the Bernstein coefficients row by row
    # (element-wise: a matrix product would start BLAS threads for this).
    terms = np.ascontiguousarray(flat_p.T)
    upper = np.zeros(S * m)
    for weights in _BERNSTEIN:
        np.maximum(upper, np.abs(sum(w * t for w, t in zip(weights, terms) if w)), out=upper)
    upper += PRUNE_MARGIN * np.sum(np.abs(terms), axis=0)
    upper = upper.reshape(S, m) / bounds[None, :]
    rows = np.flatnonzero(~(upper < (floor * (1.0 - PRUNE_MARGIN))[:, None]))
    if rows.size:
        candidates = candidates[rows]
        _unit_interval_roots(flat_dp[rows], candidates[:, 2:])
        peaks[rows] = _row_max(np.abs(_horner(flat_p[rows], candidates)))
        ratios = peaks.reshape(S, m) / bounds[None, :]
    return ratios


def position_extrema(coeffs, durations, end_values=None):
    """
    Smallest and largest position of every segment and joint, and where.

    Returns ``(low, high, low_time, high_time)``, each (S, m), with local
    times ``tau`` in ``[0, T_s]``.  Exact like the peaks: the candidates are
    the segment ends and the real roots in the interval of the velocity, a
    quartic for a quintic segment, found as eigenvalues of its companion
    matrix (all segments at once; an error in a root moves the extreme
    value only to second order, since the velocity vanishes there).
    ``end_values`` (S, m), when given, are the exact positions at every
    segment's end (the next knot), used instead of evaluating the
    polynomial there, which can land an ulp past a waypoint.
    """
    T = np.asarray(durations, dtype=float)
    c = np.asarray(coeffs, dtype=float)
    S, width, m = c.shape
    p = c * (T[:, None, None] ** np.arange(width)[None, :, None])
    flat_p = p.transpose(0, 2, 1).reshape(S * m, width)
    dp = flat_p[:, 1:] * np.arange(1, width)[None, :]
    scale = np.max(np.abs(dp), axis=1)
    scale[scale == 0.0] = 1.0
    dp = dp / scale[:, None]
    candidates = np.zeros((S * m, width + 1))
    candidates[:, 1] = 1.0
    degree = np.zeros(S * m, dtype=int)
    for d in range(1, dp.shape[1]):
        degree[np.abs(dp[:, d]) > _DEGENERATE] = d
    for d in range(1, dp.shape[1]):
        rows = np.flatnonzero(degree == d)
        if rows.size == 0:
            continue
        companion = np.zeros((rows.size, d, d))
        companion[:, np.arange(1, d), np.arange(d - 1)] = 1.0
        companion[:, :, d - 1] = -dp[rows, :d] / dp[rows, d:d + 1]
        eig = np.linalg.eigvals(companion)
        real = np.abs(eig.imag) <= 1e-9 * np.maximum(1.0, np.abs(eig.real))
        inside = real & (eig.real > 0.0) & (eig.real < 1.0)
        candidates[rows, 2:2 + d] = np.where(inside, eig.real, 0.0)
    values = _horner(flat_p, candidates)
    if end_values is not None:
        values[:, 1] = np.asarray(end_values, dtype=float).reshape(S * m)
    rows = np.arange(S * m)
    low, high = np.argmin(values, axis=1), np.argmax(values, axis=1)
    return (values[rows, low].reshape(S, m), values[rows, high].reshape(S, m),
            candidates[rows, low].reshape(S, m) * T[:, None],
            candidates[rows, high].reshape(S, m) * T[:, None])


def segment_peak_times(coeffs, durations, derivative):
    """Local time (S, m) at which each segment's |d-th derivative| peaks."""
    S, _, m = np.shape(coeffs)
    candidates, values = _candidates(coeffs, durations, derivative)
    best = np.argmax(values, axis=1)
    x = candidates[np.arange(S * m), best].reshape(S, m)
    return x * np.asarray(durations, dtype=float)[:, None]


def peak_sensitivities(coeffs, durations, derivative):
    """
    Peaks (S, m) of |d-th derivative| and how they change with the coefficients.

    A peak sits at the end of its segment or at a stationary point of the
    d-th derivative, so to first order it moves only through the values at
    the same relative position ``x = tau / T`` (the envelope theorem).
    Returns ``(peaks, weights, slope)``: ``d peak = weights . d coeffs +
    slope * d T`` with ``weights`` (S, m, 6) on the ascending coefficients of
    the same segment and joint, and ``slope`` (S, m) for a change of that
    segment's own duration ``T`` (non-zero only for a peak at ``tau = T``).
    """
    c = np.asarray(coeffs, dtype=float)
    T = np.asarray(durations, dtype=float)
    S, _, m = c.shape
    candidates, values = _candidates(c, T, derivative)
    best = np.argmax(values, axis=1)
    rows = np.arange(S * m)
    x = candidates[rows, best].reshape(S, m)
    peaks = values[rows, best].reshape(S, m)
    tau = x * T[:, None]
    falling, exponent = falling_factors(derivative)
    weights = falling[None, None, :] * tau[..., None] ** exponent[None, None, :]
    value = np.einsum('smi,sim->sm', weights, c)
    next_falling, next_exponent = falling_factors(derivative + 1)
    next_value = np.einsum('smi,sim->sm',
                           next_falling[None, None, :] * tau[..., None] ** next_exponent, c)
    sign = np.sign(value)
    return peaks, sign[..., None] * weights, sign * next_value * x
