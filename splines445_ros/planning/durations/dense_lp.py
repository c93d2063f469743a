"""
A dense simplex for the small trust-region LPs of optimal timing (:mod:`optimal`).

A request of a few waypoints gives LPs of a few variables and a few dozen
rows.  HiGHS solves them in microseconds, but ``scipy.optimize.milp``
around it costs about 0.6 ms a call, which was a third of a 3 x 3 request's
planning time (issue 23: small requests planned slower than TOPP-RA).  This
module solves exactly the LP of :func:`optimal._lp_step`::

    minimise    c . x + penalty * sum(e)
    subject to  A x - e_V <= b,   lower <= x <= upper,   e >= 0

where ``e`` has one entry per violated row ``V = {i : b_i < 0}`` (the
elastic constraints) and ``lower <= 0 <= upper``.  Writing
``x = p - m`` with ``0 <= p <= upper`` and ``0 <= m <= -lower``, the point
``x = 0`` with ``e_i = -b_i`` is a basic feasible solution, so a primal
simplex (Dantzig's rule, Bland's rule after :data:`BLAND_AFTER` pivots
against cycling) starts there without a first phase.  The bounds are rows of
the tableau: the problems are small, and the pivots stay plain.
"""

import numpy as np

# Requests of at most this many segments solve their LPs here (optimal's
# LP step; sensitivity.PeakJacobian keeps their band dense): scipy's milp
# costs more a call around HiGHS than such an LP takes.
DENSE_LP_SEGMENTS = 12

# Pivots before Bland's rule replaces Dantzig's (no cycling), and most pivots.
BLAND_AFTER = 50
MAX_PIVOTS = 500
# Relative tolerances: reduced costs (of the largest cost) and pivot entries.
COST_TOLERANCE = 1e-12
PIVOT_TOLERANCE = 1e-11


def solve_elastic_lp(c, A, b, lower, upper, penalty):
    """
    Return the optimal ``x`` (S,) of the LP above, or None when the pivots run out.

    ``c`` (S,), ``A`` (m, S) dense, ``b`` (m,), ``lower`` <= 0 <= ``upper``
    (S,) finite, ``penalty`` > 0 the cost of each unit of violation.
    """
    c = np.asarray(c, float)
    A = np.asarray(A, float).reshape(-1, c.size)
    b = np.asarray(b, float)
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    m, n_x = A.shape
    violated = np.flatnonzero(b < 0.0)
    n_e = violated.size
    # Columns: p (S), m (S), e (V), row slacks (m), bound slacks of p and m (2 S).
    n_col = 2 * n_x + n_e + m + 2 * n_x
    n_row = m + 2 * n_x
    table = np.zeros((n_row, n_col + 1))
    table[:m, :n_x] = A
    table[:m, n_x:2 * n_x] = -A
    table[violated, 2 * n_x + np.arange(n_e)] = -1.0
    slack = 2 * n_x + n_e
    table[np.arange(m), slack + np.arange(m)] = 1.0
    table[:m, -1] = b
    bounds = m + np.arange(2 * n_x)
    table[bounds, np.arange(2 * n_x)] = 1.0
    table[bounds, slack + m + np.arange(2 * n_x)] = 1.0
    table[bounds, -1] = np.concatenate([upper, -lower])
    # A violated row is held by its elastic variable: the row times -1.
    table[violated] *= -1.0
    basis = slack + np.arange(n_row)
    basis[violated] = 2 * n_x + np.arange(n_e)
    cost = np.zeros(n_col)
    cost[:n_x], cost[n_x:2 * n_x] = c, -c
    cost[2 * n_x:slack] = penalty
    tolerance = COST_TOLERANCE * max(float(np.max(np.abs(cost))), 1.0)
    # The last row holds the reduced costs (and minus the objective), pivoted with the rest.
    table = np.vstack([table, np.append(cost, 0.0)])
    table[-1] -= cost[basis] @ table[:-1]
    # (The pivots use the arrays' own methods and no np.outer: numpy's
    # wrappers of the same reductions and product cost more than a pivot's
    # arithmetic on tables this small.)
    for pivots in range(MAX_PIVOTS):
        reduced = table[-1, :-1]
        if pivots < BLAND_AFTER:
            enter = int(reduced.argmin())
            if reduced[enter] >= -tolerance:
                break
        else:
            candidates = (reduced < -tolerance).nonzero()[0]
            if candidates.size == 0:
                break
            enter = int(candidates[0])
        column = table[:-1, enter]
        rows = (column > PIVOT_TOLERANCE * max(float(np.abs(column).max()), 1.0)).nonzero()[0]
        if rows.size == 0:
            return None     # unbounded: cannot happen with finite bounds
        ratios = table[rows, -1] / column[rows]
        least = ratios.min()
        ties = rows[ratios <= least + 1e-14 * max(abs(least), 1.0)]
        leave = int(ties[basis[ties].argmin()])
        table[leave] /= table[leave, enter]
        factors = table[:, enter].copy()
        factors[leave] = 0.0
        table -= factors[:, None] * table[leave][None, :]
        basis[leave] = enter
    else:
        return None
    values = np.zeros(n_col)
    values[basis] = table[:-1, -1]
    return values[:n_x] - values[n_x:2 * n_x]


__all__ = ['solve_elastic_lp']
