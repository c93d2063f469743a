"""
The dense simplex of optimal timing's small LPs against HiGHS on the same LP written out here.

The LP (:mod:`dense_lp`): minimise ``c x + penalty * sum(e)`` subject to
``A x - e <= b`` on the violated rows (``b < 0``), ``A x <= b`` on the
others, ``lower <= x <= upper`` and ``e >= 0``.  Here it is written with
explicit elastic variables and solved by scipy's HiGHS; the simplex must
reach the same optimal value, with a feasible point.
"""

from example_counts import examples
from hypothesis import given, settings, strategies as st
import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp
from splines445_ros.planning.durations.dense_lp import solve_elastic_lp


def highs_value(c, A, b, lower, upper, penalty):
    """Return the optimal value of the LP, one elastic variable per violated row, by HiGHS."""
    violated = np.flatnonzero(b < 0.0)
    m, n = A.shape
    matrix = np.zeros((m, n + violated.size))
    matrix[:, :n] = A
    matrix[violated, n + np.arange(violated.size)] = -1.0
    cost = np.concatenate([c, np.full(violated.size, penalty)])
    bounds = Bounds(np.concatenate([lower, np.zeros(violated.size)]),
                    np.concatenate([upper, np.full(violated.size, np.inf)]))
    constraints = LinearConstraint(matrix, -np.inf, b) if m else ()
    result = milp(cost, constraints=constraints, bounds=bounds)
    assert result.status == 0
    return result.fun


def elastic_value(c, A, b, x, penalty):
    """Return the objective of ``x`` with every elastic variable at its least value."""
    violated = b < 0.0
    return float(c @ x + penalty * np.sum(np.maximum(A[violated] @ x - b[violated], 0.0)))


@st.composite
def lps(draw):
    """Trust-region LPs like optimal timing's: durations as costs, sparse rows, a box."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(1, 12))
    m = draw(st.integers(0, 80))
    c = rng.uniform(0.05, 5.0, n)
    if draw(st.booleans()):
        c[rng.uniform(size=n) < 0.3] = 0.0     # degenerate costs
    A = rng.normal(size=(m, n)) * (rng.uniform(size=(m, n)) < 0.5)
    if m > 1 and draw(st.booleans()):
        A[m // 2:] = A[:m - m // 2]            # repeated rows: degenerate vertices
    b = rng.normal(scale=0.1, size=m)
    radius = rng.uniform(1e-4, 0.2)
    lower = -np.minimum(radius, rng.uniform(0.0, 1.0, n)) if draw(st.booleans()) \
        else np.zeros(n)
    upper = np.full(n, radius)
    penalty = 10.0 * float(np.max(c, initial=1.0)) * rng.uniform(0.5, 2.0)
    return c, A, b, lower, upper, penalty


@settings(max_examples=examples(300), deadline=None)
@given(lp=lps())
def test_the_dense_simplex_reaches_highs_optimum_with_a_feasible_point(lp):
    c, A, b, lower, upper, penalty = lp
    x = solve_elastic_lp(c, A, b, lower, upper, penalty)
    assert x is not None
    assert np.all(x >= lower - 1e-12) and np.all(x <= upper + 1e-12)
    kept = b >= 0.0
    assert np.all(A[kept] @ x <= b[kept] + 1e-9)
    best = highs_value(c, A, b, lower, upper, penalty)
    value = elastic_value(c, A, b, x, penalty)
    assert abs(value - best) <= 1e-9 * max(1.0, abs(best)) + 1e-9


def test_a_violated_row_that_no_step_can_mend_is_paid_for_not_refused():
    """The one row needs x >= 1 but the box allows 0.1: the LP moves to the box and pays."""
    x = solve_elastic_lp(np.array([1.0]), np.array([[-1.0]]), np.array([-1.0]),
                         np.array([-0.1]), np.array([0.1]), 10.0)
    assert x[0] == 0.1
