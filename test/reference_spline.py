"""
Independent formulations used to cross-check the planning core (test helpers only).

* ``global_coefficients``: one dense linear system over *all* polynomial
  coefficients of one joint (6 per segment), written from the method's
  definition (degrees, waypoints, boundary values, continuity), not from the
  paper's reduced banded system (nor from the core's method definitions).
* ``exact_peaks``: per-segment peaks with ``numpy.roots`` on each segment.
* ``random_limits``: limits and boundary values of a random request (the
  ranges every property test of the planning core draws from).
"""

from math import factorial

import numpy as np


def _row(T, derivative, at_end):
    """Weights of the 6 ascending coefficients giving the derivative at 0 or T."""
    row = np.zeros(6)
    for i in range(derivative, 6):
        tau = T if at_end else 0.0
        row[i] = factorial(i) / factorial(i - derivative) * tau ** (i - derivative)
    return row


# Derivatives continuous at interior knots, from each method's published definition.
CONTINUOUS = {'445': (1, 2, 3), '434': (1, 2), '555': (1, 2, 3, 4)}


def degrees(method, n_segments):
    """Polynomial degree of every segment for the method's definition."""
    if n_segments == 1 or method == '555':
        return [5] * n_segments
    if method == '445':
        return [4] * (n_segments - 1) + [5]
    return [4] + [3] * (n_segments - 2) + [4]


def global_coefficients(method, points, durations, v0, a0, ve, ae):
    """Ascending coefficients (S, 6) of one joint from the dense global system."""
    S = len(durations)
    rows, rhs = [], []

    def add(segment, weights, value):
        r = np.zeros(6 * S)
        r[6 * segment:6 * segment + 6] = weights
        rows.append(r)
        rhs.append(value)

    for s, (T, deg) in enumerate(zip(durations, degrees(method, S))):
        for power in range(deg + 1, 6):
            w = np.zeros(6)
            w[power] = 1.0
            add(s, w, 0.0)
        add(s, _row(T, 0, False), points[s])
        add(s, _row(T, 0, True), points[s + 1])
    add(0, _row(durations[0], 1, False), v0)
    add(0, _row(durations[0], 2, False), a0)
    add(S - 1, _row(durations[-1], 1, True), ve)
    add(S - 1, _row(durations[-1], 2, True), ae)
    for s in range(S - 1):
        for d in CONTINUOUS[method]:
            r = np.zeros(6 * S)
            r[6 * s:6 * s + 6] = _row(durations[s], d, True)
            r[6 * (s + 1):6 * (s + 1) + 6] = -_row(durations[s + 1], d, False)
            rows.append(r)
            rhs.append(0.0)
    A = np.array(rows)
    assert A.shape == (6 * S, 6 * S), A.shape
    return np.linalg.solve(A, np.array(rhs)).reshape(S, 6)


def exact_peaks(ppoly, derivative):
    """Max |d-th derivative| per segment and joint (S, n) with numpy.roots per segment."""
    dpp = ppoly.derivative(derivative)
    ddpp = ppoly.derivative(derivative + 1)
    x = ppoly.x
    S = len(x) - 1
    n = ppoly.c.shape[2]
    out = np.zeros((S, n))
    for s in range(S):
        T = x[s + 1] - x[s]
        for j in range(n):
            cand = [0.0, T]
            poly = np.trim_zeros(ddpp.c[:, s, j], 'f')
            for r in np.roots(poly) if poly.size > 1 else []:
                if abs(r.imag) < 1e-9 * max(1.0, abs(r)) and 0.0 < r.real < T:
                    cand.append(r.real)
            out[s, j] = max(abs(np.polyval(dpp.c[:, s, j], c)) for c in cand)
    return out


def random_limits(rng, n_joints, boundary_fraction):
    """
    Random (vmax, amax, jmax or None, boundary) for ``n_joints`` joints.

    The boundary values (v_start, a_start, v_end, a_end) are uniform up to
    ``boundary_fraction`` of the velocity and acceleration limits.
    """
    vmax = rng.uniform(0.5, 3.0, n_joints)
    amax = rng.uniform(1.0, 20.0, n_joints)
    jmax = rng.uniform(5.0, 200.0, n_joints) if rng.random() < 0.5 else None
    boundary = [boundary_fraction * rng.uniform(-1, 1, n_joints) * lim
                for lim in (vmax, amax, vmax, amax)]
    return vmax, amax, jmax, boundary
