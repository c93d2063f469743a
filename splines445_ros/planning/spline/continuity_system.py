"""
The banded linear system that makes the spline continuous at interior knots.

What is unknown and what is made continuous is the method's definition
(:mod:`methods`).  For 445 the unknowns are the knot velocities and
accelerations ``[v_2, a_2, ..., v_{N-1}, a_{N-1}]`` (2N-4 per joint) and the
equations are the acceleration (28) and jerk (29), (33) continuity conditions
at every interior knot.  For 555 the unknowns are the same and the equations
are jerk and snap continuity between the quintics of eqs. (13)-(23).  For 434
(Ho & Cook) the unknowns are the interior knot velocities only and the
equations are acceleration continuity.

Instead of transcribing (28), (29) and (33) entry by entry, every equation is
built from the segment maps of :mod:`segments`: the derivative at the end of
segment ``k-1`` minus the same derivative at the start of segment ``k`` is a
linear form in the knot states of knots ``k-1, k, k+1``.  This reproduces the
paper's rows (the tests cross-check against an independent global system).
The matrix depends only on the durations, so it is assembled and factorised
once and every joint (and every right-hand side) is a column of the solve.
Rows are equilibrated (scaled by their largest entry) before the solve.
"""

from functools import lru_cache
from types import SimpleNamespace

import numpy as np
from scipy.linalg import LinAlgError, solve_banded
from scipy.linalg.lapack import dgbsv

from .methods import ACC, get_method, VEL
from .peaks import row_max
from .segments import (A_END, A_START, derivative_weights, DP, input_maps, INPUT_ORDER, V_END,
                       V_START)


def spline_coefficients(method, points, durations, boundary):
    """
    Return the ascending terms of the spline through ``points`` (N, n).

    ``durations`` (S,) gives (S, 6, n); a (B, S) batch of durations gives
    (B, S, 6, n).  ``boundary`` is (v_start, a_start, v_end, a_end).
    """
    system = ContinuitySystem(method, durations)
    points = np.asarray(points)
    dP = points[1:] - points[:-1]   # np.diff's values, without its wrapper
    vel, acc = system.solve(dP, *boundary)
    return system.coefficients(points[:-1], dP, vel, acc)


class ContinuitySystem:
    """
    The continuity equations of one method for one set of segment durations.

    ``solve(dP, v_start, a_start, v_end, a_end)`` returns the knot velocities and
    accelerations for any number of right-hand-side columns at once.

    ``durations`` may also be a (B, S) batch of duration vectors: the B
    independent systems are stacked block-diagonally into one banded matrix of
    the same bandwidth and solved at once (used for finite-difference
    Jacobians in optimal timing); results then have a leading batch axis.
    """

    def __init__(self, method, durations):
        """Assemble the banded matrix for ``method`` and the (S,) or (B, S) ``durations``."""
        self.definition = get_method(method)
        self.method = self.definition.name
        self.durations = np.asarray(durations, dtype=float)
        self.batched = self.durations.ndim == 2
        batch = np.atleast_2d(self.durations)
        self.n_batch, n_seg = batch.shape
        self.n_knots = n_seg + 1
        tiled = _tiled_segment_types(self.definition, n_seg, self.n_batch)
        flat = batch.reshape(-1)
        maps = input_maps(tiled, flat)
        self._maps = maps.reshape(self.n_batch, n_seg, *maps.shape[1:])
        self.maps = self._maps if self.batched else self._maps[0]
        derivatives = self.definition.continuous
        self._derivatives = np.array(derivatives)
        self._unknowns = self.definition.unknowns
        self._n_interior = self.n_knots - 2
        if self._n_interior == 0:
            return

        def forms(at_end):
            # Linear form of each continuous derivative in the segment inputs,
            # at the end or start of every segment: shape (n_q, B, S, 5).
            out = np.empty((len(derivatives), self.n_batch, n_seg, maps.shape[2]))
            for q, d in enumerate(derivatives):
                weights = (derivative_weights(flat, d, True) if at_end else
                           _start_weights(flat.size, d))
                out[q] = (weights[:, None, :] @ maps).reshape(self.n_batch, n_seg, -1)
            return out

        left = forms(True)[:, :, :-1]    # segment k-1, ending at interior knot k
        right = forms(False)[:, :, 1:]   # segment k, starting at interior knot k
        self._left, self._right = left, right
        # Coefficients of each equation (n_q, B, K) on the states of knots
        # k-1, k, k+1: shape (n_q, B, K, 3 knots, 2 components).
        coeff = np.zeros(left.shape[:3] + (3, 2))
        coeff[..., 0, VEL] = left[..., V_START]
        coeff[..., 0, ACC] = left[..., A_START]
        coeff[..., 1, VEL] = left[..., V_END] - right[..., V_START]
        coeff[..., 1, ACC] = left[..., A_END] - right[..., A_START]
        coeff[..., 2, VEL] = -right[..., V_END]
        coeff[..., 2, ACC] = -right[..., A_END]
        # The equation reads coeff . states + dp_left * dP_{k-1} + dp_right * dP_k = 0.
        self._dp_left = left[..., DP]
        self._dp_right = -right[..., DP]
        self._coeff = coeff
        self._assemble()

    def _assemble(self):
        n_q, n_b, n_int = self._coeff.shape[:3]
        pattern = _band_pattern(n_q, n_b, n_int, tuple(self._unknowns))
        vals = self._coeff.reshape(-1)[pattern.gather]
        # The largest |entry| of every row (the padding points at a 0).
        padded = np.zeros(vals.size + 1)
        np.abs(vals, out=padded[:-1])
        self._row_scale = 1.0 / row_max(padded[pattern.row_entries])
        self._bandwidth = pattern.bandwidth
        band = np.zeros((2 * pattern.bandwidth + 1) * pattern.size)
        band[pattern.band_index] = vals * self._row_scale[pattern.rows]
        self._band = band.reshape(2 * pattern.bandwidth + 1, pattern.size)

    @property
    def unknowns(self):
        """Return the unknowns per interior knot, in their order in the system."""
        return self._unknowns

    @property
    def banded(self):
        """Return (bandwidth, band): the assembled matrix in LAPACK's band storage."""
        return self._bandwidth, self._band

    def solve(self, dP, v_start, a_start, v_end, a_end):
        """
        Return knot velocities and accelerations, each of shape (N, m) or (B, N, m).

        ``dP`` has shape (S, m) (the same waypoints for every batch member); the
        boundary values have shape (m,).  Knot accelerations that are not
        unknowns of the method (434 interior knots) are returned as the
        acceleration the spline actually has there.
        """
        dP = np.asarray(dP, dtype=float)
        m = dP.shape[1]
        vel = np.zeros((self.n_batch, self.n_knots, m))
        acc = np.zeros((self.n_batch, self.n_knots, m))
        vel[:, 0], acc[:, 0], vel[:, -1], acc[:, -1] = v_start, a_start, v_end, a_end
        if self._n_interior > 0:
            # Right-hand side (n_q, B, K, m): waypoint terms and known boundary states.
            rhs = -(self._dp_left[..., None] * dP[None, None, :-1] +
                    self._dp_right[..., None] * dP[None, None, 1:])
            for comp, start, end in ((VEL, vel[0, 0], vel[0, -1]), (ACC, acc[0, 0], acc[0, -1])):
                rhs[:, :, 0] -= self._coeff[:, :, 0, 0, comp][..., None] * start
                rhs[:, :, -1] -= self._coeff[:, :, -1, 2, comp][..., None] * end
            rhs = rhs.transpose(1, 2, 0, 3).reshape(-1, m) * self._row_scale[:, None]
            try:
                x = banded_solve(self._bandwidth, self._band, rhs, overwrite_b=True)
            except LinAlgError:
                raise ValueError(f'the {self.method} continuity system is singular for these '
                                 'segment durations; change the durations') from None
            if not np.isfinite(x).all():
                raise ValueError(f'the {self.method} continuity system is numerically '
                                 'singular for these segment durations')
            x = x.reshape(self.n_batch, self._n_interior, len(self._unknowns), m)
            for ui, comp in enumerate(self._unknowns):
                (vel, acc)[comp][:, 1:-1] = x[:, :, ui]
            if ACC not in self._unknowns:
                inputs = self.segment_inputs(dP, vel, acc)[:, 1:]
                coeffs = self._maps[:, 1:] @ inputs
                acc[:, 1:-1] = 2.0 * coeffs[:, :, 2]
        if not self.batched:
            return vel[0], acc[0]
        return vel, acc

    def duration_derivatives(self, dP, vel, acc, segments, columns, n_columns):
        """
        Return knot-state derivatives with respect to segment durations (exact).

        For the solution ``vel, acc`` (N, m) of this (unbatched) system, the
        derivative of every knot velocity and acceleration with respect to the
        duration of each segment in ``segments`` is the solution of the same
        banded system with the derivative of the equations as right-hand side
        (the equations are homogeneous in each duration, see
        :mod:`segments`).  Segment ``segments[i]`` goes into right-hand-side
        column ``columns[i]``; several segments may share a column (their
        responses add up, which is exact as long as they do not overlap).
        Returns shape (N, 2, n_columns, m): axis 1 is velocity, acceleration;
        components that are not unknowns of the method are zero.
        """
        m = dP.shape[1]
        out = np.zeros((self.n_knots, 2, n_columns, m))
        K = self._n_interior
        if K == 0:
            return out
        segments = np.asarray(segments)
        columns = np.asarray(columns)
        T = self.durations
        inputs = self.segment_inputs(dP, vel, acc)           # (S, 5, m)
        order = INPUT_ORDER[None, :] - self._derivatives[:, None]   # (n_q, 5)
        rhs = np.zeros((len(self._derivatives), K, n_columns, m))
        # Segment s ends at interior knot s + 1 (equation s) when s < K ...
        ends = segments < K
        s = segments[ends]
        d_left = self._left[:, 0, s] * order[:, None, :] / T[s][None, :, None]
        rhs[:, s, columns[ends]] += np.einsum('qpi,pim->qpm', d_left, inputs[s])
        # ... and starts at interior knot s (equation s - 1) when s >= 1.
        starts = segments >= 1
        s = segments[starts]
        d_right = self._right[:, 0, s - 1] * order[:, None, :] / T[s][None, :, None]
        rhs[:, s - 1, columns[starts]] -= np.einsum('qpi,pim->qpm', d_right, inputs[s])
        rhs = rhs.transpose(1, 0, 2, 3).reshape(-1, n_columns * m) * self._row_scale[:, None]
        x = banded_solve(self._bandwidth, self._band, rhs, overwrite_b=True)
        x = -x.reshape(K, len(self._unknowns), n_columns, m)
        for ui, comp in enumerate(self._unknowns):
            out[1:-1, comp] = x[:, ui]
        return out

    @staticmethod
    def segment_inputs(dP, vel, acc):
        """Stack ``[dP, v_s, a_s, v_e, a_e]`` per segment: shape (..., S, 5, m)."""
        # Filled in place: np.stack's values and layout, without its overhead.
        dP, vel, acc = np.asarray(dP), np.asarray(vel), np.asarray(acc)
        shape = vel[..., 1:, :].shape
        out = np.empty(shape[:-1] + (5,) + shape[-1:], dtype=np.result_type(dP, vel, acc))
        out[..., 0, :] = dP
        out[..., 1, :] = vel[..., :-1, :]
        out[..., 2, :] = acc[..., :-1, :]
        out[..., 3, :] = vel[..., 1:, :]
        out[..., 4, :] = acc[..., 1:, :]
        return out

    def coefficients(self, starts, dP, vel, acc):
        """Return every segment's ascending polynomial terms (S, 6, m) or (B, S, 6, m)."""
        coeffs = self.maps @ self.segment_inputs(dP, vel, acc)
        coeffs[..., 0, :] = starts
        return coeffs


def banded_solve(bandwidth, band, rhs, overwrite_b=False):
    """
    Return ``solve_banded((bandwidth, bandwidth), band, rhs, check_finite=False)``, the same bits.

    For float ``band`` (2 bandwidth + 1, M) and ``rhs`` (M,) or (M, K) with
    ``bandwidth`` > 1, M > 1 and a non-empty ``rhs``, LAPACK's gbsv is called
    directly with the arguments scipy gives it: scipy's validation and batch
    wrapper cost more than the solve of the small systems of
    :mod:`inner_knots` and optimal timing.  Everything else goes to scipy.
    Raises LinAlgError for a singular matrix, as scipy does.
    """
    if (bandwidth < 2 or band.shape[1] < 2 or rhs.size == 0 or band.dtype != np.float64 or
            rhs.dtype != np.float64 or band.shape[0] != 2 * bandwidth + 1 or
            rhs.ndim > 2 or rhs.shape[0] != band.shape[1]):
        return solve_banded((bandwidth, bandwidth), band, rhs, overwrite_b=overwrite_b,
                            check_finite=False)
    # gbsv needs room for the fill-in of its LU factors above the band.
    work = np.zeros((3 * bandwidth + 1, band.shape[1]))
    work[bandwidth:] = band
    _, _, x, info = dgbsv(bandwidth, bandwidth, work, rhs, overwrite_ab=True,
                          overwrite_b=overwrite_b)
    if info > 0:
        raise LinAlgError('singular matrix')
    if info < 0:
        raise ValueError(f'illegal value in {-info}-th argument of internal gbsv')
    return x


@lru_cache(maxsize=64)
def _tiled_segment_types(definition, n_seg, n_batch):
    """
    Return the types of ``n_seg`` segments of ``definition``, tiled ``n_batch`` times.

    One type (an int) when every segment has it (every 555 spline's): then
    :func:`segments.input_maps` need not compare them.
    """
    types = definition.segment_types(n_seg)
    if np.all(types == types[0]):
        return int(types[0])
    tiled = np.tile(types, n_batch)
    tiled.flags.writeable = False   # shared by later systems
    return tiled


@lru_cache(maxsize=64)
def _start_weights(n_seg, derivative):
    """Return ``derivative_weights`` at the start of ``n_seg`` segments (read-only)."""
    weights = derivative_weights(np.ones(n_seg), derivative, False)
    weights.flags.writeable = False
    return weights


# Index patterns of the banded matrix kept for reuse (see _band_pattern).
PATTERN_CACHE = 16


@lru_cache(maxsize=PATTERN_CACHE)
def _band_pattern(n_q, n_b, n_int, unknowns):
    """
    Where the equations' coefficients go in the banded matrix: a function of the sizes only.

    For ``n_q`` continuous derivatives, ``n_b`` stacked systems of ``n_int``
    interior knots and the method's ``unknowns``: ``gather`` picks every
    entry's coefficient from the flattened (n_q, B, K, 3, 2) coefficients,
    ``rows`` is its equation, ``band_index`` its place in the flattened
    (2 bandwidth + 1, size) band, and ``row_entries`` (size, most entries in
    a row) lists the entries of every row, padded with the index one past
    the last entry.  Inner knots (:mod:`inner_knots`) solve many systems of
    the same size one after another, and the indices cost more to build than
    the values; cached, the assembly is the same, bit for bit.
    """
    n_u = len(unknowns)
    knot = np.tile(np.arange(1, n_int + 1), n_b)        # interior knot of each equation
    first = np.repeat(np.arange(n_b) * n_int, n_int)    # its system's first unknown knot
    flat = np.arange(n_q * n_b * n_int * 3 * 2).reshape(n_q, n_b, n_int, 3, 2)
    rows, cols, gather = [], [], []
    for q in range(n_q):
        for offset in range(3):
            other = knot - 1 + offset
            interior = (other >= 1) & (other <= n_int)
            for ui, comp in enumerate(unknowns):
                rows.append(((first + knot - 1) * n_q + q)[interior])
                cols.append(((first + other - 1) * n_u + ui)[interior])
                gather.append(flat[q, :, :, offset, comp].reshape(-1)[interior])
    rows = np.concatenate(rows)
    cols = np.concatenate(cols)
    size = n_b * n_int * n_q
    bandwidth = 2 * n_q - 1
    order = np.argsort(rows, kind='stable')
    per_row = np.bincount(rows, minlength=size)
    row_entries = np.full((size, int(per_row.max())), rows.size)
    place = np.arange(rows.size) - np.repeat(np.cumsum(per_row) - per_row, per_row)
    row_entries[rows[order], place] = order
    pattern = SimpleNamespace(rows=rows, gather=np.concatenate(gather), row_entries=row_entries,
                              band_index=(bandwidth + rows - cols) * size + cols)
    for index in vars(pattern).values():
        index.flags.writeable = False   # shared by every later system of these sizes
    pattern.size, pattern.bandwidth = size, bandwidth
    return pattern
