"""
Exact per-segment peaks of |velocity|, |acceleration| and |jerk|.

A polynomial's extreme values on ``[0, T]`` are at the ends or at the real roots
of its next derivative inside the interval.  Here those roots are computed
directly: the next derivative of a quintic's velocity is a cubic (closed
form, polished by Newton steps; eigenvalues of the companion matrix for
nearly degenerate cubics), everything else is at most quadratic and solved
in closed form for all segments and joints at once.  No sampling is involved.
"""

from functools import lru_cache
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
# The three angles of the trigonometric solution of a cubic.
_THIRDS = 2.0 * np.pi / 3.0 * np.arange(3)[None, :]
# Exponents of the polynomial terms.
_POWERS = np.arange(16)
# Points x = tau / T at which sampled_peaks evaluates: the ends and the eighths.
_SAMPLES = np.linspace(0.0, 1.0, 9)


@lru_cache(maxsize=None)
def _derivative_factors(degree, derivative):
    """Return ``i! / (i - d)!`` for i = d .. ``degree``, d = ``derivative`` (read-only)."""
    powers = np.arange(derivative, degree + 1)
    factor = np.ones(powers.size)
    for j in range(derivative):
        factor = factor * (powers - j)
    factor.flags.writeable = False
    return factor


def derivative_coefficients(coeffs, derivative):
    """Ascending coefficients of the ``derivative``-th derivative, shape (S, 6-d, m)."""
    c = np.asarray(coeffs, dtype=float)
    factor = _derivative_factors(c.shape[1] - 1, derivative)
    return c[:, derivative:] * factor[None, :, None]


def row_max(x):
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
        # In place: the same products and sums without new arrays.
        out *= x
        out += coeffs[:, i:i + 1]
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
    companion-matrix eigenvalues instead.  Called with numpy's invalid and
    divide warnings off (:func:`_unit_interval_roots`: one context for both).
    """
    # Every step is element-wise, so rows go through it in any grouping; the
    # selections are skipped where every row takes the same branch (the
    # common case on the few rows of a small request).
    K = q.shape[0]
    small = np.abs(q[:, 3]) < _SMALL_CUBIC
    n_small = np.count_nonzero(small)
    if n_small == K:
        return _companion_roots(q)
    if n_small:
        roots = np.full((K, 3), np.nan)
        roots[small] = _companion_roots(q[small])
        ok = ~small
        q = q[ok]
    a = q[:, 3]
    B, C, D = q[:, 2] / a, q[:, 1] / a, q[:, 0] / a
    # Depressed cubic t^3 + p t + r = 0 with x = t - B / 3.
    p = C - B * B / 3.0
    r = (2.0 * B * B - 9.0 * C) * B / 27.0 + D
    disc = 0.25 * r * r + p * p * p / 27.0
    three = disc <= 0.0
    n = a.size
    n_three = np.count_nonzero(three)
    if n_three:
        p3, r3 = (p, r) if n_three == n else (p[three], r[three])
        m = 2.0 * np.sqrt(np.maximum(-p3, 0.0) / 3.0)
        # np.clip's values, without its wrapper.
        cos_arg = np.minimum(np.maximum(np.where(m > 0.0, 3.0 * r3 / (p3 * m), 0.0),
                                        -1.0), 1.0)
        theta = np.arccos(cos_arg) / 3.0
        t_three = m[:, None] * np.cos(theta[:, None] - _THIRDS)
    if n_three < n:
        if n_three:
            one = ~three
            p1, r1, disc1 = p[one], r[one], disc[one]
        else:
            p1, r1, disc1 = p, r, disc
        u = np.cbrt(-0.5 * r1 - np.copysign(np.sqrt(disc1), r1))
        t_one = np.where(u != 0.0, u - p1 / (3.0 * u), 0.0)
    if n_three == n:
        t = t_three
    else:
        t = np.full((n, 3), np.nan)
        if n_three:
            t[three] = t_three
            t[one, 0] = t_one
        else:
            t[:, 0] = t_one
    x = t - B[:, None] / 3.0
    c0, c1, c2, c3 = q[:, 0:1], q[:, 1:2], q[:, 2:3], q[:, 3:4]
    c3_3, c2_2 = 3.0 * c3, 2.0 * c2
    for _ in range(2):
        value = ((c3 * x + c2) * x + c1) * x + c0
        slope = (c3_3 * x + c2_2) * x + c1
        x = np.where(slope != 0.0, x - value / slope, x)
    if not n_small:
        return x
    roots[ok] = x
    return roots


def _unit_interval_roots(q, out):
    """
    Write the real roots in (0, 1) of ascending polynomials ``q`` (K, <=4) into ``out``.

    ``out`` is (K, 3); slots without such a root are left at 0 (an interval
    end, which is a candidate anyway).
    """
    K, width = q.shape
    scale = row_max(np.abs(q))
    scale[scale == 0.0] = 1.0
    q = q / scale[:, None]
    n_cubic = 0
    if width == 4:
        cubic = np.abs(q[:, 3]) > _DEGENERATE
        n_cubic = np.count_nonzero(cubic)
    with np.errstate(invalid='ignore', divide='ignore'):
        if n_cubic == K:
            # Only cubics (no rows for the closed forms below).
            roots = _cubic_roots(q)
        else:
            # The closed forms on every row (element-wise, so the rows that
            # are not cubics get the values they would get alone), then the
            # cubics' roots over theirs: fewer numpy calls than selecting the
            # other rows (102 -> 91 us on the 18 rows of a 3 x 3 rival's
            # evaluation).
            a = q[:, 2] if width > 2 else np.zeros(K)
            b, c = q[:, 1], q[:, 0]
            quad = np.abs(a) > _DEGENERATE
            roots = np.empty((K, 3))
            sq = np.sqrt(b * b - 4.0 * a * c)  # NaN when there is no real root
            half = -0.5 * (b + np.copysign(sq, b))
            roots[:, 0] = np.where(quad, half / a,
                                   np.where(np.abs(b) > _DEGENERATE, -c / b, np.nan))
            roots[:, 1] = np.where(quad & (half != 0.0), c / half, np.nan)
            roots[:, 2] = np.nan
            if n_cubic:
                roots[cubic] = _cubic_roots(q[cubic])
    inside = (roots > 0.0) & (roots < 1.0)
    out[:] = np.where(inside, roots, 0.0)


def flat_polynomials(coeffs, durations, derivatives):
    """
    Return the ``derivatives`` and their next derivatives in ``x = tau / T``, a row each.

    Ascending coefficients (k S m, w) and (k S m, w - 1), ``w`` the number
    of terms of the lowest derivative, rows derivative by derivative, then
    segment, then joint: coefficient ``i`` of a derivative is multiplied by
    ``T**i``, so that every term is comparable on ``x in [0, 1]``, and
    derivatives with fewer terms are padded with zeros.
    """
    c = np.asarray(coeffs, dtype=float)
    T = np.asarray(durations, dtype=float)
    S, n_terms, m = c.shape
    width = n_terms - min(derivatives)
    # The powers of T once for all derivatives: the same values as each
    # derivative's own (a power depends only on its base and exponent).
    scale = T[:, None, None] ** _POWERS[None, :width, None]
    flat_p = np.zeros((len(derivatives), S, m, width))
    for k, derivative in enumerate(derivatives):
        p = derivative_coefficients(c, derivative)
        p *= scale[:, :p.shape[1]]
        flat_p[k, :, :, :p.shape[1]] = p.transpose(0, 2, 1)
    flat_p = flat_p.reshape(-1, width)
    # The padding's zeros stay zeros, as they would padded after this.
    return flat_p, flat_p[:, 1:] * _POWERS[None, 1:width]


def peak_candidates(flat_p, flat_dp):
    """Candidate points x in [0, 1] (K, 5) of the rows and the |polynomial| there."""
    candidates = np.zeros((flat_p.shape[0], 5))
    candidates[:, 1] = 1.0
    _unit_interval_roots(flat_dp, candidates[:, 2:])
    values = _horner(flat_p, candidates)
    return candidates, np.abs(values, out=values)


def sampled_peaks(flat_p):
    """
    Lower bounds of the rows' peaks (K,): the largest ``|p|`` at the points :data:`_SAMPLES`.

    ``flat_p`` as from :func:`flat_polynomials`.  Evaluated like the
    candidates of the exact peaks, without their root finding (a third of
    the cost of the exact peaks on a small spline): within
    round-off of the polynomial's values below the exact peaks, so a bound
    that shows a state to be too long spares its exact peaks.
    """
    x = np.broadcast_to(_SAMPLES, (flat_p.shape[0], _SAMPLES.size))
    return row_max(np.abs(_horner(flat_p, x)))


def sampled_segment_peaks_of(coeffs, durations, derivatives):
    """
    Lower bounds of :func:`segment_peaks_of` (len(derivatives), S, m): :func:`sampled_peaks`.

    Within round-off of the polynomials' values below the exact peaks.
    """
    S, _, m = np.shape(coeffs)
    flat_p, _ = flat_polynomials(coeffs, durations, tuple(derivatives))
    return sampled_peaks(flat_p).reshape(len(derivatives), S, m)


def _candidates(coeffs, durations, derivative):
    """Candidate points x in [0, 1] (S*m, 5) and the |d-th derivative| there."""
    return peak_candidates(*flat_polynomials(coeffs, durations, (derivative,)))


def segment_peaks(coeffs, durations, derivative):
    """
    Max |d-th derivative| of every segment and joint: shape (S, m).

    ``coeffs`` are ascending polynomial coefficients (S, 6, m) in local time
    ``tau in [0, T_s]``; ``derivative`` is 1 (velocity), 2 (acceleration) or
    3 (jerk).
    """
    S, _, m = np.shape(coeffs)
    _, values = _candidates(coeffs, durations, derivative)
    return row_max(values).reshape(S, m)


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
    candidates = peak_candidates(*flat_polynomials(coeffs, durations, tuple(derivatives)))
    return peaks_of_candidates(candidates, (len(derivatives), S, m))


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
    flat_p, flat_dp = flat_polynomials(coeffs, durations, (1,))
    candidates = np.zeros((S * m, 5))
    candidates[:, 1] = 1.0
    # The ends exactly as segment_peaks evaluates them (two of its candidates).
    peaks = row_max(np.abs(_horner(flat_p, candidates[:, :2])))
    ratios = peaks.reshape(S, m) / bounds[None, :]
    floor = np.maximum(np.asarray(floor, dtype=float), row_max(ratios))
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
        peaks[rows] = row_max(np.abs(_horner(flat_p[rows], candidates)))
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


def peaks_of_candidates(candidates, shape):
    """
    Return the peaks (k, S, m) of :func:`peak_candidates`' ``candidates`` (points, |values|).

    ``shape`` is (k, S, m): the derivatives, segments and joints of the
    rows; the largest |value| of every row (:func:`segment_peaks_of`'s), for
    a caller that may need the sensitivities at them later
    (:func:`peak_sensitivities_at`).
    """
    return row_max(candidates[1]).reshape(shape)


def peak_sensitivities_at(coeffs, durations, derivatives, candidates):
    """
    Return per derivative its peaks (S, m) of |value| and how they move with the coefficients.

    A peak sits at the end of its segment or at a stationary point of the
    derivative, so to first order it moves only through the values at the
    same relative position ``x = tau / T`` (the envelope theorem).  For
    each of ``derivatives`` the result has ``(peaks, weights, slope)``:
    ``d peak = weights . d coeffs + slope * d T`` with ``weights`` (S, m,
    6) on the ascending coefficients of the same segment and joint, and
    ``slope`` (S, m) for a change of that segment's own duration ``T``
    (non-zero only for a peak at ``tau = T``).  ``candidates`` are the
    rows' :func:`peak_candidates` (the root finding is done: optimal
    timing's evaluations need the rest only for a Jacobian).  The powers of
    every peak's time are found once for a derivative and the next one.
    """
    c = np.asarray(coeffs, dtype=float)
    T = np.asarray(durations, dtype=float)
    S, n_terms, m = c.shape
    k = len(derivatives)
    points, values = candidates
    best = np.argmax(values, axis=1)
    rows = np.arange(k * S * m)
    x = points[rows, best].reshape(k, S, m)
    peaks = values[rows, best].reshape(k, S, m)
    tau = x * T[:, None]
    # tau**i for every exponent i the weights use: the same values as
    # computed for each weight (a power depends only on base and exponent).
    # (np.take keeps them in C order, as einsum's summation order depends
    # on the memory layout of its operands.)
    powers = tau[..., None] ** _POWERS[None, None, None, :n_terms]
    out = []
    for i, derivative in enumerate(derivatives):
        falling, exponent = falling_factors(derivative)
        weights = falling[None, None, :] * np.take(powers[i], exponent, axis=2)
        value = np.einsum('smi,sim->sm', weights, c)
        next_falling, next_exponent = falling_factors(derivative + 1)
        next_weights = next_falling[None, None, :] * np.take(powers[i], next_exponent, axis=2)
        next_value = np.einsum('smi,sim->sm', next_weights, c)
        sign = np.sign(value)
        out.append((peaks[i], sign[..., None] * weights, sign * next_value * x[i]))
    return out
