"""
The fastest speed profile along a path under third-order constraints, by sequential LPs (issue 38).

:mod:`path_velocity` finds the fastest profile under first- and
second-order constraints; its acceleration jumps, and the C4 spline that
follows it overshoots there.  Here the jerk (:class:`constraints.
JointJerk`) is a constraint of the profile itself.  On the grid ``s_0 <
... < s_M`` of a rest-to-rest path, with ``x_i = sdot**2`` and the path
acceleration ``u_i = (x_{i+1} - x_i) / (2 ds_i)`` on step ``i``:

* first order: ``0 <= x_i <= x_max_i``, where ``x_max`` is the fastest
  second-order profile (:meth:`path_velocity.PathLimits.profile`): every
  profile that also holds the jerk lies below it;
* second order: ``lo <= a u + b x <= hi`` at both ends of every step with
  that step's ``u`` (TOPP-RA's "interpolation" discretisation);
* third order, at every inner grid point, with ``u`` the mean of its two
  steps' and ``du/ds`` their difference over the mean step::

      |sqrt(x_i) (c_x x_i + c_u u + c_du du/ds)| <= bound_i

  nonlinear through ``sqrt(x_i)`` only.  Under an upper bound
  ``x_i <= xbar_i`` the row ``|c_x x_i + c_u u + c_du du/ds| <= bound_i /
  sqrt(xbar_i)`` is linear and conservative: the jerk term linearised and
  kept conservative, as Lee, Bylard & Sentis (2024) do for third-order
  TOPP.

Sequential LPs (:meth:`ThirdOrderProfile.profile`): the first bound is
``xbar = x_max``; each next is ``min(x_max, gamma_k x)`` of the last
profile ``x``, for the decreasing growth factors :data:`GROWTH` (and
at least ``(gamma_k - 1)`` :data:`RESTART_SHARE` ``x_max``, so that a
point where an LP stopped may move again).  Every profile an LP returns
holds every limit on the grid; should one fail, the last is kept.  The
objective is the traversal time
``sum 2 ds_i / (sqrt(x_i) + sqrt(x_{i+1}))`` linearised at ``xbar``:
maximise ``sum w_i x_i`` with ``w_i = ds_i / xbar_i**1.5``, its negative
gradient up to a factor.  scipy's HiGHS solves them.
"""

import numpy as np
from scipy.optimize import linprog
import scipy.sparse as sp

# Growth factors of the bound xbar over the last profile, one per LP: large
# first (the first profile is held down by the jerk bound at x_max), then
# closing in on the conservative linearisation's fixed point: with gamma
# the jerk rows are conservative by at most sqrt(gamma).
GROWTH = (4.0, 1.5, 1.1, 1.02)
# The bound never falls below (gamma - 1) times this share of x_max.
RESTART_SHARE = 0.1
# Weights of the objective are taken at xbar, at least this share of its
# largest value (xbar is 0 at a rest end).
MIN_WEIGHT_SHARE = 1e-6


class ThirdOrderProfile:
    """
    The LPs of one gridded path: its second-order rows and third-order terms, prepared once.

    ``path`` is a :class:`constraints.GriddedPath` with ``third``;
    ``constraints`` its constraint objects of order 2 (rows) and 3 (terms);
    order 1 comes with the ``x_max`` of every call.
    """

    def __init__(self, path, constraints):
        """Assemble the constraint matrices in ``x`` (M + 1 unknowns)."""
        steps = path.steps
        m = steps.size
        self.steps = steps
        # u = D x (M steps).
        d = sp.diags([-0.5 / steps, 0.5 / steps], [0, 1], shape=(m, m + 1), format='csr')
        blocks, self._second_bounds = [], []
        jerk, self._jerk_bounds = [], []
        inner = np.arange(1, m)
        mean_step = 0.5 * (steps[:-1] + steps[1:])
        at_inner = sp.csr_matrix((np.ones(m - 1), (np.arange(m - 1), inner)),
                                 shape=(m - 1, m + 1))
        mean_u = 0.5 * (d[:-1] + d[1:])
        du_ds = sp.diags(1.0 / mean_step) @ (d[1:] - d[:-1])
        for constraint in constraints:
            if constraint.order == 2:
                a, b, lo, hi = (np.asarray(part, float) for part in constraint.rows(path))
                for end in (0, 1):      # the step's start and its end
                    points = np.arange(m) + end
                    for k in range(a.shape[1]):
                        row = (sp.diags(a[points, k]) @ d + sp.csr_matrix(
                            (b[points, k], (np.arange(m), points)), shape=(m, m + 1)))
                        blocks += [row, -row]
                        self._second_bounds += [(hi[points, k], end), (-lo[points, k], end)]
            elif constraint.order == 3:
                c_x, c_u, c_du, bound = (np.asarray(part, float)
                                         for part in constraint.terms(path))
                for k in range(c_x.shape[1]):
                    row = (sp.diags(c_x[inner, k]) @ at_inner + sp.diags(c_u[inner, k]) @ mean_u
                           + sp.diags(c_du[inner, k]) @ du_ds)
                    jerk += [row, -row]
                    self._jerk_bounds += [bound[inner, k]] * 2
        self._matrix = sp.vstack(blocks + jerk, format='csr')
        # Each grid point's share of the path (half a step at either end).
        self._weights = np.concatenate([[0.5 * steps[0]], mean_step, [0.5 * steps[-1]]])

    def profile(self, scale, x_max):
        """
        Return the squared path speed ``x`` (M + 1,) at rest at both ends, or None.

        ``scale`` (M + 1,) is the local limit factor (second-order bounds
        times ``scale**2``, third-order times ``scale**3``); ``x_max`` the
        fastest second-order profile under it.  None when an LP fails.
        """
        m = self.steps.size
        square, cube = scale * scale, scale ** 3
        second = np.concatenate([bound * square[np.arange(m) + end]
                                 for bound, end in self._second_bounds]) \
            if self._second_bounds else np.zeros(0)
        jerk = np.concatenate(self._jerk_bounds) if self._jerk_bounds else np.zeros(0)
        cube_inner = np.tile(cube[1:-1], len(self._jerk_bounds))
        x = None
        bar = np.array(x_max, float)
        for growth in GROWTH:
            if x is not None:
                # Grown from the last profile, and never below a share of
                # x_max: a point the last LP stopped at may move again.
                bar = np.minimum(x_max, np.maximum(growth * x, (growth - 1.0) * RESTART_SHARE
                                                   * x_max))
            root = np.tile(np.sqrt(bar[1:-1]), len(self._jerk_bounds))
            with np.errstate(divide='ignore'):
                rhs = np.concatenate([second, jerk * cube_inner / root])
            keep = np.isfinite(rhs)
            weights = self._weights / np.maximum(bar, MIN_WEIGHT_SHARE * np.max(bar)) ** 1.5
            bounds = np.column_stack([np.zeros(m + 1), bar])
            bounds[[0, -1], 1] = 0.0
            result = linprog(-weights, A_ub=self._matrix[keep], b_ub=rhs[keep], bounds=bounds,
                             method='highs')
            if result.status != 0:
                return x
            x = np.clip(result.x, 0.0, bar)
        return x
