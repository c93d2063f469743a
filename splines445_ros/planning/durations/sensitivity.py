"""
Peak ratios of a spline as functions of its segment durations, with exact derivatives.

The constraints of optimal timing (:mod:`optimal`) are, for every segment s,
joint j and limited quantity q (1 velocity, 2 acceleration, 3 jerk)::

    r_{s,j,q}(T) = (peak_{s,j,q} / limit_{j,q})^(1/q)

used as ``log r`` of ``log T``: a segment's own constraint is then exactly
linear when only its time scale changes (``log r = log r_0 - log(T / T_0)``).

Derivatives (:func:`peak_jacobian`) are exact, not finite differences.  A
change of ``T_k`` changes the equations of the banded continuity system
(:mod:`continuity_system`) at the two knots of segment k only; the knot
states respond by one banded solve with that right-hand side
(:meth:`ContinuitySystem.duration_derivatives`), the coefficients through
the segment maps (eqs. 3-23) and their exact ``T`` derivatives, and a peak
through the coefficients at its fixed relative position (envelope theorem,
:func:`peaks.peak_sensitivities_at`).

The response decays away from segment k by the method's ``reach``
(:mod:`methods`), so the Jacobian is banded and responses of segments one
window apart share one right-hand-side column: a few dozen columns give the
whole Jacobian, at a cost linear in N.  445's response does not decay
downstream (the -1 root of its knot recursion): beyond a few knots every
column is the same undamped mode ``psi`` with its own amplitude, so the
Jacobian is the band plus a lower-triangular part of rank one per joint,
``beta_{s,j,q} * alpha_{k,j}`` (a semi-separable matrix), still linear in N
to compute and to use (:class:`PeakJacobian`).
"""

import numpy as np
from scipy.sparse import csr_matrix

from .dense_lp import DENSE_LP_SEGMENTS
from ..spline.continuity_system import banded_solve, ContinuitySystem
from ..spline.limits import QUANTITIES
from ..spline.methods import get_method
from ..spline.peaks import (flat_polynomials, peak_candidates, peak_sensitivities_at,
                            peaks_of_candidates, sampled_peaks)
from ..spline.segments import input_map_derivatives

# Jacobian entries (d log r / d log T) below this are dropped.
NEGLIGIBLE = 1e-6
# PeakRatios.evaluate(above=...): relative margin of the sampled lower bound
# of the restored total over ``above``, far above the round-off of the
# polynomials' values (1e-13 even where their terms cancel a thousandfold).
LOWER_BOUND_RTOL = 1e-6


class PeakRatios:
    """The constraint values log r(log T) of one request and their exact Jacobian."""

    def __init__(self, method, points, boundary, limits):
        """Keep the request; nothing is solved yet."""
        self.method = get_method(method)
        self.points = points
        self.dP = np.diff(points, axis=0)
        self.boundary = boundary
        self.limits = limits
        bounds = limits.as_array()
        self._quantities = [q for q in range(len(QUANTITIES))
                            if not np.all(np.isinf(bounds[q]))]
        self._bounds = bounds[self._quantities]        # (n_q, n)
        # Per evaluation the same: the derivatives and the orders q of the
        # quantities (issue 38, planning time of small requests).
        self._derivatives = tuple(q + 1 for q in self._quantities)
        self._order = np.array(self._quantities) + 1.0
        self._order.flags.writeable = False     # shared by every state
        self.evaluations = 0

    def evaluate(self, log_durations, above=None):
        """
        Return the state at ``log_durations``: a dict, or None when the system is singular.

        ``state['log_ratios']`` (S, n, n_q) are the constraint values (-inf for
        a zero peak); the rest is what :meth:`jacobian` needs.  ``above``, a
        restored total (:func:`optimal._restored_total`): None also when the
        state's is certainly above it, which a lower bound from the
        polynomials' values at fixed points shows without the exact peaks
        (:func:`peaks.sampled_peaks`, :data:`LOWER_BOUND_RTOL`).  For a caller
        that rejects such a state anyway: on a 3 x 3 request such a state
        costs 0.18 ms instead of 0.37 ms.  Of 1573 states so checked on 170
        random requests (2-25 waypoints), 256 were skipped: 121 of the 146
        first warm-start steps that optimal rejected, 135 of its 305
        rejected trust-region steps.
        """
        durations = np.exp(log_durations)
        self.evaluations += 1
        try:
            system = ContinuitySystem(self.method, durations)
            vel, acc = system.solve(self.dP, *self.boundary)
        except ValueError:  # singular for these durations
            return None
        coeffs = system.coefficients(self.points[:-1], self.dP, vel, acc)
        derivatives = self._derivatives
        flat = flat_polynomials(coeffs, durations, derivatives)
        if above is not None and self._restored_above(durations, flat[0], above):
            return None
        candidates = peak_candidates(*flat)
        # (S, n, n_q): np.moveaxis(..., 0, -1)'s view, without its wrapper.
        peaks = peaks_of_candidates(candidates, (len(derivatives),) +
                                    coeffs.shape[::2]).transpose(1, 2, 0)
        if not np.all(np.isfinite(peaks)):
            return None
        order = self._order
        with np.errstate(divide='ignore'):
            log_ratios = np.log(peaks / self._bounds.T[None]) / order
        # The peaks' sensitivities (weights, slope) wait for a Jacobian
        # (_sensitivities): most states are trials that are not taken.
        return {'durations': durations, 'system': system, 'vel': vel, 'acc': acc,
                'peaks': peaks, 'order': order, 'log_ratios': log_ratios,
                'coeffs': coeffs, 'derivatives': derivatives, 'candidates': candidates}

    @staticmethod
    def _sensitivities(state):
        """Add the peaks' ``weights`` (S, n, n_q, 6) and ``slope`` (S, n, n_q) to ``state``."""
        if 'weights' not in state:
            sens = peak_sensitivities_at(state['coeffs'], state['durations'],
                                         state['derivatives'], state['candidates'])
            state['weights'] = np.stack([s[1] for s in sens], axis=2)
            state['slope'] = np.stack([s[2] for s in sens], axis=-1)
        return state

    def _restored_above(self, durations, flat_p, above):
        """Whether the restored total of ``durations`` is above ``above`` by the sampled bound."""
        n_q, n = self._bounds.shape
        lower = sampled_peaks(flat_p).reshape(n_q, durations.size, n)
        with np.errstate(divide='ignore', invalid='ignore'):
            log_ratios = np.log(lower / self._bounds[:, None, :]) / self._order[:, None, None]
        bound = float(durations.sum()) * np.exp(max(0.0, float(np.max(log_ratios))))
        return bound > above + LOWER_BOUND_RTOL * abs(above)

    def jacobian(self, state):
        """Return d log r / d log T at ``state`` as a :class:`PeakJacobian`."""
        return peak_jacobian(self.method, self.dP, self._sensitivities(state))


class PeakJacobian:
    """
    The Jacobian: a sparse band plus an optional semi-separable tail.

    Row ``(s * n + j) * n_q + q`` is segment s, joint j, quantity q; column k
    is ``log T_k``.  The tail (445 only) is ``beta[row] * weight[k, j]`` for
    ``k <= s - lag``, that is ``beta[row] * z[s - lag, j]`` with the running
    sums ``z[m, j] = sum_{k <= m} weight[k, j] * dx_k``.

    The band is kept as CSR arrays (``data``, ``indices``, ``indptr``);
    scipy's matrix of them (:attr:`band`) is built only when asked for
    (HiGHS's LPs of long requests).  Issue 38, planning time of small
    requests: building it, its ``abs`` and its row slices cost about 100 us
    of each LP step of a 5 x 6 request, more than its LP.  The row sums,
    products and dense rows here are computed as scipy computes them (the
    same operations in the same order: the same bits).
    """

    def __init__(self, band, n_joints, n_q, beta=None, weight=None, lag=0):
        """
        Wrap ``band`` and the tail ``beta`` (rows,), ``weight`` (S, n).

        ``band`` is a (rows, S) CSR matrix, or its ``(data, indices, indptr,
        shape)`` with sorted, unique column indices in every row.
        """
        if isinstance(band, tuple):
            self._data, self._indices, self._indptr, self.shape = band
            self._band = None
        else:
            self._data, self._indices, self._indptr = band.data, band.indices, band.indptr
            self.shape, self._band = band.shape, band
        self._dense = None
        self.n_joints = n_joints
        self.n_q = n_q
        self.beta = beta
        self.weight = weight
        self.lag = lag
        rows = np.arange(self.shape[0])
        self.row_segment = rows // (n_joints * n_q)
        self.row_joint = rows // n_q % n_joints
        self.has_tail = beta is not None
        if self.has_tail:
            self._tail_rows = np.flatnonzero(self.row_segment >= lag)

    @property
    def band(self):
        """Return the band as a scipy CSR matrix (rows, S), built the first time."""
        if self._band is None:
            self._band = csr_matrix((self._data, self._indices, self._indptr),
                                    shape=self.shape)
        return self._band

    def _dense_band(self):
        """Return the band as a dense (rows, S) array (zeros off it); None for a long request."""
        if self._dense is None and self.shape[1] <= DENSE_LP_SEGMENTS:
            dense = np.zeros(self.shape)
            entry_rows = np.repeat(np.arange(self.shape[0]), np.diff(self._indptr))
            dense[entry_rows, self._indices] = self._data
            self._dense = dense
        return self._dense

    def _tail(self, running):
        """Add ``beta * running[s - lag, j]`` over the rows that have a tail."""
        out = np.zeros(self.shape[0])
        r = self._tail_rows
        out[r] = self.beta[r] * running[self.row_segment[r] - self.lag, self.row_joint[r]]
        return out

    def __matmul__(self, step):
        """Return the Jacobian times ``step`` (S,)."""
        dense = self._dense_band()
        if dense is None:
            out = self.band @ step
        else:
            # scipy's csr_matvec: every row's products added in column order
            # to 0.0; the zeros off the band add +-0.0, which changes no sum.
            out = np.zeros(self.shape[0])
            for k in range(self.shape[1]):
                out += dense[:, k] * step[k]
        if self.has_tail:
            out += self._tail(np.cumsum(self.weight * step[:, None], axis=0))
        return out

    def abs_row_sums(self):
        """Return the sum of |entries| of every row (rows,)."""
        # abs(band).sum(axis=1) as scipy sums a CSR matrix's rows: add.reduceat.
        out = np.zeros(self.shape[0])
        filled = np.flatnonzero(np.diff(self._indptr))
        if filled.size:
            out[filled] = np.add.reduceat(np.abs(self._data), self._indptr[filled])
        if self.has_tail:
            out += np.abs(self._tail(np.cumsum(np.abs(self.weight), axis=0)))
        return out

    def dense_rows(self, rows):
        """Return the rows ``rows`` of the Jacobian as a dense (len(rows), S) array."""
        rows = np.asarray(rows, int)
        dense = self._dense_band()
        out = self.band[rows].toarray() if dense is None else dense[rows]
        if self.has_tail:
            k = np.arange(self.shape[1])
            below = k[None, :] <= self.row_segment[rows, None] - self.lag
            out += np.where(below, self.beta[rows, None] * self.weight[:, self.row_joint[rows]].T,
                            0.0)
        return out

    def tail_columns(self, rows):
        """Return (positions in ``rows``, running-sum indices m * n + j) of their tail entries."""
        rows = np.asarray(rows)
        segment = self.row_segment[rows]
        has = np.flatnonzero(segment >= self.lag)
        return has, (segment[has] - self.lag) * self.n_joints + self.row_joint[rows[has]]


def _batches(n_seg, up, down):
    """Yield (segments, columns, n_columns): which segments share which solve column."""
    window = up + down + 2
    if window < n_seg:
        segments = np.arange(n_seg)
        yield segments, segments % window, window
        return
    yield np.arange(n_seg), np.arange(n_seg), n_seg


def _undamped_mode(system, n_knots):
    """Return the knot-state shape (N, 2) of a response far downstream of its cause."""
    bandwidth, band = system.banded
    rhs = np.zeros((band.shape[1], 1))
    rhs[0] = 1.0
    x = banded_solve(bandwidth, band, rhs)
    psi = np.zeros((n_knots, 2))
    x = x.reshape(n_knots - 2, len(system.unknowns))
    for ui, comp in enumerate(system.unknowns):
        psi[1:-1, comp] = x[:, ui]
    return psi / np.max(np.abs(psi))


def peak_jacobian(method, dP, state):
    """
    Exact d log r / d log T at ``state`` (see the module docstring).

    Band entries are kept for segments ``k - up .. k + down`` of a change
    of ``T_k`` (the method's ``reach``); for a method without downstream
    decay (445) the band reaches ``up`` segments downstream and the rest is
    the rank-one-per-joint tail.
    """
    method = get_method(method)
    system = state['system']
    T = state['durations']
    n_seg, n, n_q = state['log_ratios'].shape
    up, down = method.reach
    tail = down is None
    down = up if tail else down
    up, down = min(up, n_seg - 1), min(down, n_seg - 1)
    vel, acc = state['vel'], state['acc']
    inputs = system.segment_inputs(dP, vel, acc)                       # (S, 5, n)
    maps = system.maps                                                 # (S, 6, 5)
    with np.errstate(divide='ignore'):
        scale = 1.0 / (state['order'][None, None, :] * state['peaks'])
    scale[~np.isfinite(scale)] = 0.0                                   # zero peaks
    # d log r = scale * (weights . d coeffs + slope d T), d coeffs = B d inputs
    # (+ dB/dT inputs d T for the own segment): fold B into the weights.
    weights = state['weights'] * scale[..., None]                      # (S, n, n_q, 6)
    knot_weights = np.ascontiguousarray(
        (weights @ maps[:, None])[..., 1:].transpose(3, 0, 1, 2))      # (4, S, n, n_q)
    own_coeffs = input_map_derivatives(maps, T) @ inputs               # (S, 6, n)
    own = np.einsum('sjqi,sij->sjq', weights, own_coeffs) + state['slope'] * scale
    # Band: entry (s, j, q, i) is d log r_{s,j,q} / d log T_{s - offsets[i]}.
    offsets = np.arange(down, -up - 1, -1)
    band = np.zeros((n_seg, n, n_q, offsets.size))
    lag = down + 1
    with_tail = tail and n_seg > lag
    beta = weight = None
    segments, columns, n_columns = next(_batches(n_seg, up, down))
    response = system.duration_derivatives(dP, vel, acc, segments, columns, n_columns)
    if with_tail:
        psi = _undamped_mode(system, n_seg + 1)                        # (N, 2)
        # Tails of the earlier segments sharing a column: subtract them.
        probe = np.arange(n_seg - lag)                                 # segments with a tail
        at = probe + lag                                               # knot past the band
        norm = np.sum(psi[at] ** 2, axis=1)
        running = np.einsum('kc,kcj->kj', psi[at], response[at, :, columns[probe]]) / \
            norm[:, None]                                              # (P, n)
        earlier = np.zeros((n_seg, n))
        if n_columns < n_seg:
            # Same column, one window earlier (always a segment with a tail).
            earlier[n_columns:] = running[:n_seg - n_columns]
        amplitude = np.zeros((n_seg, n))
        amplitude[:n_seg - lag] = running - earlier[:n_seg - lag]
        weight = amplitude * T[:, None]
        mode = [psi[:-1, 0], psi[:-1, 1], psi[1:, 0], psi[1:, 1]]       # inputs of segment s
        beta = sum(w * m[:, None, None] for w, m in zip(knot_weights, mode))
    # Every (affected segment s, offset) pair at once, perturbed segment
    # k = s - offset: the same element-wise operations as one offset at a time
    # (issue 38, planning time of small requests: a loop over the 2 reach + 1
    # offsets cost 15 numpy calls each).
    cols = np.arange(n_seg)[:, None] - offsets[None, :]                # (S, n_off)
    s_of, i_of = np.nonzero((cols >= 0) & (cols < n_seg))
    k_of = cols[s_of, i_of]
    col = columns[k_of]
    start = response[s_of, :, col][..., None]                          # (P, 2, n, 1)
    end = response[s_of + 1, :, col][..., None]
    if with_tail:
        start = start - (earlier[k_of, None, :] * psi[s_of, :, None])[..., None]
        end = end - (earlier[k_of, None, :] * psi[s_of + 1, :, None])[..., None]
    d_ratios = (knot_weights[0, s_of] * start[:, 0] + knot_weights[1, s_of] * start[:, 1] +
                knot_weights[2, s_of] * end[:, 0] + knot_weights[3, s_of] * end[:, 1])
    own_pairs = np.flatnonzero(offsets[i_of] == 0)
    d_ratios[own_pairs] += own[s_of[own_pairs]]
    band[s_of, :, :, i_of] = d_ratios * T[k_of, None, None]            # d log r / d log T_k
    keep = (np.abs(band) > NEGLIGIBLE) & ((cols >= 0) & (cols < n_seg))[:, None, None, :]
    keep = keep.reshape(n_seg * n * n_q, offsets.size)
    indptr = np.concatenate([[0], np.cumsum(keep.sum(axis=1))])
    indices = np.broadcast_to(cols[:, None, None, :], band.shape).reshape(keep.shape)[keep]
    matrix = (band.reshape(keep.shape)[keep], indices, indptr, (n_seg * n * n_q, n_seg))
    if with_tail:
        return PeakJacobian(matrix, n, n_q, beta.reshape(-1), weight, lag)
    return PeakJacobian(matrix, n, n_q)
