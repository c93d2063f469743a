"""
Time-optimal segment durations (beyond the paper).

The paper scales all durations by one factor, so the limits bind on one
segment only.  Here the N-1 durations are chosen to minimise the total time
subject to every joint's velocity, acceleration and (when given) jerk limit::

    minimise  sum_k T_k   subject to  r_{s,j,q}(T) <= 1  for every segment s,
                                      joint j and limited quantity q,

    r_{s,j,q} = (peak_{s,j,q} / limit_{j,q})^(1/q)

(q = 1, 2, 3 for velocity, acceleration, jerk; the root makes every
constraint behave like a time scale: shortening segment s alone by a factor
c raises r_{s,.,.} by about 1/c).  One smooth constraint per peak, rather
than one per segment (their maximum), lets SLSQP converge in tens of
iterations instead of stalling at the kinks of the maximum.  The variables
are log-durations, started from the uniform (paper) solution.  The
constraint Jacobian is a forward difference, computed for all segments at
once: the S perturbed duration vectors are independent spline systems
stacked into one banded solve (:class:`ContinuitySystem` with a batch of
durations) and one batched peak computation.

Afterwards feasibility is restored exactly by the smallest common factor
(the same search as uniform timing, from exact polynomial peaks), and the
uniform solution is kept if it is not longer.

Every segment of the result either binds a limit, or cannot be shortened on
its own without another segment exceeding a limit (the splines couple all
segments: a 445 spline carries a disturbance undamped to its end), or sits
at the lower bound ``MIN_FRACTION`` times its uniform duration.
"""

import numpy as np
from scipy.optimize import minimize

from .continuity_system import spline_coefficients
from .limits import limit_ratios
from .timing import ScaledSpline, uniform_scale
from .trajectory import Trajectory

# Forward-difference step in log-duration.
FD_STEP = 1e-7
# Bounds of every duration relative to its uniform-timing value.
MIN_FRACTION = 1e-2
MAX_FRACTION = 10.0
MAX_ITERATIONS = 200
# Largest number of segments optimised (SLSQP's subproblem grows with the
# square of it: about 2 s at 100 segments x 7 joints).
MAX_SEGMENTS = 300
# Stop when the total time changes by less than this fraction of the uniform total.
RELATIVE_TOLERANCE = 1e-7
_ROOTS = 1.0 / np.arange(1, 4)
# Segments a duration change reaches above round-off, as (upstream, downstream)
# segment counts: the influence decays by about 0.1 per knot upstream and not
# at all downstream for 445 (roots 5 - sqrt(24) and -1 of the recursion), and
# by about 0.27 per knot both ways for 434 (2 - sqrt(3)); 0.1^8 and 0.27^15
# are below 1e-8, under the forward-difference noise.
INFLUENCE = {'445': (8, None), '434': (15, 15)}


class SegmentScales:
    """The constraint values r(T) and their Jacobian for one request (value cached)."""

    def __init__(self, method, points, boundary, limits):
        """Keep the request; nothing is solved yet."""
        self.method = method
        self.points = points
        self.boundary = boundary
        self.limits = limits
        self._value_key = None
        self._value = None
        self.evaluations = 0
        # One constraint per segment, joint and limited quantity.
        self._limited = np.array([True, True, bool(np.any(np.isfinite(limits.jerk)))])
        self.n_constraints = (len(points) - 1) * points.shape[1] * int(self._limited.sum())

    def batch(self, log_durations, rows=None, fill=None):
        """
        Return r for a (B, S) batch of log-durations: (B, n_constraints), inf if singular.

        With a (B, S) boolean ``rows``, peaks are computed only for those
        segments; the others take their values from ``fill`` (n_constraints,).
        """
        durations = np.exp(log_durations)
        n_batch, n_seg = durations.shape
        self.evaluations += n_batch
        try:
            coeffs = spline_coefficients(self.method, self.points, durations, self.boundary)
        except ValueError:  # a singular system somewhere in the batch
            if n_batch == 1:
                return np.full((1, self.n_constraints), np.inf)
            return np.vstack([
                self.batch(row[None, :], None if rows is None else rows[i:i + 1], fill)
                for i, row in enumerate(log_durations)])
        if rows is None:
            rows = np.ones((n_batch, n_seg), dtype=bool)
        ratios = limit_ratios(coeffs[rows], durations[rows], self.limits)
        scales = ratios[..., self._limited] ** _ROOTS[None, None, self._limited]
        out = np.empty((n_batch, n_seg) + scales.shape[1:])
        if fill is not None:
            out[:] = fill.reshape((1, n_seg) + scales.shape[1:])
        out[rows] = scales
        return out.reshape(n_batch, -1)

    def value(self, x):
        """Return the scaled peak ratios at x, shape (n_constraints,)."""
        key = x.tobytes()
        if key != self._value_key:
            self._value_key, self._value = key, self.batch(x[None, :])[0]
        return self._value

    def jacobian(self, x):
        """Return their Jacobian (n_constraints, S): forward differences, one batched solve."""
        n = x.size
        trial = np.tile(x, (n, 1)) + FD_STEP * np.eye(n)
        up, down = INFLUENCE[self.method]
        offset = np.arange(n)[None, :] - np.arange(n)[:, None]  # segment - perturbed one
        rows = offset >= -up
        if down is not None:
            rows &= offset <= down
        base = self.value(x)
        return ((self.batch(trial, rows, base) - base[None, :]) / FD_STEP).T


def optimal_durations(method, points, start, boundary, limits, dropped, uniform=None):
    """
    Plan with time-optimal durations, starting from the (S,) ``start`` durations.

    ``uniform`` is the feasible uniform-timing trajectory (kept when not
    longer), or None when uniform timing found no feasible factor; the
    optimiser then starts from infeasible durations and its constraints pull
    it into the feasible set.  Raises ValueError when the result cannot be
    made feasible.
    """
    scales = SegmentScales(method, points, boundary, limits)
    x0 = np.log(start)
    bounds = list(zip(x0 + np.log(MIN_FRACTION), x0 + np.log(MAX_FRACTION)))
    result = minimize(
        lambda x: float(np.sum(np.exp(x))), x0, jac=np.exp, method='SLSQP', bounds=bounds,
        constraints=[{'type': 'ineq',
                      'fun': lambda x: 1.0 - scales.value(x),
                      'jac': lambda x: -scales.jacobian(x)}],
        options={'maxiter': MAX_ITERATIONS, 'ftol': RELATIVE_TOLERANCE * start.sum()})
    candidate = np.exp(result.x) if np.all(np.isfinite(result.x)) else start
    refined = ScaledSpline(method, points, candidate, boundary)
    try:
        factor, ratios = uniform_scale(refined, limits)
        durations, coeffs = refined.durations(factor), refined.coefficients(factor)
    except ValueError:
        if uniform is None:
            raise ValueError('infeasible: neither uniform nor optimal timing found durations '
                             'that meet the limits with these boundary velocities and '
                             'accelerations') from None
        durations = None
    if uniform is not None and (durations is None or durations.sum() >= uniform.duration):
        durations, coeffs, ratios = uniform.durations, uniform.coefficients, uniform.limit_ratios()
    traj = Trajectory(method, 'optimal', points, durations, coeffs, boundary, limits,
                      None, dropped, ratios=ratios)
    traj.optimizer = {'iterations': int(result.nit), 'evaluations': scales.evaluations,
                      'message': str(result.message),
                      'uniform_duration': None if uniform is None else uniform.duration}
    return traj
