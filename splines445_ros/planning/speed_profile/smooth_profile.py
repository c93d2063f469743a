"""
A third-order speed profile that can be followed: ``x(s) = sdot**2`` smooth in ``s`` (issue 38).

:mod:`jerk_profile` bounds the jerk on a grid, but its ``x`` is piecewise
linear: the path acceleration ``u = x'/2`` jumps at every grid point and at
the rest ends, so ``q(s(t))`` sampled every 1 ms needs a slow-down of 1.3-4
to hold the jerk.  Here ``x`` is a C2 function of ``s`` and every row is
linear in its coefficients ``z``:

* ``x(s) = B(s) + sum_ends [alpha phi_{4/3}(r) + beta phi_{5/3}(r)]``,
  ``r`` the distance to the end.  ``B`` is a clamped cubic B-spline with a
  knot every :data:`KNOT_STEPS` grid steps; its first two and last two
  coefficients are 0, so ``B = B' = 0`` at both ends.
  ``phi_p(r) = r**p (1 - r/L)**3`` on ``r < L`` (``L`` =
  :data:`END_STEPS` grid steps), C2 at ``L``.
* Along the path ``q(s)``, with ``u = x'/2`` and ``du/ds = x''/2``::

      velocity      q' sqrt(x)
      acceleration  q' x'/2 + q'' x
      jerk          sqrt(x) (q' x''/2 + 3 q'' x'/2 + q''' x)

  The rows are ``0 <= x <= x_max`` (the fastest v/a profile of
  :mod:`path_velocity`, which holds the velocity; its stops at
  zero-inertia points lifted, :func:`_lift_isolated_stops`),
  ``|q' x'/2 + q'' x| <= a``, the rows ``lo <= a x'/2 + b x <= hi`` of any
  more constraint objects (:mod:`constraints`: the joint torque
  ``M q' u + (M q'' + C q') x + g``, linear in ``x`` and ``x'`` like the
  acceleration) and the jerk below.  They are applied at
  :data:`DENSE` points per grid step, :data:`END_DENSE` per step in the end
  regions, :data:`GEOMETRIC_POINTS` points ``L 2**-m`` from each end and on
  both sides of every waypoint (the natural cubic's ``q'''`` jumps there).
* Rest ends.  Near rest ``x ~ alpha s**(4/3)``, which is exactly a constant
  path jerk ``J`` from rest: ``s = J t**3/6`` gives
  ``x = (J**2/4) (6 s/J)**(4/3)``, so ``J = (2/9) alpha**1.5``.  The bound
  ``alpha <= (4.5 min_j j_j / |q'_j(end)|)**(2/3)`` holds the jerk at the
  end itself, and it is linear.  ``s**(5/3)`` lets the jerk change away
  from the end.  As ``x``, ``x'`` and ``x''`` are continuous, ``s(t)`` has
  continuous acceleration and jerk; the jerk of ``q(s(t))`` jumps only at
  the waypoints, with ``q'''``.
* The jerk rows, nonlinear through ``sqrt(x)``, written
  ``|L(z)| <= j / sqrt(x)``.  ``j / sqrt(x)`` is convex in ``x``, so its
  tangent at the last profile ``x_p`` lies below it for every ``x > 0``:
  ``|L(z)| + (j/2) x_p**-1.5 x(z) <= 1.5 j / sqrt(x_p)`` is conservative
  everywhere and exact at ``x_p``, with no trust region.  (jerk_profile's
  ``j / sqrt(xbar)`` rows need one, and converge in 15+ LPs instead of 3-5.)

Sequential LPs (HiGHS' dual simplex): each maximises the traversal time
``sum w x / x_p**1.5`` linearised at ``x_p`` (as jerk_profile), under
``x <= min(x_max, gamma x_p)`` for the factors :data:`GROWTH`, and stops
when the time improves by less than :data:`TOLERANCE`.  All rows (up to
~80 000, built once for all joints) enter only where violated (constraint
generation), but ``x <= cap`` about once a grid step; rows within
:data:`KEEP` of their bound are kept from one LP to the next, and the first
LP starts from the rows violated (by :data:`FIRST_KEEP`) at a least-squares
fit of ``x_max``.  With highspy (:class:`_WarmHighs`) one HiGHS model
serves all the LPs: a round's violated rows are appended and the simplex
goes on from its basis, and each new LP is passed with the last basis
(after the first, an LP takes tens of simplex iterations instead of
about 4 per unknown).  Without highspy (an apt ROS install) each round is a cold
``scipy.optimize.linprog(method='highs-ds')``: the same profile, to the
solver's tolerance (durations within 1e-9 on the bench's 72 paths).

With a ``vibration_frequency`` f and a rest end, up to :data:`RESIDUAL_LPS`
more LPs (each tried at up to three bounds, :data:`RESIDUAL_STEPS`, with
rounds of generated rows each: ``lps`` counts every HiGHS solve) also
bound the content ``Z_j`` of every joint's acceleration at the mode
(:mod:`residual_vibration`: the ringing it leaves after the stop).
``q_j'' = q_j' x'/2 + q_j'' x`` is linear in ``z``; the time law in the
phases ``exp(lambda (T - t))`` is the last profile's, so
``|Z_j| <= bound`` becomes :data:`RESIDUAL_DIRECTIONS` linear rows (a
polygon), dense over ``z``.  A fixed point, not a Newton step: its
profile lands within 1-3 times the bound, and a full linearisation of the
phases (tried) failed where this converges.  This is the profile doing
its own input shaping, at the price of a slower stop where the mode
needs it (a share of a period, not the 8 / f of ramps).

:class:`SmoothProfile` also gives the exact time law: ``t(s) = int ds /
sqrt(x)`` by Gauss-Legendre on the spline's pieces, with ``s = h tau**3``
on the first and last pieces (the integrand ``~ s**(-2/3)`` becomes
regular), and ``s(t)`` by Newton, safeguarded by bisection.

Measured (``benchmarks/bench_smooth_profile.py``, doc/benchmarks.md):
sampled every 1 ms, ``q(s(t))`` needs a uniform slow-down of 1.0004
median (1.0018 worst) on 76 paths of 8 arms, and it lasts 1.025 x TOPP-RA
(median) against plan()'s default 1.085.  It takes 0.05 s a path (median,
0.10-0.14 worst; seeds 2114261222, 2509197314, 3725442882) with highspy,
3.5-4.3 x less than linprog's cold solves (0.16-0.27 s), durations within
1e-9; plan()'s default takes 0.02 s.  ``plan(..., speed_profile=
'time_optimal')``, which solves it (:mod:`time_optimal`), took 0.07-0.11 s
a path median with highspy against 0.21-0.36 s (2.5-3.4 x).
"""

import numpy as np
from scipy.interpolate import BSpline, PPoly
from scipy.optimize import linprog, OptimizeResult
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

try:
    import highspy
    # A row's status in a HiGHS basis: basic (its slack in the basis, the row not binding).
    _BASIC = highspy.HighsBasisStatus.kBasic
    # HighsBasisStatus by its code (0 lower, 1 basic, 2 upper, 3 zero, 4 nonbasic).
    _STATUSES = sorted(highspy.HighsBasisStatus.__members__.values(), key=int)
except (ImportError, AttributeError):   # e.g. an apt ROS install: scipy's linprog instead
    highspy = None

from .path_velocity import PathLimits
from .residual_vibration import content_weights, static_scale
from ..constraints import GriddedPath, JointAcceleration, JointVelocity
from ..validation import positive_array

# The passes' profile counts as stopped below this share of its largest x (a
# stop at a zero-inertia point, _lift_isolated_stops; those seen were 1e-7 of it,
# the waypoints' rows 1e-9 of the path apart leave it little room to brake).
ISOLATED_STOP = 1e-5
# A B-spline knot every this many grid steps: 1 gained < 0.5 %, 3 lost 0.3-1 %.
KNOT_STEPS = 2
# Row points per grid step: 2 halved the solve time but lost 0.3-1 % in duration.
DENSE = 4
# Length of the end terms, in grid steps: 16 gained nothing measurable.
END_STEPS = 4
# Row points per grid step in the end regions, where x'' is largest.
END_DENSE = 12
# Points L 2**-m (m = 1 ..) from each end: the rows near rest, where x ~ s**(4/3).
GEOMETRIC_POINTS = 14
# Waypoints: rows this share of the path on each side (q''' one-sided).
WAYPOINT_OFFSET = 1e-9
# Growth of x <= gamma x_p per LP: large first, then closing in.
GROWTH = (4.0, 2.0, 1.5, 1.3, 1.2, 1.1, 1.05, 1.05)
# The bound x <= gamma x_p never falls below (gamma - 1) times this share of x_max.
RESTART_SHARE = 0.1
# Linearisation points and weights at least this share of the largest x (0 at rest).
MIN_WEIGHT_SHARE = 1e-6
# Stop when an LP shortens the linearised time by less than this share: 2e-4 took one
# LP more a path for durations within 0.03 %.
TOLERANCE = 3e-3
# Rows with lhs above this share of their bound stay in the next LP's working set: 0.8
# kept 3-5 times the binding rows, and each HiGHS solve's time grows with its rows.
KEEP = 0.95
# The first LP starts from the rows above this share of their bound at x_max's fit:
# 1.2-1.5 was 6-10 % faster than KEEP (fewer rows, a round more), same durations.
FIRST_KEEP = 1.2
# Constraint-generation rounds per LP (2-3 are usual).
MAX_ROUNDS = 40
# A generated row counts as violated above its bound by this share.
VIOLATION = 1e-9
# HiGHS dual simplex, Dantzig pricing: 1.2-1.3 x faster here than its default (steepest
# edge), same solutions; IPM was 1.5-2 x slower.
HIGHS_OPTIONS = {'simplex_dual_edge_weight_strategy': 'dantzig'}
# Warm-started HiGHS through highspy when it imports (the tests set it False for linprog's).
HIGHSPY = highspy is not None
# The same dual simplex through highspy, with no presolve: it would drop the basis.
HIGHSPY_OPTIONS = {'presolve': 'off', 'solver': 'simplex', 'simplex_strategy': 1,
                   'simplex_dual_edge_weight_strategy': 0}
# highspy's passModel: the matrix given by rows.
ROWWISE = 2
# A solve stops after this many simplex iterations per row and column of its model
# (a failed LP: the last feasible profile is kept).  The most measured was 0.5 (random
# requests, 100 x 7 and 200 x 7 with a mode); a request with a = 0.02 and 300 s
# segments (helper-20's fuzz) cycled for minutes in one solve.
ITERATIONS_PER_ROW = 10
# And after this many seconds (each solve; HiGHS' own limit counts all a model's runs):
# a badly scaled LP (matrix entries 1e-9 to 6e3, bounds to 2e10: jerk limits of 1e-4
# on 300 s segments) spent 7-84 s in one solve on as few as 600 iterations.  The
# longest solve measured on a request time_optimal takes was 1.9 s (200 x 7 with a
# 1.5 Hz mode: 90 solves, 42 s in all).  Only a solve that long can depend on the
# machine.
SOLVE_SECONDS = 10.0
# Exact time law: Gauss-Legendre nodes per piece, pieces per spline interval.
QUADRATURE_NODES = 16
QUADRATURE_SPLIT = 4
# Newton steps at most for s(t) (quadratic), and its stop: tau moved by less
# than this (1e-15 is below the quadrature's round-off, and every call ran all
# 30 steps; 1e-12 takes 3-4 from the Hermite guess, s within 1e-12 of a piece).
NEWTON_STEPS = 30
NEWTON_TOLERANCE = 1e-12
# End terms r**p: 4/3 is a constant path jerk from rest, 5/3 lets it change.
POWERS = (4.0 / 3.0, 5.0 / 3.0)
# vibration_frequency: the rows bound the mode's residual share (residual_vibration),
# never below this, with the phases of the last profile; the next profile lands within
# 1-3 times it (its own time law has moved by milliseconds), so it counts as cancelled
# at RESIDUAL_ACCEPTED, measured on itself.  0.02 / 0.1 left 0.05-0.07 of TOPP-RA's
# ringing at 4 Hz on 2 x 12 random requests; 0.05 left 0.03, but took a 2-waypoint
# move from 5.25 s to 6.39 s (0.1: 5.68 s; the default's windows 6.23 s, the same
# ringing).
RESIDUAL_BOUND = 0.02
RESIDUAL_ACCEPTED = 0.1
# Each of those LPs bounds the residual at the first of these shares of the last one's
# that is feasible (RESIDUAL_BOUND at least): its x stays within [RESIDUAL_FLOOR,
# GROWTH[-1]] times the last profile's, and a mode far below the stop's own content
# (1.5 Hz: shares of 3-5) cannot be cancelled in one LP.  The bound at once made those
# LPs infeasible, and HiGHS took 1.5-3.4 s to say so; 0.2 at 1.5 Hz: 1.059 x TOPP-RA,
# residual 0.13 of its (0.1: 1.087, 0.13; 0.3: 1.053, 0.21), at 4 Hz no change.  The
# looser ones: a torque-bound 2-link arm's short moves, where 0.2 was infeasible
# and 0.5 reached 0.05-0.39 from 0.7-0.9 (helper-18's review).
RESIDUAL_STEPS = (0.2, 0.5, 0.8)
# LPs at most with the residual rows, after the time's own have converged (the least
# residual of them is kept): 1-3 at 4-8 Hz.  8 rather than 4: the Panda's stops
# (j = 500 a, shares of 2-5) were left 0.07-0.34 instead of 0.31-0.75, a 1.5 Hz mode
# 0.06 of TOPP-RA's ringing instead of 0.13, for 30-50 % more planning there.
RESIDUAL_LPS = 8
# |Z| <= bound as this many half-planes, a regular polygon (|Z| within 1 / cos(pi / 8)).
RESIDUAL_DIRECTIONS = 8
# In those LPs x stays above this share of the last profile: the rows' phases are its
# time law's, and x = 0 at a point (a stop: a time that is not its own) would satisfy
# them (found at 1.5 Hz, where the profile then never ended).
RESIDUAL_FLOOR = 0.5
# Z is summed on the row points with each step cut into parts of at most this many
# a period of the mode (the trapezoid rule's phase error about 2 %; the row points
# are per segment, 10-50 ms apart on segments of seconds), and not at all when that
# takes more than MAX_MODE_POINTS points more: the plan reports what it rings.
MODE_POINTS = 16
MAX_MODE_POINTS = 20000


def _end_terms(r, length):
    """Return [phi_p, phi_p', phi_p''] (3, len(r)) for each power, 0 outside 0 < r < length."""
    inside = (r > 0.0) & (r < length)
    rr = np.where(inside, r, 0.5 * length)
    left = 1.0 - rr / length
    h, h1, h2 = left ** 3, -3.0 * left ** 2 / length, 6.0 * left / length ** 2
    terms = []
    for p in POWERS:
        g, g1, g2 = rr ** p, p * rr ** (p - 1.0), p * (p - 1.0) * rr ** (p - 2.0)
        values = np.array([g * h, g1 * h + g * h1, g2 * h + 2.0 * g1 * h1 + g * h2])
        terms.append(np.where(inside[None], values, 0.0))
    return terms


def _derivative_matrix(knots, degree, count):
    """Return the (count - 1, count) map from B-spline coefficients to their derivative's."""
    span = knots[degree + 1:degree + count] - knots[1:count]
    with np.errstate(divide='ignore', invalid='ignore'):
        factor = np.where(span > 0.0, degree / span, 0.0)
    return sp.diags([-factor, factor], [0, 1], shape=(count - 1, count), format='csr')


def _lift_isolated_stops(x):
    """
    Return the passes' profile ``x`` with each interior stop between moving points lifted.

    Where every joint's ``q'`` passes 0 at once (a joint reversing alone)
    the acceleration rows leave ``u`` free at one point: the forward pass
    jumps up there and must stop at the next point (TOPP's zero-inertia
    points).  Such a stop is the passes' artefact, and as the cap of the
    LPs it would make the profile stop there, which its C2 ``x`` cannot do
    in finite time.  The lower neighbour stands in for it (only a cap and
    a start: the LP's own rows hold the acceleration there).
    """
    x = np.array(x, float)
    stopped = np.concatenate([[0], x <= ISOLATED_STOP * np.max(x), [0]]).astype(int)
    edges = np.diff(stopped)
    # Runs [first, last] of stopped points; those between two moving ones are
    # lifted (the ends stay at rest).
    for first, last in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1):
        if first > 0 and last < x.size - 1:
            x[first:last + 1] = min(x[first - 1], x[last + 1])
    return x


def _per_joint(name, value, n_joints, allow_inf=False):
    """Return :func:`validation.positive_array` of ``value``, a scalar standing for every joint."""
    if np.ndim(value) == 0:
        value = np.full(n_joints, value, dtype=float)
    return positive_array(name, value, n_joints, allow_inf)


def _least_squares(matrix, target):
    """
    Return the least-squares ``z`` of ``matrix z = target`` (a sparse, banded design).

    By its normal equations (SuperLU), with a ridge of 1e-15 of their
    largest diagonal entry (an empty column gets 0): the free B-spline
    columns have a condition number of about 1e3, so the normal equations
    about 1e6, and this takes 0.4-1 ms where ``lsqr``'s iterations took
    2-4 ms (the same residuals).  Only the first LP's working set depends on it.
    """
    matrix = sp.csc_matrix(matrix)
    if matrix.shape[1] == 0:
        return np.zeros(0)
    normal = (matrix.T @ matrix).tocsc()
    ridge = 1e-15 * max(float(normal.diagonal().max()), np.finfo(float).tiny)
    return np.atleast_1d(spsolve(normal + ridge * sp.identity(normal.shape[0], format='csc'),
                                 matrix.T @ target))


def _tangent_rows(candidates, x, n_jerk):
    """
    Return the candidate rows with room for the jerk rows' tangent term, and its parts.

    The last ``n_jerk`` rows of ``candidates`` are the jerk's ``+-L(z)``;
    their tangent rows add ``c x(z)`` (``x`` repeated, a factor ``c`` a row,
    new every LP).  The CSR matrix returned has their union pattern, and
    the data of those rows, ``jerk_data + c[row] * x_data``, is set in place
    each LP (rather than a new matrix of ~80 000 rows).
    """
    if n_jerk == 0:         # no joint has a jerk limit
        return candidates.tocsr(), np.zeros(0), np.zeros(0), np.zeros(0, int)
    repeated = sp.vstack([x] * (n_jerk // x.shape[0]), format='csr')
    pattern, jerk_data, x_data, entry_row = _union_pattern(candidates[-n_jerk:], repeated)
    rows = sp.vstack([candidates[:-n_jerk], pattern], format='csr')
    return rows, jerk_data, x_data, entry_row


def _union_pattern(a, b):
    """
    Return ``a`` and ``b`` (sparse, one shape) on their union pattern: (CSR, a's, b's, rows).

    The CSR matrix holds ``a``'s values on the union of both patterns (its
    data to be rewritten in place), then the data of ``a`` and of ``b``
    there (an entry absent from one is an exact 0) and each entry's row.
    Both at once: the real and imaginary parts of one complex sum (an entry
    is left out only where both are 0).
    """
    both = (sp.csr_matrix(a).astype(complex) + 1j * b).tocsr()
    both.sort_indices()
    pattern = sp.csr_matrix((both.data.real.copy(), both.indices, both.indptr),
                            shape=both.shape)
    return (pattern, both.data.real.copy(), both.data.imag.copy(),
            np.repeat(np.arange(both.shape[0]), np.diff(both.indptr)))


def _checked(status, call):
    """
    Raise RuntimeError unless a highspy call returned ``kOk`` (or a warning).

    Its model would otherwise no longer hold the rows the profile thinks it
    holds (HiGHS refuses entries beyond its large-value bound, about 1e15:
    plans lasting milliseconds); RuntimeError is a failed profile, which
    plan() answers with the default construction.
    """
    if status == highspy.HighsStatus.kError:
        raise RuntimeError(f"HiGHS refused the profile's LP ({call})")


class _WarmHighs:
    """
    One HiGHS model for all the LPs of a profile, each solved from the last basis (highspy).

    Within an LP, :meth:`add` appends the violated rows and the dual simplex
    goes on from its optimal basis (the new rows enter basic, so it stays
    dual feasible).  A new LP (new cost, caps, jerk rows) is passed whole
    with the last basis: kept rows keep their status, new rows enter basic,
    and the rows nonbasic in it stay in the working set, so that the basis
    stays square.  (Changing the jerk rows' coefficients in place instead,
    one ``changeCoeff`` a nonzero, was 1.2 x slower.)
    """

    def __init__(self, bounds):
        """Open the model with the variable bounds (linprog's)."""
        self.highs = highspy.Highs()
        self.highs.silent()
        for name, value in HIGHSPY_OPTIONS.items():
            self.highs.setOptionValue(name, value)
        self.lower = np.array([-np.inf if lo is None else lo for lo, _ in bounds])
        self.upper = np.array([np.inf if hi is None else hi for _, hi in bounds])
        self.model = None       # the candidate row of each model row, in the model's order
        self.rows = self.bound = None

    def start(self, cost, rows, bound, work):
        """Pass a new LP: its cost, all candidate rows ``A z <= b``, the working ones."""
        self.rows, self.bound = rows, bound
        keep = np.flatnonzero(work)
        basis = None if self.model is None else self.highs.getBasis()
        if basis is not None and basis.valid:
            # Each candidate row's last status (basic if it was not in the model).
            status = np.full(rows.shape[0], int(_BASIC))
            status[self.model] = np.fromiter(map(int, basis.row_status), int, self.model.size)
            keep = np.flatnonzero(work | (status != int(_BASIC)))
        block = rows[keep]
        self.model = None       # until the model holds these rows
        _checked(self.highs.passModel(
            cost.size, keep.size, block.nnz, ROWWISE, 1, 0.0, cost, self.lower, self.upper,
            np.full(keep.size, -np.inf), bound[keep], block.indptr[:-1].astype(np.int32),
            block.indices.astype(np.int32), block.data, np.zeros(cost.size, np.int32)),
            'passModel')
        if basis is not None and basis.valid:
            warm = highspy.HighsBasis()
            warm.col_status = basis.col_status
            warm.row_status = [_STATUSES[code] for code in status[keep].tolist()]
            warm.valid = True
            _checked(self.highs.setBasis(warm), 'setBasis')
        self.model = keep

    def add(self, new):
        """Append the candidate rows ``new`` (indices) to the model."""
        block = self.rows[new]
        _checked(self.highs.addRows(new.size, np.full(new.size, -np.inf), self.bound[new],
                                    block.nnz, block.indptr[:-1].astype(np.int32),
                                    block.indices.astype(np.int32), block.data), 'addRows')
        self.model = np.concatenate([self.model, new])

    def run(self):
        """
        Solve from the current basis: linprog's result fields.

        A run without an optimum clears the basis (the next LP starts from
        none) and is not run again cold: on 150 fuzz requests (helper-20's
        generator, seeds 1000-1149) none of 36 cold runs after "Unknown" found
        one, and they took 31 of the 100 s; one took 84 s to end as the warm
        run had, where a badly scaled LP crawls through phase 1.  Plans were
        the same without them (and none of 58 cold runs after a proven
        infeasibility, on 90 random plans, was optimal either).
        """
        self.highs.setOptionValue('simplex_iteration_limit', ITERATIONS_PER_ROW * (
            self.highs.getNumRow() + self.highs.getNumCol()))
        # HiGHS' time limit counts the model's run time over all its runs so far.
        self.highs.setOptionValue('time_limit', self.highs.getRunTime() + SOLVE_SECONDS)
        self.highs.run()
        status = self.highs.getModelStatus()
        if status == highspy.HighsModelStatus.kOptimal:
            return OptimizeResult(status=0, x=np.array(self.highs.getSolution().col_value),
                                  message='')
        self.highs.clearSolver()
        return OptimizeResult(status=2, x=None, message=self.highs.modelStatusToString(status))


class _SpeedRows:
    """
    The rows with a ``c sdot`` term, stacked once below the others and linearised in place each LP.

    ``speed``: :meth:`SmoothProfile._constraint_rows`' third return (per
    row block its rows without the term, their points, ``+-c`` and the
    bound).  ``c sqrt(x)`` by its tangent at ``x_q``: ``c x / (2 sqrt(x_q))
    + c sqrt(x_q) / 2``, exact at ``x_q`` (above ``c sqrt(x)`` elsewhere for
    ``c > 0``: the damping that brakes, conservative; below it for ``c < 0``,
    where it helps).  ``x_q`` is capped at ``(bound / |c|)**2`` at a row
    (the tangent is then taken there, not at the profile), so the row still
    allows rest where its bound is positive (the tangent's constant at most
    half the bound).  The plan's own torque is checked after, damping in
    full.  Each block's rows are held on the union pattern of its rows and
    of ``x`` at its points (like the jerk rows, :func:`_tangent_rows`), and
    each LP writes ``base + k x`` into the data: stacking them anew took
    about 10 ms an LP on a 7-joint path (helper-86), a fifth of a damped
    arm's profile.  The values are those of the sparse sum, bit for bit
    (an entry absent from one part adds an exact 0).
    """

    def __init__(self, speed, x, rows):
        """Stack ``rows`` (CSR) and the blocks' union patterns; keep each block's parts."""
        self._blocks = []
        data, indices, indptr = [rows.data], [rows.indices], [rows.indptr]
        count, start = rows.shape[0], rows.nnz
        for base, at, c, limit in speed:
            pattern, base_data, x_data, entry_row = _union_pattern(base, x[at])
            with np.errstate(over='ignore'):   # c = 0 at a row: no cap there
                room = np.where(limit > 0.0, (limit / np.maximum(np.abs(c), 1e-300)) ** 2,
                                np.inf)
            self._blocks.append((base_data, x_data, entry_row, at, c, limit, room, start,
                                 start + pattern.nnz))
            data.append(pattern.data)
            indices.append(pattern.indices)
            indptr.append(pattern.indptr[1:] + start)
            count += at.size
            start += pattern.nnz
        self.matrix = sp.csr_matrix((np.concatenate(data), np.concatenate(indices),
                                     np.concatenate(indptr)), shape=(count, rows.shape[1]))
        self._others = rows.nnz
        self.bound = np.empty(count)

    def stacked(self, x_q, rows, bound):
        """Return the rows and bounds of an LP: ``rows``' and the blocks' linearised at ``x_q``."""
        data = self.matrix.data
        data[:self._others] = rows.data
        self.bound[:bound.size] = bound
        at_row = bound.size
        for base, x_data, entry_row, at, c, limit, room, start, stop in self._blocks:
            root = np.sqrt(np.minimum(x_q[at], room))
            data[start:stop] = base + (0.5 * c / root)[entry_row] * x_data
            self.bound[at_row:at_row + at.size] = limit - 0.5 * c * root
            at_row += at.size
        return self.matrix, self.bound


class _WithoutSpeedTerm:
    """A second-order constraint's rows without their term in the path speed (``c sdot``)."""

    order = 2

    def __init__(self, constraint):
        """Wrap ``constraint`` (``rows`` hold the term as ``c x``, ``speed_terms`` give ``c``)."""
        self.constraint = constraint
        self.interpolated = constraint.interpolated

    def rows(self, path):
        """Return the constraint's rows with ``b - c`` (as they are without a speed term)."""
        a, b, lo, hi = self.constraint.rows(path)
        terms = getattr(self.constraint, 'speed_terms', None)
        c = None if terms is None else terms(path)
        return a, (b if c is None else b - c), lo, hi


class SmoothProfile:
    """
    ``x(s) = sdot**2`` along ``path``, C2 in ``s``, at rest or moving at each end; see the module.

    ``path`` is a scipy ``PPoly`` ``q(s)`` (n joints) and ``grid`` its
    increasing grid from ``path.x[0]`` to ``path.x[-1]`` (e.g. 24 steps a
    segment); ``velocity``, ``acceleration``, ``jerk`` the joint limits
    (n,) or scalars (a jerk of inf: no jerk rows for that joint);
    ``constraints`` more :mod:`constraints` objects,
    first order (``x`` at most their squared speed) or second order (rows
    ``lo <= a u + b x <= hi`` with ``u = x'/2``: the joint torque, the tool
    acceleration), applied at the same row points; ``ends`` the squared
    path speeds at the start and the end (0: at rest, the end terms; a
    moving end has ``x = x_e`` and ``x' = 0``, the path carrying the
    boundary velocity and acceleration in its own time);
    ``vibration_frequency`` [Hz] (0: none): with a rest end, the profile
    also cancels the ringing of a lightly damped mode at it after the stop
    (:mod:`residual_vibration`; :meth:`_cancel_residual`).  Solved on
    construction; raises ValueError on bad input (a constraint's own, such
    as :class:`constraints.GravityOverload`) and RuntimeError when the
    first LP fails.

    Attributes: ``knots``, ``coefficients`` (the B-spline's),
    ``end_coefficients`` ((alpha, beta) at the start, at the end),
    ``end_lengths`` (L at each end), ``duration``, ``lps`` (HiGHS solves),
    ``residual`` (the mode's residual share on the profile's own time law,
    None without one, nan when the mode is too fast to cancel).
    """

    def __init__(self, path, grid, velocity, acceleration, jerk, constraints=(), ends=(0.0, 0.0),
                 vibration_frequency=0.0):
        """Check the input, solve the LPs and prepare the time law."""
        if not isinstance(path, PPoly):
            raise ValueError(f'path must be a scipy PPoly, got {type(path).__name__}')
        grid = np.asarray(grid, float)
        if grid.ndim != 1 or grid.size < 2 * END_STEPS + 1:
            raise ValueError(f'grid must be 1-D with at least {2 * END_STEPS} steps')
        if not np.all(np.diff(grid) > 0.0):
            raise ValueError('grid must be strictly increasing')
        if not np.allclose(grid[[0, -1]], path.x[[0, -1]], rtol=0.0,
                           atol=1e-12 * (path.x[-1] - path.x[0])):
            raise ValueError(f'grid must span the path [{path.x[0]}, {path.x[-1]}], '
                             f'got [{grid[0]}, {grid[-1]}]')
        points = np.atleast_2d(path(grid).T).T
        n_joints = points.shape[1]
        if not np.any(np.abs(points - points[0]) > 0.0):
            raise ValueError('the path does not move: no profile to plan')
        self.path = path
        self.velocity = _per_joint('velocity', velocity, n_joints)
        self.acceleration = _per_joint('acceleration', acceleration, n_joints)
        self.jerk = _per_joint('jerk', jerk, n_joints, allow_inf=True)
        self.constraints = tuple(constraints)
        self.ends = tuple(float(e) for e in ends)
        if len(self.ends) != 2 or not all(np.isfinite(e) and e >= 0.0 for e in self.ends):
            raise ValueError(f'ends must be two squared path speeds >= 0, got {ends}')
        self.vibration_frequency = float(vibration_frequency)
        if not (np.isfinite(self.vibration_frequency) and self.vibration_frequency >= 0.0):
            raise ValueError(f'vibration_frequency must be finite and >= 0 [Hz], got '
                             f'{vibration_frequency}')
        self.residual = None
        if any(c.order not in (1, 2) for c in self.constraints):
            raise ValueError('constraints must be first or second order (planning.constraints)')
        self.start, self.end = grid[0], grid[-1]
        steps = np.diff(grid)
        self.end_lengths = (grid[END_STEPS] - grid[0], grid[-1] - grid[-1 - END_STEPS])
        knots = grid[::KNOT_STEPS]
        if knots[-1] != grid[-1]:
            # The last knot interval: merged when under half a knot spacing.
            short = grid.size - 1 - (knots.size - 1) * KNOT_STEPS < KNOT_STEPS / 2
            knots = np.concatenate([knots[:-1] if short else knots, grid[-1:]])
        self.knots = np.concatenate([[grid[0]] * 3, knots, [grid[-1]] * 3])
        self._count = self.knots.size - 4
        self.lps = 0
        z = self._solve(grid, steps)
        self.coefficients = z[:self._count]
        self.end_coefficients = (tuple(z[self._count:self._count + 2]),
                                 tuple(z[self._count + 2:]))
        self._prepare_time_law()

    # The problem.

    def _design(self, s, orders=3):
        """Return the sparse (len(s), unknowns) maps from z to x, x' (and x'') at ``s``."""
        t, count = self.knots, self._count
        d1 = _derivative_matrix(t, 3, count)
        bases = [BSpline.design_matrix(s, t, 3).tocsr(),
                 BSpline.design_matrix(s, t[1:-1], 2).tocsr() @ d1]
        if orders > 2:
            bases.append(BSpline.design_matrix(s, t[2:-2], 1).tocsr()
                         @ _derivative_matrix(t[1:-1], 2, count - 1) @ d1)
        first = _end_terms(s - self.start, self.end_lengths[0])
        last = _end_terms(self.end - s, self.end_lengths[1])
        sign = np.array([1.0, -1.0, 1.0])[:, None]     # d/ds = -d/dr at the end
        ends = np.stack(first + [term * sign for term in last], axis=-1)
        return [sp.hstack([basis, sp.csr_matrix(ends[order])], format='csr')
                for order, basis in enumerate(bases)]

    def _points(self, grid, steps):
        """Return the row points, ends included (sorted, unique)."""
        fractions = np.arange(DENSE) / DENSE
        dense = (grid[:-1, None] + fractions * steps[:, None]).ravel()
        halves = 2.0 ** -np.arange(1, GEOMETRIC_POINTS + 1)
        ends = np.concatenate([
            self.start + np.linspace(0.0, self.end_lengths[0], END_DENSE * END_STEPS + 1),
            self.end - np.linspace(0.0, self.end_lengths[1], END_DENSE * END_STEPS + 1),
            self.start + self.end_lengths[0] * halves, self.end - self.end_lengths[1] * halves])
        offset = WAYPOINT_OFFSET * (self.end - self.start)
        waypoints = self.path.x[1:-1]
        points = np.unique(np.concatenate([dense, grid[-1:], ends, waypoints - offset,
                                           waypoints + offset]))
        return points[(points >= self.start) & (points <= self.end)]

    def _rows(self, points):
        """
        Return x's design at ``points``, the candidate rows ``A z <= b`` and the jerk limits.

        Blocks of len(points) rows, built once for all joints: ``x <= cap``,
        ``-x <= 0`` (``-x <= -floor`` in the residual's LPs), ``+-(acceleration)
        <= a``, then ``+-L(z)`` of the jerk (module docstring).  ``b`` is 0
        for the cap and jerk rows, set per LP; the last return is the jerk
        limit of each jerk row.
        """
        x, x1, x2 = self._design(points)
        n = points.size
        acc, jerk = self._joint_maps(points, (x, x1, x2))
        # Jerk rows for the joints with a jerk limit (inf: none).
        joints = np.isfinite(self.jerk)
        jerk = jerk[np.repeat(joints, n)]
        more, more_bound, self._speed = self._constraint_rows(points, x, x1)
        rows = sp.vstack([x, -x, acc, -acc] + more + [jerk, -jerk], format='csr')
        jerk_bound = np.tile(np.repeat(self.jerk[joints], n), 2)
        bound = np.concatenate([np.zeros(2 * n), np.tile(np.repeat(self.acceleration, n), 2)]
                               + more_bound + [np.zeros(jerk_bound.size)])
        return x, rows, bound, jerk_bound

    def _joint_maps(self, points, designs):
        """
        Return the maps (n_joints * n, unknowns), joint-major, from z to the joints' motion.

        ``designs``: the designs of x, x' (and x'') at ``points``.  The map
        of the acceleration ``q' x'/2 + q'' x``; given x'', the pair of it
        and the jerk's ``L(z) = q' x''/2 + 3 q'' x'/2 + q''' x`` (module
        docstring), with the path's slopes evaluated once for both.
        """
        n_joints = self.jerk.size
        slopes = [np.atleast_2d(self.path(points, k).T).ravel()
                  for k in range(1, len(designs) + 1)]
        stacked = [sp.vstack([design] * n_joints, format='csr') for design in designs]
        acc = sp.diags(0.5 * slopes[0]) @ stacked[1] + sp.diags(slopes[1]) @ stacked[0]
        if len(designs) == 2:
            return acc
        return acc, (sp.diags(0.5 * slopes[0]) @ stacked[2] + sp.diags(1.5 * slopes[1])
                     @ stacked[1] + sp.diags(slopes[2]) @ stacked[0])

    def _constraint_rows(self, points, x, x1):
        """
        Return the rows and bounds of the second-order ``constraints`` at ``points``.

        ``lo <= a u + b x <= hi`` with ``u = x'/2``: ``+-(a x'/2 + b x)``
        below ``hi`` and ``-lo``; rows whose bound is infinite are left out.
        A constraint with a term in the path speed itself, ``c sdot``
        (``speed_terms``: the joint torque's damping), has it out of ``b``
        (``b - c``: ``rows`` gives it at ``sdot = 1``) and its rows apart
        (the third return: per row block its rows without the term, the row
        points, ``+-c`` and the bound), linearised anew each LP
        (:class:`_SpeedRows`).
        """
        rows, bounds, speed = [], [], []
        if not any(c.order == 2 for c in self.constraints):
            return rows, bounds, speed
        gridded = GriddedPath.of_ppoly(self.path, points)
        for constraint in self.constraints:
            if constraint.order != 2:
                continue
            a, b, lo, hi = constraint.rows(gridded)
            terms = getattr(constraint, 'speed_terms', None)
            c = None if terms is None else terms(gridded)
            if c is not None:
                b = b - c
            for k in range(a.shape[1]):
                row = sp.diags(0.5 * a[:, k]) @ x1 + sp.diags(b[:, k]) @ x
                for sign, limit in ((1.0, hi[:, k]), (-1.0, -lo[:, k])):
                    finite = np.flatnonzero(np.isfinite(limit))
                    if not finite.size:
                        continue
                    if c is not None and np.any(c[finite, k]):
                        speed.append((sign * row[finite], finite, sign * c[finite, k],
                                      limit[finite]))
                    else:
                        rows.append(sign * row[finite])
                        bounds.append(limit[finite])
        return rows, bounds, speed

    def _solve(self, grid, steps):
        """Return the coefficients z of the last feasible LP (sequential LPs, see the module)."""
        every = self._points(grid, steps)
        # x_max: the fastest v/a profile on the row points; it holds the velocity.
        gridded = GriddedPath.of_ppoly(self.path, every)
        joint_limits = (JointVelocity(self.velocity), JointAcceleration(self.acceleration))
        x_max = x_start = _lift_isolated_stops(PathLimits(
            gridded, joint_limits + self.constraints).profile(
                np.ones(every.size), *self.ends))[1:-1]
        width = np.zeros(every.size)                # trapezoid weights of the time
        width[:-1] += 0.5 * np.diff(every)
        width[1:] += 0.5 * np.diff(every)
        width = width[1:-1]
        points = every[1:-1]
        n = points.size
        x, candidates, bound, jerk = self._rows(points)
        if self._speed:
            # A term in the path speed itself (the damping) is the speed rows', not the
            # cap's: the rows hold it as c x, which overstates it beyond sdot = 1 and
            # capped the damped arms' profiles below what the speed rows allow
            # (helper-86).  The first LP is still linearised at the profile with it.
            x_max = np.maximum(x_start, _lift_isolated_stops(PathLimits(
                gridded, joint_limits + tuple(_WithoutSpeedTerm(c) if c.order == 2 else c
                                              for c in self.constraints))
                .profile(np.ones(every.size), *self.ends))[1:-1])
        rows, jerk_data, x_data, row_of_entry = _tangent_rows(candidates, x, jerk.size)
        first = rows.nnz - jerk_data.size         # the jerk rows' first entry
        # A fixed count of rows with a speed term, after the others: the basis holds.
        speed = _SpeedRows(self._speed, x, rows) if self._speed else None
        bounds = self._bounds()
        # The first LP's working set: the rows violated at x_max's least-squares fit.
        free = np.array([bound == (None, None) for bound in bounds])
        z_best = np.array([0.0 if bound[0] is None else bound[0] for bound in bounds])
        z_best[free] = _least_squares(x[:, free], x_start)
        warm = _WarmHighs(bounds) if HIGHSPY else None

        def solve(x_p, z_p, growth, first_lp=False, residual=None):
            """Solve one LP linearised at ``x_p``, from ``z_p``'s rows (``residual``: more)."""
            x_q = np.maximum(x_p, MIN_WEIGHT_SHARE * x_p.max())
            x_r = np.tile(x_q, jerk.size // n)
            # The tangent of j / sqrt(x) at x_q: conservative for every x > 0.
            rows.data[first:] = jerk_data + (0.5 * jerk * x_r ** -1.5)[row_of_entry] * x_data
            bound[:n] = x_p if first_lp else np.minimum(
                x_max, np.maximum(growth * x_p, (growth - 1.0) * RESTART_SHARE * x_max))
            bound[n:2 * n] = 0.0 if residual is None else -RESIDUAL_FLOOR * x_p
            bound[bound.size - jerk.size:] = 1.5 * jerk / np.sqrt(x_r)
            cost = -(x.T @ (width / x_q ** 1.5))
            every_row, every_bound = (rows, bound) if speed is None else speed.stacked(
                x_q, rows, bound)
            work = every_row @ z_p > (FIRST_KEEP if first_lp else KEEP) * every_bound
            work[:n:DENSE] = True       # x <= cap about once a grid step: a bounded LP
            if residual is None:
                return self._generate(cost, every_row, every_bound, work, bounds, warm)
            more, more_bound = residual     # few dense rows, all in the working set
            return self._generate(cost, sp.vstack([every_row, more], format='csr'),
                                  np.concatenate([every_bound, more_bound]),
                                  np.concatenate([work, np.ones(more_bound.size, bool)]),
                                  bounds, warm)

        x_p, z_feasible, last_time, message = x_start.copy(), None, None, ''
        for iteration, growth in enumerate(GROWTH):
            try:
                result = solve(x_p, z_best, growth, first_lp=iteration == 0)
            except RuntimeError as error:   # HiGHS refused a later LP: keep the last profile
                if z_feasible is None:
                    raise
                message = str(error)
                break
            if result.status != 0:
                message = result.message
                break                   # keep the last feasible profile
            z_best = z_feasible = result.x
            x_p = np.maximum(x @ z_best, 0.0)
            time = np.sum(width / np.sqrt(np.maximum(x_p, np.finfo(float).tiny)))
            if last_time is not None and last_time - time < TOLERANCE * time:
                break
            last_time = time
        if z_feasible is None:
            raise RuntimeError(f'the first LP of the smooth profile failed: {message}')
        if self.vibration_frequency > 0.0 and self.ends[1] == 0.0:
            z_feasible = self._cancel_residual(solve, every, x, z_feasible)
        return z_feasible

    def _cancel_residual(self, solve, every, x, z):
        """
        Return the profile of least residual share of up to :data:`RESIDUAL_LPS` more LPs.

        From the converged profile ``z``: each LP adds the residual rows
        linearised at the last profile (:meth:`_residual_rows`, on the grid
        of :meth:`_mode_grid`), at :data:`RESIDUAL_STEPS` of its share in
        turn until one is feasible (at least :data:`RESIDUAL_BOUND`), and
        keeps ``x`` above :data:`RESIDUAL_FLOOR` of it; they stop once a
        profile's own share is at most :data:`RESIDUAL_ACCEPTED`, or when no
        step is feasible.  ``self.residual`` is the kept profile's share.
        """
        grid = self._mode_grid(every, x, z)
        if grid is None:
            self.residual = np.nan      # a mode too fast for the grid: left as it is
            return z
        content = self._mode_content(grid, z)
        best_share = share = self._residual_share(content, z)
        best = z
        for _ in range(RESIDUAL_LPS):
            if share <= RESIDUAL_ACCEPTED:
                break
            x_p = np.maximum(x @ z, 0.0)
            result = None
            for step in RESIDUAL_STEPS:
                rows = self._residual_rows(content, max(RESIDUAL_BOUND, step * share))
                try:
                    result = solve(x_p, z, GROWTH[-1], residual=rows)
                except RuntimeError:    # HiGHS refused it: keep what is found
                    result = None
                    break
                if result.status == 0:
                    break
            if result is None or result.status != 0:
                break
            z = result.x
            content = self._mode_content(grid, z)
            share = self._residual_share(content, z)
            if share < best_share:
                best_share, best = share, z
        self.residual = float(best_share)
        return best

    def _mode_grid(self, every, x, z):
        """
        Return the points, x's design and the joints' acceleration map on which ``Z`` is summed.

        The row points, each step of the profile ``z``'s time law cut into
        as many as put :data:`MODE_POINTS` points a period of the mode (the
        row points are per segment: a segment of seconds has steps of tens
        of milliseconds).  None when that takes more than
        :data:`MAX_MODE_POINTS` points beyond the row points (a mode of
        hundreds of Hz on a plan of seconds).
        """
        dt = self._time_steps(every, np.maximum(x @ z, 0.0))
        # Capped before the cast: a step between two points where x is 0 lasts ~1e305 s
        # (a cap of MAX_MODE_POINTS + 2 parts is already too many).
        parts = np.maximum(1.0, np.minimum(np.ceil(dt * self.vibration_frequency * MODE_POINTS),
                                           MAX_MODE_POINTS + 2.0))
        if np.isnan(parts).any() or parts.sum() - parts.size > MAX_MODE_POINTS:
            return None
        parts = parts.astype(int)
        first = np.repeat(np.cumsum(parts) - parts, parts)
        fine = np.concatenate([np.repeat(every[:-1], parts) + np.repeat(
            np.diff(every) / parts, parts) * (np.arange(parts.sum()) - first), every[-1:]])
        inner = fine[1:-1]
        design, slope = self._design(inner, orders=2)
        return fine, design, self._joint_maps(inner, (design, slope))

    def _time_steps(self, points, x_p):
        """
        Return the times ``dt`` between ``points`` (the ends included) on the profile ``x_p``.

        ``dt = 2 ds / (sqrt(x_i) + sqrt(x_i+1))``, exact where ``x`` is
        linear and finite at a rest end; ``x_p`` at the inner points.
        """
        speed = np.sqrt(np.concatenate([[self.ends[0]], np.maximum(x_p, 0.0), [self.ends[1]]]))
        return 2.0 * np.diff(points) / np.maximum(speed[:-1] + speed[1:], np.finfo(float).tiny)

    def _mode_content(self, grid, z):
        """
        Return the (n_joints, unknowns) complex map from z to each joint's ``Z``, phases of ``z``.

        ``Z = sum_k qdd_k dt_k exp(lambda (T - t_k))`` (:mod:`residual_vibration`)
        on the inner points of ``grid`` (:meth:`_mode_grid`), ``t`` by
        :meth:`_time_steps` on the profile ``z`` and ``dt_k`` the trapezoid
        weight of point k (:func:`residual_vibration.content_weights`, as the
        plan's own figure is summed).  The ends' own terms are left out: 0 at rest, half
        a step's content at a moving start.
        """
        points, design, acceleration = grid
        weights = content_weights(self._time_steps(points, design @ z),
                                  self.vibration_frequency)[1:-1]
        n = weights.size
        return np.array([acceleration[j * n:(j + 1) * n].T @ weights
                         for j in range(self.acceleration.size)])

    def _residual_share(self, content, z):
        """Return the largest residual share over the joints of ``z``, ``content`` its own map."""
        return float(np.max(np.abs(content @ z)
                            * static_scale(self.vibration_frequency, self.acceleration)))

    def _residual_rows(self, content, share):
        """
        Return the rows and bounds ``Re(exp(-i theta) Z_j(z')) <= bound_j`` of the map ``content``.

        ``content`` is :meth:`_mode_content` of the last profile (its
        phases); :data:`RESIDUAL_DIRECTIONS` angles ``theta`` a joint;
        ``bound_j`` is the residual ``share`` over the joint's
        :func:`residual_vibration.static_scale`.
        """
        angles = np.exp(-2j * np.pi * np.arange(RESIDUAL_DIRECTIONS) / RESIDUAL_DIRECTIONS)
        rows = (angles[None, :, None] * content[:, None, :]).real.reshape(-1, content.shape[1])
        bound = share / static_scale(self.vibration_frequency, self.acceleration)
        return sp.csr_matrix(rows), np.repeat(bound, RESIDUAL_DIRECTIONS)

    def _generate(self, cost, rows, bound, work, bounds, warm=None):
        """Solve the LP on the rows ``work``, adding the violated others until none is."""
        if warm is not None:
            warm.start(cost, rows, bound, work)
        # The rows the solver holds: with highspy also the rows nonbasic in the last
        # basis (start keeps them), which must not be appended a second time.
        held = work.copy()
        if warm is not None:
            held[warm.model] = True
        result = None
        for _ in range(MAX_ROUNDS):
            if warm is None:
                result = linprog(cost, A_ub=rows[held], b_ub=bound[held], bounds=bounds,
                                 method='highs-ds', options=dict(
                                     HIGHS_OPTIONS, time_limit=SOLVE_SECONDS,
                                     maxiter=ITERATIONS_PER_ROW * (
                                         int(np.count_nonzero(held)) + cost.size)))
            else:
                result = warm.run()
            self.lps += 1
            if result.status != 0:
                return result
            violated = (rows @ result.x > bound + VIOLATION * np.abs(bound)) & ~held
            if not violated.any():
                return result
            held |= violated
            if warm is not None:
                warm.add(np.flatnonzero(violated))
        result.status, result.message = 1, f'rows still violated after {MAX_ROUNDS} rounds'
        return result

    def _bounds(self):
        """
        Variable bounds: ``B = B' = 0`` at the rest ends, ``0 <= alpha <=`` the jerk at the end.

        At a moving end (``ends``: ``x_e > 0``) ``B = x_e`` and ``B' = 0``
        instead (its first or last two coefficients ``x_e``) and no end terms.
        """
        count = self._count
        bounds = [(None, None)] * (count + 4)
        for pair, value, terms in (((0, 1), self.ends[0], count),
                                   ((count - 2, count - 1), self.ends[1], count + 2)):
            for i in pair:
                bounds[i] = (value, value)
            if value:
                bounds[terms] = bounds[terms + 1] = (0.0, 0.0)
        for column, s, value in ((count, self.start, self.ends[0]),
                                 (count + 2, self.end, self.ends[1])):
            if value:
                continue
            slope = np.abs(np.atleast_1d(self.path(s, 1)))
            with np.errstate(divide='ignore'):
                path_jerk = np.min(self.jerk / slope)
            bounds[column] = (0.0, None if np.isinf(path_jerk) else
                              (4.5 * path_jerk) ** (2.0 / 3.0))
        return bounds

    # The solved profile.

    def x(self, s, order=0):
        """Return ``x`` (order 0), ``x'`` (1) or ``x''`` (2) at ``s``."""
        s = np.asarray(s, float)
        flat = s.ravel()
        out = np.array(self._spline[order](flat), float)
        sign = (1.0, -1.0, 1.0)[order]
        # The end terms only where they are not 0 (the time law's hot path).
        for (alpha, beta), r, length, factor in (
                (self.end_coefficients[0], flat - self.start, self.end_lengths[0], 1.0),
                (self.end_coefficients[1], self.end - flat, self.end_lengths[1], sign)):
            inside = (r > 0.0) & (r < length)
            if inside.any():
                terms = _end_terms(r[inside], length)
                out[inside] = out[inside] + factor * (alpha * terms[0][order]
                                                      + beta * terms[1][order])
        return out.reshape(s.shape)

    def _prepare_time_law(self):
        """Split the path into quadrature pieces and integrate t at their ends."""
        spline = BSpline(self.knots, self.coefficients, 3)
        self._spline = (spline, spline.derivative(1), spline.derivative(2))
        breaks = np.unique(np.concatenate([self.knots, [self.start + self.end_lengths[0],
                                                        self.end - self.end_lengths[1]]]))
        fractions = np.arange(QUADRATURE_SPLIT) / QUADRATURE_SPLIT
        self._breaks = np.concatenate([(breaks[:-1, None] + fractions
                                        * np.diff(breaks)[:, None]).ravel(), breaks[-1:]])
        nodes, weights = np.polynomial.legendre.leggauss(QUADRATURE_NODES)
        self._nodes, self._weights = 0.5 * (nodes + 1.0), 0.5 * weights
        pieces = self._breaks.size - 1
        self._times = np.concatenate([[0.0], np.cumsum(
            self._partial(np.arange(pieces), np.ones(pieces)))])
        self.duration = self._times[-1]
        # The path speed at the pieces' ends: s_of_t's first guess (a Hermite cubic).
        self._speeds = np.sqrt(np.maximum(self.x(self._breaks), 0.0))

    def _map(self, piece, tau):
        """Return s and ds/dtau at ``tau`` in [0, 1] on ``piece`` (cubic on the first and last)."""
        a, b = self._breaks[piece], self._breaks[piece + 1]
        h = b - a
        s, ds = a + h * tau, h * np.ones_like(tau)
        first, last = piece == 0, piece == self._breaks.size - 2
        s = np.where(first, a + h * tau ** 3, np.where(last, b - h * (1.0 - tau) ** 3, s))
        ds = np.where(first, 3.0 * h * tau ** 2,
                      np.where(last, 3.0 * h * (1.0 - tau) ** 2, ds))
        return s, ds

    def _rate(self, piece, tau):
        """Return dt/dtau on ``piece``."""
        s, ds = self._map(piece, tau)
        with np.errstate(divide='ignore', invalid='ignore'):
            return ds / np.sqrt(np.maximum(self.x(s), 0.0))

    def _partial(self, piece, tau):
        """Return the time from the start of ``piece`` to ``tau`` on it (vectorised)."""
        pieces = np.repeat(piece[:, None], self._nodes.size, axis=1)
        at = tau[:, None] * self._nodes[None, :]
        rate = self._rate(pieces.ravel(), at.ravel()).reshape(pieces.shape)
        return tau * (rate @ self._weights)

    def _first_guess(self, piece, t):
        """
        Return Newton's first ``tau`` at the times ``t``: the cubic Hermite ``s(t)`` of the piece.

        From ``s`` and ``sdot`` at both ends of the piece; mapped to ``tau``
        by :meth:`_map`'s inverse.  (A linear guess in time needed 5-8 Newton
        steps of a quadrature each; this one 2-3.)
        """
        times, breaks, speeds = self._times, self._breaks, self._speeds
        a, b = breaks[piece], breaks[piece + 1]
        span = times[piece + 1] - times[piece]
        u = np.clip((t - times[piece]) / span, 0.0, 1.0)
        guess = ((1.0 + 2.0 * u) * (1.0 - u) ** 2 * a + u * (1.0 - u) ** 2 * span * speeds[piece]
                 + u * u * (3.0 - 2.0 * u) * b - u * u * (1.0 - u) * span * speeds[piece + 1])
        return self._tau_of(piece, guess)

    def _tau_of(self, piece, s):
        """Return ``tau`` in [0, 1] of the positions ``s`` on ``piece``: :meth:`_map`'s inverse."""
        breaks = self._breaks
        a, b = breaks[piece], breaks[piece + 1]
        share = np.clip((s - a) / (b - a), 0.0, 1.0)
        # s = a + h tau**3 on the first piece, b - h (1 - tau)**3 on the last.
        return np.where(piece == 0, np.cbrt(share),
                        np.where(piece == breaks.size - 2, 1.0 - np.cbrt(1.0 - share), share))

    def s_of_t(self, t):
        """Return ``s`` at the times ``t`` (``start`` before 0, ``end`` after the duration)."""
        t = np.atleast_1d(np.asarray(t, float))
        out = np.where(t >= self.duration, self.end, self.start)
        # Newton on the times strictly inside only: at rest (t = 0) the rate is
        # 0 / 0, and its nan kept the loop from ever stopping.
        moving = (t > 0.0) & (t < self.duration)
        t = t[moving]
        times = self._times
        piece = np.clip(np.searchsorted(times, t, side='right') - 1, 0, self._breaks.size - 2)
        tau = self._first_guess(piece, t)
        # Safeguarded: t(tau) increases on a piece, so each error narrows a
        # bracket, and a step that is not finite or leaves it bisects it
        # (a rest end where x is 0 to round-off left 0 / 0 there, and nan).
        low, high = np.zeros_like(tau), np.ones_like(tau)
        active = np.arange(t.size)      # the times whose last step was not yet below tolerance
        for _ in range(NEWTON_STEPS):
            if active.size == 0:
                break
            at, now = piece[active], tau[active]
            error = times[at] + self._partial(at, now) - t[active]
            low[active] = np.where(error <= 0.0, now, low[active])
            high[active] = np.where(error >= 0.0, now, high[active])
            with np.errstate(divide='ignore', invalid='ignore'):
                new = now - error / self._rate(at, np.maximum(now, 1e-9))
            inside = np.isfinite(new) & (new >= low[active]) & (new <= high[active])
            new = np.where(inside, new, 0.5 * (low[active] + high[active]))
            tau[active] = new
            active = active[np.abs(new - now) >= NEWTON_TOLERANCE]
        out[moving] = self._map(piece, tau)[0]
        return out

    def time_at(self, s):
        """Return the time ``t(s)`` at the path positions ``s`` (clipped to the path)."""
        s = np.clip(np.atleast_1d(np.asarray(s, float)), self.start, self.end)
        breaks = self._breaks
        piece = np.clip(np.searchsorted(breaks, s, side='right') - 1, 0, breaks.size - 2)
        tau = self._tau_of(piece, s)
        moved = tau > 0.0           # the integrand is 0 / 0 at rest, its integral 0
        partial = np.zeros_like(tau)
        partial[moved] = self._partial(piece[moved], tau[moved])
        return self._times[piece] + partial

    def samples(self, period=1e-3):
        """Return the times ``k period`` (k = 0, 1, .. up to one past the duration) and s."""
        t = np.arange(int(np.floor(self.duration / period)) + 2) * period
        return t, self.s_of_t(t)
