"""
Free inner knots for 555 optimal timing (issue 17).

With knots at the waypoints only, the durations alone fix the whole C4
quintic spline of 555 (the quintic of eqs. 13-23 on every segment, jerk and
snap continuous): a segment cannot shape its own accelerate, cruise and
decelerate phases.  Here every segment is split into ``m + 1`` pieces; the
``m`` inner knots are passed at free positions, and the result is still one
C4 quintic spline through all knots (waypoints and inner knots).

Parameterisation.  Every knot ``i`` carries a state ``(p_i, v_i, a_i)`` per
joint; piece ``i`` is the quintic of eqs. (13)-(23) between the states of
knots ``i`` and ``i + 1`` (:func:`segments.input_maps`), and jerk and snap
continuity at every interior knot are linear equalities in those states (the
equations of :mod:`continuity_system`, kept here as LP constraints instead
of being solved).  For fixed piece durations every derivative of the spline
at a fixed point of a piece is linear in the states of its two knots, so
with the waypoint positions and the boundary values fixed, the best inner
knots of one joint are a sparse LP (:func:`_solve`).

Warm start (exact).  The knots-only optimum (:mod:`optimal`) is a C4 quintic
spline; inserting a knot at the spline's own position, velocity and
acceleration leaves it unchanged (the quintic on each side of the new knot
is fixed by the same end states, eqs. 13-23, and jerk and snap are
continuous there because the spline is C4).  :func:`insert_knots` does that;
the refinement starts from the durations of that optimum, and the result is
kept only when it is shorter.

Optimisation (rest-to-rest requests).  With all boundary values zero, a
spline whose durations are multiplied by ``f`` (velocities divided by ``f``,
accelerations by ``f**2``, positions kept) has peaks ``v / f``, ``a / f**2``,
``j / f**3``; so the exact factor that brings a spline to its limits is
``max(r_v, r_a**(1/2), r_j**(1/3))`` of its exact peak ratios (:mod:`peaks`,
roots of the derivative polynomials, no sampling).

1. Common scale (:func:`_common_scale`).  For fixed relative piece
   durations, each joint on its own: the LP "smallest scale change ``d``
   with every sampled derivative within ``limit * (1 + q d)``" at the current
   scale, then the exact factor of its solution, repeated while the scale
   falls (:func:`_best_scale`).  The spline takes the largest of the joints'
   scales (slower joints stay feasible when slowed down further), and the
   exact factor of the whole spline is applied: every limit holds exactly,
   one binds.
2. Redistribution (:func:`refine_rest_to_rest`).  Per joint, the LP with a
   scale change ``d_i`` per piece, minimising ``sum_i h_i d_i`` (the first-order
   change of the total time) within a trust region ``|d_i| <= radius``; each
   piece is then scaled by its exact factor (the largest over the joints of
   that piece's exact factor in their LP solutions), and step 1 gives the
   exact total of the new durations.  A step is kept when the total falls,
   otherwise the radius halves.

The LPs bound the derivatives at :data:`SAMPLES` points per piece only; the
exact factors afterwards make every limit hold exactly (the sampled LP
is only how the next iterate is found).

Non-zero boundary values (a moving start state) do not scale that way; the
refinement is not used for them (the knots-only optimum is returned, see
:func:`with_inner_knots`).
"""

from concurrent.futures import ThreadPoolExecutor
import os

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, linprog, milp
from scipy.sparse import csc_array, csr_array

from .continuity_system import ContinuitySystem
from .limits import limit_ratios
from .segments import (
    A_END, A_START, derivative_weights, DP, falling_factors, input_maps, QUINTIC, V_END,
    V_START,
)
from .trajectory import representable_durations, Trajectory

# Largest number of inner knots per segment accepted by plan().
MAX_INNER_KNOTS = 8
# Points per piece at which the LPs bound every derivative (plus the last knot).
SAMPLES = 5
# Per-joint scale iteration (step 1): most LPs, and the relative fall of the
# scale below which it stops.
SCALE_ITERATIONS = 12
SCALE_TOLERANCE = 1e-3
# Largest relative shortening in one LP of step 1 (keeps 1 + q d positive).
MAX_SHRINK = 0.3
# Redistribution (step 2): most rounds, first and smallest trust-region radius,
# and the relative fall of the total for a step to be kept.
ROUNDS = 5
INITIAL_RADIUS = 0.3
MIN_RADIUS = 0.01
ROUND_GAIN = 1e-4
# Scale iterations per joint when a redistribution step is evaluated.
TRIAL_ITERATIONS = 1
# Threads that solve the joints' LPs at once (HiGHS releases the GIL while it
# solves; each joint's LPs are independent, so the result does not depend on it):
# one per core this process may run on.
JOINT_THREADS = (len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity')
                 else os.cpu_count() or 1)
# Safety factor on exact restoring factors against round-off.
_ROUNDOFF = 1.0 + 1e-12


def inner_knot_count(value, method, timing):
    """
    Validate the ``inner_knots`` argument of plan(); return it as an int.

    An integer from 0 to :data:`MAX_INNER_KNOTS`; a non-zero count needs
    method 555 with timing "optimal" (the only combination that uses it).
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ValueError(f'inner_knots must be an integer, got {value!r}')
    value = int(value)
    if not 0 <= value <= MAX_INNER_KNOTS:
        raise ValueError(f'inner_knots must be between 0 and {MAX_INNER_KNOTS}, got {value}')
    if value and (method != '555' or timing != 'optimal'):
        raise ValueError(f'inner_knots = {value} needs method "555" with timing "optimal", '
                         f'got method {method!r} with timing {timing!r}')
    return value


def split_durations(durations, n_inner):
    """
    Return piece durations (S * (n_inner + 1),) and the knot index of every waypoint (S + 1,).

    Every segment is split into ``n_inner + 1`` equal pieces.
    """
    durations = np.asarray(durations, dtype=float)
    pieces = np.repeat(durations / (n_inner + 1), n_inner + 1)
    return pieces, np.arange(durations.size + 1) * (n_inner + 1)


def quintic_coefficients(pieces, positions, velocities, accelerations):
    """Ascending coefficients (P, 6, n) of the quintics (eqs. 13-23) between knot states (K, n)."""
    maps = input_maps(np.full(pieces.size, QUINTIC), pieces)
    inputs = np.stack([np.diff(positions, axis=0), velocities[:-1], accelerations[:-1],
                       velocities[1:], accelerations[1:]], axis=1)
    coeffs = maps @ inputs
    coeffs[:, 0] = positions[:-1]
    return coeffs


def insert_knots(traj, pieces):
    """
    Knot states (3, K, n): position, velocity, acceleration of ``traj`` at new knots.

    The knots are at the cumulative ``pieces`` durations.  For a C4 quintic
    spline whose breakpoints are among them, the quintics between these
    states reproduce ``traj`` exactly (the warm start).
    """
    times = np.concatenate([[0.0], np.cumsum(pieces)])
    times[-1] = min(times[-1], traj.duration)
    return np.stack([traj.ppoly(times, nu=d) for d in range(3)])


def c4_states(pieces, positions):
    """
    Knot states (3, K, n) of the C4 quintic spline through ``positions`` (K, n), at rest.

    Velocities and accelerations come from the banded continuity system of
    555 (:mod:`continuity_system`, jerk and snap continuity) over all knots:
    the LP's own values meet those equations only to its tolerance, these
    to round-off.
    """
    zero = np.zeros(positions.shape[1])
    vel, acc = ContinuitySystem('555', pieces).solve(np.diff(positions, axis=0), zero, zero,
                                                     zero, zero)
    return np.stack([positions, vel, acc])


def exact_factors(coeffs, pieces, limits):
    """
    Exact restoring factor per piece and joint (P, n): ``max(r_v, r_a**(1/2), r_j**(1/3))``.

    The ratios are exact peaks from the polynomials (:func:`limits.limit_ratios`);
    a rest-to-rest spline whose durations are all multiplied by ``f`` has
    ratios ``r_v / f``, ``r_a / f**2``, ``r_j / f**3``.
    """
    ratios = limit_ratios(coeffs, pieces, limits)
    return np.max(ratios ** (1.0 / np.arange(1, 4))[None, None, :], axis=2)


class _Rows:
    """
    Linear forms of the spline's derivatives in the knot states, for fixed piece durations.

    Variables of one joint are ``[p_0 .. p_{K-1}, v_0 .., a_0 ..]`` (3K),
    scaled by :attr:`column_scale` (velocities times, accelerations times
    the square of, the local piece duration: comparable sizes keep HiGHS's
    simplex well conditioned).  Rows are derivative ``q`` (1, 2, 3) at
    :data:`SAMPLES` points of every piece and at the last knot: ``cols``,
    ``data`` (R, 6), with their ``quantity`` and ``piece`` (R,).  The
    equalities ``eq_cols``, ``eq_data`` are jerk and snap continuity at the
    interior knots.
    """

    def __init__(self, pieces, samples=SAMPLES):
        """Build the rows for the piece durations ``pieces`` (P,)."""
        P = pieces.size
        self.n_knots = K = P + 1
        maps = input_maps(np.full(P, QUINTIC), pieces)            # (P, 6, 5)
        # Columns of the five inputs [dP, v_s, a_s, v_e, a_e] of every piece
        # (dP = p_{i+1} - p_i takes two columns).
        idx = np.arange(P)
        cols = np.stack([idx, idx + 1, K + idx, 2 * K + idx, K + idx + 1, 2 * K + idx + 1],
                        axis=1)

        def forms(weights, maps=maps):
            # weights (P', r, 6) on the coefficients -> (P', r, 6) on the columns.
            w = weights @ maps
            return np.stack([-w[..., DP], w[..., DP], w[..., V_START], w[..., A_START],
                             w[..., V_END], w[..., A_END]], axis=-1)

        x = np.arange(samples) / samples
        rows, data, quantity, piece = [], [], [], []
        for q in (1, 2, 3):
            falling, exponent = falling_factors(q)
            tau = x[None, :] * pieces[:, None]
            f = forms(falling[None, None, :] * tau[..., None] ** exponent[None, None, :])
            last = forms(derivative_weights(pieces[-1:], q, True)[:, None, :], maps[-1:])[0]
            rows.append(np.concatenate([np.broadcast_to(cols[:, None, :], f.shape)
                                        .reshape(-1, 6), cols[-1:]]))
            data.append(np.concatenate([f.reshape(-1, 6), last]))
            quantity.append(np.full(P * samples + 1, q))
            piece.append(np.append(np.repeat(idx, samples), P - 1))
        self.cols = np.concatenate(rows)
        self.quantity = np.concatenate(quantity)
        self.piece = np.concatenate(piece)
        eq_cols, eq_data = [], []
        for q in (3, 4):
            end = forms(derivative_weights(pieces[:-1], q, True)[:, None, :], maps[:-1])[:, 0]
            start = forms(derivative_weights(pieces[1:], q, False)[:, None, :], maps[1:])[:, 0]
            eq_cols.append(np.concatenate([cols[:-1], cols[1:]], axis=1))
            eq_data.append(np.concatenate([end, -start], axis=1))
        self.eq_cols = np.concatenate(eq_cols)
        h = np.concatenate([pieces[:1], 0.5 * (pieces[:-1] + pieces[1:]), pieces[-1:]])
        self.column_scale = np.concatenate([np.ones(K), 1.0 / h, 1.0 / h ** 2])
        self.data = np.concatenate(data) * self.column_scale[self.cols]
        eq_data = np.concatenate(eq_data) * self.column_scale[self.eq_cols]
        scale = np.max(np.abs(eq_data), axis=1, keepdims=True)
        self.eq_data = eq_data / np.where(scale > 0.0, scale, 1.0)


def _highs(cost, matrix, lower, upper, x_lb, x_ub):
    """Solve an LP with HiGHS (simplex through milp, interior point if that fails)."""
    result = milp(cost, constraints=LinearConstraint(matrix, lower, upper),
                  bounds=Bounds(x_lb, x_ub))
    if result.status == 0 and result.x is not None:
        return result.x
    matrix = csr_array(matrix)
    eq = lower == upper
    result = linprog(cost, A_ub=matrix[np.flatnonzero(~eq)], b_ub=upper[~eq],
                     A_eq=matrix[np.flatnonzero(eq)], b_eq=upper[eq],
                     bounds=np.column_stack([x_lb, x_ub]), method='highs-ipm')
    return result.x if result.status == 0 else None


def _solve(rows, points, waypoint_knots, limits, joint, group, weights, d_bounds):
    """
    One LP over the knot states of ``joint`` and a scale change ``d`` per group of pieces.

    Minimises ``weights . d`` subject to every sampled q-th derivative within
    ``limit_q * (1 + q d_g)``, ``g = group[piece]``: a piece whose duration
    grows by the factor ``1 + d`` has its q-th derivative divided by
    ``(1 + d)**q >= 1 + q d`` (Bernoulli), so the LP is a conservative
    linearisation of the time scaling, exact to first order.  The waypoint
    positions and the (zero) boundary velocities and accelerations are
    fixed.  Returns (states (3, K), d) or None when HiGHS fails.
    """
    K = rows.n_knots
    n_g = len(weights)
    bounds = limits.as_array()[:, joint]
    keep = np.isfinite(bounds[rows.quantity - 1])
    cols = rows.cols[keep]
    data = rows.data[keep] / bounds[rows.quantity[keep] - 1][:, None]
    q = rows.quantity[keep].astype(float)
    d_col = 3 * K + group[rows.piece[keep]]
    n = cols.shape[0]
    this = np.arange(n)
    n_eq = rows.eq_cols.shape[0]
    # |row| <= 1 + q d:  row - q d <= 1 and -row - q d <= 1; then the equalities.
    r = np.concatenate([np.repeat(this, 6), this, np.repeat(this + n, 6), this + n,
                        2 * n + np.repeat(np.arange(n_eq), rows.eq_cols.shape[1])])
    c = np.concatenate([cols.reshape(-1), d_col, cols.reshape(-1), d_col,
                        rows.eq_cols.reshape(-1)])
    v = np.concatenate([data.reshape(-1), -q, -data.reshape(-1), -q, rows.eq_data.reshape(-1)])
    n_var = 3 * K + n_g
    matrix = csc_array((v, (r, c)), shape=(2 * n + n_eq, n_var))
    lower = np.concatenate([np.full(2 * n, -np.inf), np.zeros(n_eq)])
    upper = np.concatenate([np.ones(2 * n), np.zeros(n_eq)])
    x_lb = np.full(n_var, -np.inf)
    x_ub = np.full(n_var, np.inf)
    x_lb[3 * K:], x_ub[3 * K:] = d_bounds
    x_lb[waypoint_knots] = x_ub[waypoint_knots] = points[:, joint]
    ends = np.array([K, 2 * K - 1, 2 * K, 3 * K - 1])
    x_lb[ends] = x_ub[ends] = 0.0
    cost = np.concatenate([np.zeros(3 * K), weights])
    x = _highs(cost, matrix, lower, upper, x_lb, x_ub)
    if x is None:
        return None
    states = (x[:3 * K] * rows.column_scale).reshape(3, K)
    return states, x[3 * K:]


def _joint_limits(limits, joint):
    return type(limits)(limits.velocity[joint:joint + 1], limits.acceleration[joint:joint + 1],
                        limits.jerk[joint:joint + 1])


def _best_scale(points, waypoint_knots, pieces, limits, joint, iterations):
    """
    Smallest time scale ``c`` of ``pieces`` found for joint ``joint`` (step 1).

    Iterates the one-group LP of :func:`_solve` and the exact restoring
    factor of its solution; returns (c, states (3, K) at durations ``c *
    pieces``, exactly within the joint's limits), or None.
    """
    one = _joint_limits(limits, joint)
    if np.all(points[:, joint] == points[0, joint]):
        # The joint does not move: it stays exactly at its position (an LP
        # would place its inner knots only within its tolerance) and meets
        # its limits at any scale.
        K = pieces.size + 1
        return 0.0, np.stack([np.full(K, points[0, joint]), np.zeros(K), np.zeros(K)])
    group = np.zeros(pieces.size, dtype=int)
    c, best = 1.0, None
    for _ in range(iterations):
        solved = _solve(_Rows(c * pieces), points, waypoint_knots, limits, joint, group,
                        np.ones(1), (-MAX_SHRINK, np.inf))
        if solved is None:
            break
        p, v, a = c4_states(c * pieces, solved[0][0][:, None])[:, :, 0]
        coeffs = quintic_coefficients(c * pieces, p[:, None], v[:, None], a[:, None])
        f = float(np.max(exact_factors(coeffs, c * pieces, one))) * _ROUNDOFF
        if f == 0.0:
            # The joint does not move: it meets its limits at any scale.
            return 0.0, np.stack([p, np.zeros_like(v), np.zeros_like(a)])
        if not np.isfinite(f):
            break
        if best is None or c * f < best[0]:
            best = (c * f, np.stack([p, v / f, a / f ** 2]))
        if f >= 1.0 - SCALE_TOLERANCE:
            break
        c *= f
    return best


def _common_scale(points, waypoint_knots, pieces, limits, iterations=SCALE_ITERATIONS,
                  joint_map=map):
    """
    Step 1 of the module docstring for the relative piece durations ``pieces``.

    Returns (piece durations, states (3, K, n)) exactly within the limits,
    or None when an LP fails.  ``joint_map`` maps a function over the joints
    (``map``, or a thread pool's, see :data:`JOINT_THREADS`).
    """
    n = points.shape[1]
    found = list(joint_map(
        lambda j: _best_scale(points, waypoint_knots, pieces, limits, j, iterations), range(n)))
    if any(f is None for f in found):
        return None
    c = max(f[0] for f in found)
    states = np.zeros((3, pieces.size + 1, n))
    for j, (own, joint_states) in enumerate(found):
        # A joint feasible at its own scale <= c stays feasible when slowed
        # down to c (exact rest-to-rest scaling).
        s = c / own if own > 0.0 else 1.0
        states[:, :, j] = joint_states / np.array([1.0, s, s * s])[:, None]
    # Fixed LP variables come back as their bounds; set them exactly anyway.
    states[0, waypoint_knots] = points
    scaled = c * pieces
    states = c4_states(scaled, states[0])
    g = float(np.max(exact_factors(quintic_coefficients(scaled, *states), scaled, limits)))
    g *= _ROUNDOFF
    states[1] /= g
    states[2] /= g * g
    return scaled * g, states


def refine_rest_to_rest(points, durations, limits, n_inner):
    """
    Free inner knots for a rest-to-rest 555 request (steps 1 and 2 of the module docstring).

    ``durations`` (S,) are where the pieces start (the knots-only
    optimum's).  Returns ``(pieces, states (3, K, n), waypoint_knots)`` of
    the shortest spline found, exactly within the limits, or None.
    """
    n = points.shape[1]
    workers = min(n, JOINT_THREADS)
    if workers <= 1:
        return _refine(points, durations, limits, n_inner, map)
    with ThreadPoolExecutor(workers) as pool:
        return _refine(points, durations, limits, n_inner, pool.map)


def _redistributed_factors(rows, points, waypoint_knots, pieces, limits, joint, radius):
    """Exact factor per piece (P,) of ``joint``'s redistribution LP solution, or None."""
    solved = _solve(rows, points, waypoint_knots, limits, joint, np.arange(pieces.size),
                    pieces, (-radius, radius))
    if solved is None:
        return None
    states = c4_states(pieces, solved[0][0][:, None])
    coeffs = quintic_coefficients(pieces, *states)
    return exact_factors(coeffs, pieces, _joint_limits(limits, joint))[:, 0]


def _refine(points, durations, limits, n_inner, joint_map):
    """:func:`refine_rest_to_rest` with the joints' LPs mapped by ``joint_map``."""
    pieces, waypoint_knots = split_durations(durations, n_inner)
    best = _common_scale(points, waypoint_knots, pieces, limits, joint_map=joint_map)
    if best is None:
        return None
    radius = INITIAL_RADIUS
    n = points.shape[1]
    for _ in range(ROUNDS):
        pieces = best[0]
        rows = _Rows(pieces)
        found = list(joint_map(
            lambda j, pieces=pieces, rows=rows, radius=radius: _redistributed_factors(
                rows, points, waypoint_knots, pieces, limits, j, radius), range(n)))
        if any(f is None for f in found):
            return best[0], best[1], waypoint_knots
        factors = np.stack(found, axis=1)
        per_piece = np.clip(np.max(factors, axis=1), 1.0 - radius, 1.0 + radius)
        trial = _common_scale(points, waypoint_knots, pieces * per_piece, limits,
                              TRIAL_ITERATIONS, joint_map)
        if trial is not None and trial[0].sum() < best[0].sum() * (1.0 - ROUND_GAIN):
            best = trial
        else:
            radius *= 0.5
            if radius < MIN_RADIUS:
                break
    final = _common_scale(points, waypoint_knots, best[0], limits, joint_map=joint_map)
    if final is not None and final[0].sum() < best[0].sum():
        best = final
    return best[0], best[1], waypoint_knots


def with_inner_knots(traj, n_inner):
    """
    Return the 555 optimal trajectory ``traj`` refined with ``n_inner`` free knots per segment.

    ``traj`` is the knots-only optimum.  It is returned unchanged when
    ``n_inner`` is 0, when a boundary value is non-zero (the refinement
    relies on rest-to-rest time scaling), or when the refinement fails or
    is not shorter; ``traj.optimizer['inner_knots']`` says how many inner knots
    the returned trajectory has per segment.
    """
    traj.optimizer = dict(traj.optimizer or {}, inner_knots=0)
    if n_inner == 0 or traj.method != '555' or traj.limits is None:
        return traj
    boundary = (traj.start_velocity, traj.start_acceleration, traj.end_velocity,
                traj.end_acceleration)
    if any(np.any(b) for b in boundary):
        traj.optimizer['inner_knots_skipped'] = 'non-zero boundary values'
        return traj
    try:
        found = refine_rest_to_rest(traj.waypoints, traj.durations, traj.limits, n_inner)
    except ValueError:  # a continuity system singular for some trial durations
        found = None
    if found is None or not found[0].sum() < traj.duration:
        return traj
    pieces, states, waypoint_knots = found
    # Quintics through the knot states on the widths the PPoly really has
    # (they differ from the pieces by round-off of the cumulative sum).
    pieces = representable_durations(pieces)
    coeffs = quintic_coefficients(pieces, *states)
    ratios = limit_ratios(coeffs, pieces, traj.limits)
    refined = Trajectory(traj.method, traj.timing, traj.waypoints, pieces, coeffs, boundary,
                         traj.limits, None, traj.dropped_waypoints, ratios=ratios)
    refined.waypoint_times = refined.breakpoints[waypoint_knots]
    refined.optimizer = dict(traj.optimizer, inner_knots=n_inner,
                             knots_only_duration=traj.duration)
    return refined
