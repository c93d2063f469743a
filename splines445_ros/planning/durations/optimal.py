"""
Time-optimal segment durations (beyond the paper).

The paper scales all durations by one factor, so the limits bind on one
segment only.  Here the N-1 durations are chosen to minimise the total time
subject to every joint's velocity, acceleration and (when given) jerk limit::

    minimise  sum_k T_k   subject to  log r_{s,j,q}(log T) <= 0  for every
                                      segment s, joint j, limited quantity q

with the peak ratios r of :mod:`sensitivity` (exact values and exact
sparse derivatives, linear in N to compute).  The variables are
log-durations, started from the uniform (paper) solution.

The solver is a trust-region sequential linear program.  A warm start
first scales every segment by its own largest ratio while that helps
(:func:`_warm_start`).  Then at every iterate the constraints are linearised
and a sparse LP (HiGHS, through ``scipy.optimize.milp`` without integer
variables; up to :data:`DENSE_LP_SEGMENTS` segments the dense simplex of
:mod:`dense_lp`) gives the step within a box ``|dx| <= radius``.  Rest to
rest, the start is first scaled to its limits (:func:`_at_the_limits`).  Constraints
already violated are elastic (a penalised slack each), so an infeasible
start is pulled into the feasible set.  The merit of an iterate is its
*restored total*: its total time after scaling every duration by the
largest ratio, which is what the final common factor does (exact for
rest-to-rest requests).  A step is taken when the merit decreases by at
least :data:`ACCEPT` of what the linear model predicts; otherwise half the
step is tried, then a smaller box.  Only constraints the box can bring to
their limit enter the LP, so an LP has about as many rows as there are
constraints near a limit: the cost of an iteration grows linearly with N,
and the number of iterations (15 to 25 for 434 and 555) hardly grows.  With
non-zero boundary values the last iterate is brought back to the limits by
a few lengthening-only LP steps (:func:`_repair`).  A trial point that a
lower bound of its merit already rejects (peaks sampled at fixed points,
:meth:`PeakRatios.evaluate`) is not evaluated exactly; a rival with a total
to beat stops as soon as it cannot beat it (:func:`_beyond_give_up`,
:data:`CANNOT_WIN_RTOL`).  Neither changes a plan.

Afterwards feasibility is restored exactly by a common factor (the same
search as uniform timing, from exact polynomial peaks, unless the factor
``exp(largest log-ratio)`` already meets every limit), and the uniform
solution is kept if it is not longer.

Every segment of the result either binds a limit, or cannot be shortened on
its own without another segment exceeding a limit (the splines couple the
segments: a 445 spline carries a disturbance undamped to its end), or sits
at the lower bound ``MIN_FRACTION`` times its start (a bound that moves
with the iterate: :func:`_iterate_in_box`).  This is what
the method aims at, not a guarantee; it held on 1375 random small requests
(3-7 waypoints, 1-3 joints, half with boundary values).
"""

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp
from scipy.sparse import csc_array

from .dense_lp import DENSE_LP_SEGMENTS, solve_elastic_lp
from .ratio_search import RatioSearch
from .sensitivity import PeakRatios
from .timing import chord_durations, ScaledSpline, uniform_scale
from ..spline.limits import limit_ratios
from ..spline.methods import get_method
from ..spline.trajectory import Trajectory

# The constants of the optimiser, each with its reason in one line; the
# measurements behind them are in doc/methods.md ("Where the constants come
# from").
# Bounds of every duration relative to its starting (uniform) value.
MIN_FRACTION = 1e-2
MAX_FRACTION = 10.0
# An iterate that ends on that box gets a new one around it, at most this many
# times: a caller's start 12 times too short in one segment (555, the long
# hypothesis run of issue 38) ended 2.9 times as long as from plan()'s start.
BOX_MOVES = 4
# ... "on the box": within this of a bound, in log-duration.
BOX_EDGE = 1e-9
MAX_ITERATIONS = 200
# Stop when the predicted decrease of the total time is below this fraction of it.
RELATIVE_TOLERANCE = 1e-7
# Trust region in log-duration: first, smallest and largest radius.  A small
# box keeps the LPs of long requests small (fewer constraints can reach a limit).
INITIAL_RADIUS = 0.1
MIN_RADIUS = 1e-7
MAX_RADIUS = 0.1
# Radius after a rejected step, relative to that step.
SHRINK = 0.5
# Smallest ratio of actual to predicted merit decrease for a step to be taken.
ACCEPT = 0.1
# Stop when the restored total improved by less than this fraction over that
# many accepted steps.
STALL_TOLERANCE = 1e-4
STALL_ITERATIONS = 2
# With a total to beat (``give_up``): the iterations stop once the best
# restored total is above it by more than GIVE_UP_MARGIN, a margin halved
# after every LP (the total falls fastest in the first steps).  A rival
# that gives up must be one that would lose: the caller keeps the other
# plan, so a rival given up too early makes plan() longer than the
# knots-only optimum; one given up too late costs planning time.
GIVE_UP_MARGIN = 0.15
# With a total to beat: a rival whose restored total (or uniform duration) is
# above it by more than this, far above round-off (1e-15), is not going to
# win, and :func:`optimal_durations` returns None without restoring and
# building it.
CANNOT_WIN_RTOL = 1e-9
# Warm start (per-segment scaling): most steps, smallest relative gain per step.
WARM_STEPS = 8
WARM_GAIN = 5e-3
# Penalty on constraint violation, relative to the largest starting duration.
PENALTY = 10.0
# With non-zero boundary values, iterations go on with the exact l1 merit when
# the restored-total merit ends past a limit by more than this log-ratio.
EXACT_MERIT_EXCESS = 1e-4
# An l1 penalty is exact only above the constraints' multipliers: when the l1
# iterations still end past a limit by that much, the penalty grows by this
# factor and they go on, at most this many rounds in all (so that the repair
# below does not have to lengthen such an end point).
PENALTY_GROWTH = 10.0
PENALTY_ROUNDS = 3
# Repair of a final iterate that exceeds a limit (non-zero boundary values):
# penalty factor, largest number of LP steps and the log-ratio margin aimed at
# (above HiGHS's feasibility tolerance, 1e-7; a common factor need not restore
# feasibility here: with boundary values lengthening every segment can raise
# a ratio).
REPAIR_PENALTY = 1e4
REPAIR_ITERATIONS = 10
REPAIR_MARGIN = 1e-6
# Growth of the repair's box when its LP cannot reach the limits within it.
REPAIR_GROWTH = 4.0
# Constraints below this ratio never enter the LP.
_INACTIVE = 1e-3


def _lp_step(state, jac, radius, lower, upper, penalty, merit_penalty=None, margin=0.0):
    """
    Solve the trust-region LP; return (step, predicted merit decrease) or (None, 0).

    The LP minimises the linearised total time within the box
    ``|step| <= radius`` subject to the linearised constraints.  Constraints
    already violated are elastic (a slack each, costing ``penalty``), so the
    LP is always feasible.  Only constraints that can reach their limit
    within the box enter it.  A Jacobian tail (445) enters as running sums
    ``z``, one free variable per segment and joint, tied to the step by
    bidiagonal equalities, so the LP stays sparse.
    """
    T = state['durations']
    log_ratios = state['log_ratios'].reshape(-1)
    reach = radius * jac.abs_row_sums()
    active = np.flatnonzero((log_ratios > np.log(_INACTIVE)) & (log_ratios + reach >= 0.0))
    b_ub = -log_ratios[active] - margin
    if T.size <= DENSE_LP_SEGMENTS:
        step = solve_elastic_lp(T, jac.dense_rows(active), b_ub, np.maximum(-radius, lower),
                                np.minimum(radius, upper), penalty)
        if step is not None:
            return step, _predicted(state, jac, step, merit_penalty)
        # Out of pivots (never seen): HiGHS below.
    A = jac.band[active]
    n_rows, n_seg = A.shape
    n_run = n_seg * jac.n_joints if jac.has_tail else 0
    violated = np.flatnonzero(b_ub < 0.0)
    n_slack = violated.size
    n_var = n_seg + n_run + n_slack
    cost = np.concatenate([T, np.zeros(n_run), np.full(n_slack, penalty)])
    bounds = np.concatenate([
        np.column_stack([np.maximum(-radius, lower), np.minimum(radius, upper)]),
        np.full((n_run, 2), [-np.inf, np.inf]),
        np.column_stack([np.zeros(n_slack), np.full(n_slack, np.inf)])])
    # One constraint matrix: the kept rows, then (445) the running-sum equalities.
    rows = [np.repeat(np.arange(n_rows), np.diff(A.indptr)), violated]
    cols = [A.indices, n_seg + n_run + np.arange(n_slack)]
    vals = [A.data, np.full(n_slack, -1.0)]
    lower_b, upper_b = np.full(n_rows, -np.inf), b_ub
    if n_run:
        tail_rows, running = jac.tail_columns(active)
        rows.append(tail_rows)
        cols.append(n_seg + running)
        vals.append(jac.beta[active[tail_rows]])
        # z[m, j] - z[m - 1, j] - weight[m, j] * step[m] = 0.
        eq = np.arange(n_run)
        later = eq[jac.n_joints:]
        rows += [n_rows + eq, n_rows + later, n_rows + eq]
        cols += [n_seg + eq, n_seg + later - jac.n_joints, eq // jac.n_joints]
        vals += [np.ones(n_run), -np.ones(later.size), -jac.weight.reshape(-1)]
        lower_b = np.concatenate([lower_b, np.zeros(n_run)])
        upper_b = np.concatenate([upper_b, np.zeros(n_run)])
    constraints = ()
    if n_rows + n_run:
        matrix = csc_array((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                           shape=(n_rows + n_run, n_var))
        constraints = LinearConstraint(matrix, lower_b, upper_b)
    # milp without integrality is HiGHS's LP solver with less overhead than linprog.
    result = milp(cost, constraints=constraints, bounds=Bounds(bounds[:, 0], bounds[:, 1]))
    if result.status != 0 or result.x is None:
        return None, 0.0
    step = result.x[:n_seg]
    return step, _predicted(state, jac, step, merit_penalty)


def _model_log_ratios(state, jac, step):
    """Finite log-ratios after ``step`` as the linear model predicts them."""
    log_ratios = state['log_ratios'].reshape(-1)
    return (log_ratios + jac @ step)[np.isfinite(log_ratios)]


def _predicted(state, jac, step, penalty):
    """Decrease of the merit (:func:`_merit`) that the linear model predicts for ``step``."""
    T = state['durations']
    model = _model_log_ratios(state, jac, step)
    if penalty is None:
        value = (T.sum() + T @ step) * np.exp(np.max(model, initial=0.0))
    else:
        value = T.sum() + T @ step + penalty * np.sum(np.maximum(model, 0.0))
    return _merit(state, penalty) - value


def _merit(state, penalty):
    """
    Return the merit of an iterate: :func:`_restored_total`, or with a ``penalty`` l1.

    The restored total is what the final common factor gives when the
    ratios scale exactly with it (rest-to-rest requests).  With non-zero
    boundary values they do not, and the merit is the exact l1 penalty
    function: total time plus ``penalty`` times the summed log-ratio excess.
    """
    if state is None:
        return np.inf
    if penalty is None:
        return _restored_total(state)
    return float(state['durations'].sum() +
                 penalty * np.sum(np.maximum(state['log_ratios'], 0.0)))


def _restored_total(state):
    """
    Return the total time after scaling by the largest ratio (the merit of an iterate).

    Exact for rest-to-rest requests, where every ratio r scales as 1 / factor;
    an estimate otherwise (the final common factor is searched exactly).
    """
    if state is None:
        return np.inf
    # Kept in the state (its durations and ratios do not change): an
    # iteration asks for it up to five times.
    total = state.get('restored_total')
    if total is None:
        total = state['restored_total'] = float(
            state['durations'].sum() * np.exp(max(0.0, np.max(state['log_ratios']))))
    return total


def _rejected_above(state, merit, predicted):
    """
    Return the restored total above which a trial step is rejected, or None.

    A step is taken when the merit falls by more than :data:`ACCEPT` times
    the ``predicted`` decrease; with the restored-total merit and a positive
    prediction, a trial whose total is above ``merit - ACCEPT * predicted``
    is not, so :meth:`PeakRatios.evaluate` may return None for it without
    its exact peaks (the same outcome: a merit of inf is rejected too).
    """
    if merit is not None or not predicted > 0.0:
        return None
    return _merit(state, merit) - ACCEPT * predicted


def _warm_start(ratios, x, state, merit):
    """
    Scale every segment by its own largest ratio while that shortens the restored total.

    Each step is one evaluation (no Jacobian, no LP): ``log T_s -= -log
    max_{j,q} r_{s,j,q}``, which would make every segment bind if the
    segments were independent.  Coupling makes the iteration diverge
    eventually (at once for 445), so steps are kept only while the merit
    (:func:`_merit`) falls by at least :data:`WARM_GAIN`; at most
    :data:`WARM_STEPS`.
    """
    for _ in range(WARM_STEPS):
        per_segment = np.max(state['log_ratios'], axis=(1, 2))
        if not np.all(np.isfinite(per_segment)):
            break
        enough = (1.0 - WARM_GAIN) * _merit(state, merit)
        trial = ratios.evaluate(x + per_segment, enough if merit is None else None)
        if _merit(trial, merit) > enough:
            break
        x, state = x + per_segment, trial
    return x, state


def _at_the_limits(ratios, x, state):
    """
    Return the iterate scaled by a common factor so that its largest ratio is 1 (rest to rest).

    Rest to rest every ratio scales exactly as ``1 / factor``, so this is
    exact and free of an LP.  Started past a limit, the first LPs proposed
    lengthening every segment alike, a step the restored total does not
    reward: on a 3 x 3 request five LPs were rejected, shrinking the trust
    region to 4e-4 before the iterations made progress (15 LPs in all,
    against 3 from the uniform solution).
    """
    excess = float(np.max(state['log_ratios']))
    if not np.isfinite(excess) or excess == 0.0:
        return x, state
    scaled = ratios.evaluate(x + excess)
    if scaled is None:
        return x, state
    return x + excess, scaled


def _beyond_give_up(state, give_up):
    """
    Whether the iterations would give up before their first LP (rest to rest).

    Scaled to its limits (:func:`_at_the_limits`) the iterate's restored
    total is ``sum(T) * exp(largest log-ratio)``, which :func:`_iterate`
    gives up on when it is above ``give_up`` by more than
    :data:`GIVE_UP_MARGIN`: with a margin of :data:`CANNOT_WIN_RTOL` for the
    round-off of that scaling, its evaluation (a good share of a small
    rival's cost) is not needed.
    """
    excess = float(np.max(state['log_ratios']))
    if not np.isfinite(excess):
        return False
    scaled = float(state['durations'].sum()) * np.exp(excess)
    return scaled > give_up * (1.0 + GIVE_UP_MARGIN) * (1.0 + CANNOT_WIN_RTOL)


def minimise_total_time(method, points, start, boundary, limits,
                        stall_tolerance=STALL_TOLERANCE, give_up=None):
    """
    Run the trust-region SLP from the (S,) ``start`` durations.

    Returns (durations, info) where ``info`` counts iterations and
    evaluations.  First the merit is the restored total (fast: violations
    are priced as the common factor would price them); with non-zero
    boundary values, where that is only an estimate, the iterations then go
    on from the best point with the exact l1 merit when that point exceeds a
    limit by more than :data:`EXACT_MERIT_EXCESS` (in log-ratio), with a
    penalty grown by :data:`PENALTY_GROWTH` while the end still does, and the
    end point is repaired (:func:`_repair`).  The durations may still exceed a limit by
    round-off (see the module docstring: feasibility is restored afterwards).
    ``stall_tolerance`` and ``give_up`` as for :func:`_iterate` (its first
    iterations only, with the restored-total merit).
    """
    ratios = PeakRatios(method, points, boundary, limits)
    x = np.log(start)
    bounds = (x + np.log(MIN_FRACTION), x + np.log(MAX_FRACTION))
    penalty = PENALTY * float(np.max(start))
    state = ratios.evaluate(x)
    if state is None:
        return start, {'iterations': 0, 'evaluations': ratios.evaluations,
                       'message': 'singular at the start', 'worst_log_ratio': np.inf}
    x, state = _warm_start(ratios, x, state, None)
    if not any(np.any(b) for b in boundary):
        if give_up is not None and _beyond_give_up(state, give_up):
            return np.exp(x), {'iterations': 0, 'evaluations': ratios.evaluations,
                               'message': 'gave up: cannot beat the given total',
                               'worst_log_ratio': float(np.max(state['log_ratios']))}
        x, state = _at_the_limits(ratios, x, state)
    x, state, iterations, message, radius, bounds = _iterate_in_box(
        ratios, x, state, bounds, penalty, None, INITIAL_RADIUS, stall_tolerance, give_up)
    if any(np.any(b) for b in boundary):
        merit = penalty
        for _ in range(PENALTY_ROUNDS):
            if np.max(state['log_ratios']) <= EXACT_MERIT_EXCESS:
                break
            x, state, more, message, radius, bounds = _iterate_in_box(
                ratios, x, state, bounds, merit, merit, radius)
            iterations += more
            merit *= PENALTY_GROWTH
        x, state, repairs = _repair(ratios, x, state, bounds[1], penalty)
        iterations += repairs
    return np.exp(x), {'iterations': iterations, 'evaluations': ratios.evaluations,
                       'message': message,
                       'worst_log_ratio': float(np.max(state['log_ratios']))}


def _iterate_in_box(ratios, x, state, bounds, penalty, merit, radius,
                    stall_tolerance=STALL_TOLERANCE, give_up=None):
    """
    Run :func:`_iterate`; where it ends on the box ``bounds``, widen it around that end and go on.

    The box is the start's (:data:`MIN_FRACTION`, :data:`MAX_FRACTION`), not
    the request's: a caller's start can be far off.  So is the LP's price
    of a violation (``penalty``, with the restored-total merit), which moves
    with the box.  At most :data:`BOX_MOVES` times; returns what
    :func:`_iterate` does, the LPs of every run summed, and the last box.
    """
    x, state, iterations, message, radius = _iterate(ratios, x, state, bounds, penalty, merit,
                                                     radius, stall_tolerance, give_up)
    for _ in range(BOX_MOVES):
        lower, upper = bounds
        on_the_box = np.any(x <= lower + BOX_EDGE) or np.any(x >= upper - BOX_EDGE)
        if message.startswith('gave up') or not on_the_box:
            break
        bounds = (np.minimum(lower, x + np.log(MIN_FRACTION)),
                  np.maximum(upper, x + np.log(MAX_FRACTION)))
        if merit is None:
            # The LP's price of a violation was the start's too (PENALTY times its
            # longest duration): a start far too short left it 10-100 times too low.
            penalty = max(penalty, PENALTY * float(np.max(np.exp(x))))
        x, state, more, message, radius = _iterate(ratios, x, state, bounds, penalty, merit,
                                                   INITIAL_RADIUS, stall_tolerance, give_up)
        iterations += more
    return x, state, iterations, message, radius, bounds


def _iterate(ratios, x, state, bounds, penalty, merit, radius,
             stall_tolerance=STALL_TOLERANCE, give_up=None):
    """
    Take trust-region SLP steps with the merit ``merit`` (see :func:`_merit`).

    Returns the best iterate, its state, the number of LPs, why it stopped
    and the last radius.  Stops when the LP predicts less than
    :data:`RELATIVE_TOLERANCE` of the total, or when the merit improved by
    less than ``stall_tolerance`` over :data:`STALL_ITERATIONS` accepted
    steps.  ``give_up``, a total to beat (the restored-total merit only):
    stops before the k-th LP when the best merit is still above it by more
    than :data:`GIVE_UP_MARGIN` times ``0.5**k`` (a caller that keeps the
    shorter of this result and another plan, which this one is not going to
    beat).
    """
    lower_x, upper_x = bounds
    message = 'iteration limit reached'
    iteration = 0
    jac = None
    best_x, best_state, best = x, state, _merit(state, merit)
    history = [best]
    if merit is not None:
        give_up = None
    while iteration < MAX_ITERATIONS:
        if give_up is not None and best > give_up * (1.0 + GIVE_UP_MARGIN * 0.5 ** iteration):
            message = 'gave up: cannot beat the given total'
            break
        iteration += 1
        if jac is None:
            jac = ratios.jacobian(state)
        step, predicted = _lp_step(state, jac, radius, lower_x - x, upper_x - x, penalty, merit)
        if step is None:
            message = 'LP failed'
            break
        if predicted <= RELATIVE_TOLERANCE * state['durations'].sum():
            excess = float(np.max(state['log_ratios']))
            if merit is None and excess > RELATIVE_TOLERANCE:
                # The LP prices violations above what the common factor would
                # cost (the restored total): rescale to the limits, then go on.
                rescaled = ratios.evaluate(x + excess)
                if rescaled is not None:
                    x, state, jac = x + excess, rescaled, None
                    continue
            message = 'converged'
            break
        trial = ratios.evaluate(x + step, _rejected_above(state, merit, predicted))
        rho = (_merit(state, merit) - _merit(trial, merit)) / predicted
        if not rho > ACCEPT:    # (a NaN, from an infinite prediction, is no gain either)
            # Before a new LP, try half the step (an evaluation only).
            step = 0.5 * step
            predicted = _predicted(state, jac, step, merit)
            trial = ratios.evaluate(x + step, _rejected_above(state, merit, predicted))
            rho = (_merit(state, merit) - _merit(trial, merit)) / predicted
            if not rho > ACCEPT:
                radius = SHRINK * np.max(np.abs(step))
                if radius < MIN_RADIUS:
                    message = 'trust region collapsed'
                    break
                continue
            radius = np.max(np.abs(step))
        x, state, jac = x + step, trial, None
        if rho > 0.75 and np.max(np.abs(step)) > 0.9 * radius:
            radius = min(2.0 * radius, MAX_RADIUS)
        value = _merit(state, merit)
        if value < best:
            best_x, best_state, best = x, state, value
        history.append(best)
        if (len(history) > STALL_ITERATIONS and
                history[-1 - STALL_ITERATIONS] - best < stall_tolerance * best):
            message = 'stalled'
            break
    return best_x, best_state, iteration, message, radius


def _repair(ratios, x, state, upper_x, penalty):
    """
    Bring an iterate that exceeds a limit back to the limits by LP steps.

    Returns the repaired ``x``, its state and the number of LP steps.

    With non-zero boundary values the ratios do not scale with a common
    factor, so the point the restored-total merit ends at, once scaled, is
    not a local optimum (its binding constraints do not all come back to
    their limits).  Here the violations are removed instead by LP steps that
    only lengthen segments, with every constraint hard (a penalty
    :data:`REPAIR_PENALTY` times larger), taken while they reduce the
    largest violation.  A step that does not is retried in a smaller box,
    unless the linear model itself stays past a limit: then the box is too
    small to reach the limits (several constraints meet there, and the way
    out is long), and it grows by :data:`REPAIR_GROWTH`.
    """
    steps = 0
    radius = 4.0 * max(float(np.max(state['log_ratios'])), REPAIR_MARGIN)
    while steps < REPAIR_ITERATIONS:
        worst = float(np.max(state['log_ratios']))
        if worst <= 0.0:
            break
        steps += 1
        jac = ratios.jacobian(state)
        step, _ = _lp_step(state, jac, radius, np.zeros_like(x), upper_x - x,
                           REPAIR_PENALTY * penalty, margin=REPAIR_MARGIN)
        if step is None:
            break
        trial = ratios.evaluate(x + step)
        if trial is None or np.max(trial['log_ratios']) >= worst:
            if np.max(_model_log_ratios(state, jac, step), initial=0.0) > 0.0:
                radius = min(REPAIR_GROWTH * radius, MAX_RADIUS)
            else:
                radius *= SHRINK
            continue
        x, state = x + step, trial
    return x, state, steps


def _restoring_factor(spline, limits, worst_log_ratio):
    """
    Return the common factor that makes the optimised durations feasible, and the ratios.

    The iterate ends within round-off of the limits (or slightly past them),
    so the factor ``exp(worst log-ratio)`` is tried first (exact for
    rest-to-rest requests); when it does not meet every limit exactly (a
    non-zero boundary value), the smallest feasible factor is searched as in
    uniform timing.  Raises ValueError when there is none.
    """
    factor = float(np.exp(max(worst_log_ratio, 0.0)))
    if worst_log_ratio > 0.0:
        factor *= 1.0 + 1e-12
    if np.isfinite(factor):
        ratios = limit_ratios(spline.coefficients(factor), spline.durations(factor), limits)
        if np.max(ratios) <= 1.0:
            return factor, ratios
    return uniform_scale(spline, limits)


def _restored(candidate, info):
    """Return the total of ``candidate`` durations scaled to the limits (rest to rest)."""
    return float(candidate.sum()) * np.exp(max(info['worst_log_ratio'], 0.0))


def _from_uniform_too(method, points, boundary, limits, stall_tolerance, give_up, candidate,
                      info, uniform, uniform_at_least):
    """
    After a rival gave up, run it again from the uniform solution where that starts lower.

    A warm start far from the optimum (from another plan's durations) can
    give up on a rival that the uniform solution's start would have let win,
    and plan() then returns a plan longer than the knots-only optimum
    (doc/methods.md, "Where the constants come from").  Only where the
    uniform solution (``uniform_at_least`` bounds its duration) is below
    both the restored total given up on and the first give-up threshold:
    rarely, since a rival that loses is mostly above the plan to beat from
    any start.  Returns the better of the two runs, its info (evaluations
    of both), ``uniform`` (built when it was needed) and the bound (its
    duration once built).
    """
    threshold = min(_restored(candidate, info), give_up * (1.0 + GIVE_UP_MARGIN))
    if uniform is None or uniform_at_least is None or not uniform_at_least < threshold:
        return candidate, info, uniform, uniform_at_least
    if callable(uniform):
        uniform = uniform()
    if not uniform.duration < threshold:
        return candidate, info, uniform, uniform.duration
    again, more = minimise_total_time(method, points, uniform.durations, boundary, limits,
                                      stall_tolerance, give_up)
    more['evaluations'] += info['evaluations']
    more['restarted'] = 'from the uniform solution'
    if _restored(again, more) < _restored(candidate, info):
        return again, more, uniform, uniform.duration
    info['evaluations'] = more['evaluations']
    return candidate, info, uniform, uniform.duration


def optimal_durations(method, points, start, boundary, limits, dropped, uniform=None,
                      stall_tolerance=STALL_TOLERANCE, give_up=None, uniform_at_least=None):
    """
    Plan with time-optimal durations, starting from the (S,) ``start`` durations.

    ``uniform`` is the feasible uniform-timing trajectory (kept when not
    longer), or None when uniform timing found no feasible factor; the
    optimiser then starts from infeasible durations and its elastic
    constraints pull it into the feasible set.  Raises ValueError when the
    result cannot be made feasible.  ``stall_tolerance`` and ``give_up``
    (a total to beat, rest to rest) as for :func:`_iterate`: for a rival
    that only counts when shorter than another plan.  With ``give_up``,
    ``uniform`` may be a function that builds that trajectory (called only
    when needed) and ``uniform_at_least`` a lower bound of its duration,
    and the result is None when both the optimum's restored total and the
    uniform duration (or that bound) are above ``give_up`` by more than
    :data:`CANNOT_WIN_RTOL`: the rival has lost, and restoring and building
    it is skipped.
    """
    name = get_method(method).name
    candidate, info = minimise_total_time(method, points, start, boundary, limits,
                                          stall_tolerance, give_up)
    if give_up is not None:
        if uniform is not None and not callable(uniform):
            uniform_at_least = uniform.duration
        if info['message'].startswith('gave up'):
            candidate, info, uniform, uniform_at_least = _from_uniform_too(
                method, points, boundary, limits, stall_tolerance, give_up, candidate, info,
                uniform, uniform_at_least)
        beaten = give_up * (1.0 + CANNOT_WIN_RTOL)
        restored = _restored(candidate, info)
        if restored > beaten and (uniform is None or (uniform_at_least is not None
                                                      and uniform_at_least > beaten)):
            return None
        if callable(uniform):
            uniform = uniform()
    refined = ScaledSpline(method, points, candidate, boundary)
    try:
        factor, ratios = _restoring_factor(refined, limits, info.pop('worst_log_ratio'))
        durations, coeffs = refined.durations(factor), refined.coefficients(factor)
    except ValueError:
        if uniform is None:
            raise ValueError('infeasible: neither uniform nor optimal timing found durations '
                             'that meet the limits with these boundary velocities and '
                             'accelerations') from None
        durations = None
    if uniform is not None and (durations is None or durations.sum() >= uniform.duration):
        durations, coeffs, ratios = uniform.durations, uniform.coefficients, uniform.limit_ratios()
    traj = Trajectory.build(name, 'optimal', points, durations, boundary, limits, coeffs,
                            ratios, dropped_waypoints=dropped)
    info['uniform_duration'] = None if uniform is None else uniform.duration
    traj.optimizer = info
    return traj


def two_segment_search(method, points, start, limits):
    """
    Return the :class:`ratio_search.RatioSearch` of a two-segment rest-to-rest request.

    From the (2,) ``start`` durations (the chords' when None), with the
    uniform solution's ratio among the first pass's: its plan is never
    longer than uniform timing's.
    """
    chords = chord_durations(points)
    also = [float(np.log(chords[0] / chords[1]))]
    return RatioSearch(method, points, chords if start is None else start, limits, also)


def two_segment_plan(method, points, limits, dropped, search, give_up=None):
    """
    Plan a rest-to-rest request of two segments with time-optimal durations, or return None.

    The optimum of the restored total over the ratio of the two durations
    (``search``, a :func:`two_segment_search`), brought exactly to the
    limits by the closed-form common factor.  With ``give_up`` (a total to
    beat), None when the search shows that it cannot beat it, or when the
    plan is longer.  Raises ValueError when a continuity system is singular
    (the caller then runs :func:`optimal_durations`).
    """
    if give_up is not None and search.cannot_beat(give_up):
        return None
    durations, log_factor = search.result()
    zero = np.zeros(points.shape[1])
    boundary = (zero, zero, zero, zero)
    # Slowed down by its factor (and 1e-12 for the round-off of its terms
    # and ratios, which scale with it exactly; Trajectory.build solves again
    # if the PPoly's widths differ from the durations).
    factor = np.exp(log_factor) * (1.0 + 1e-12)
    durations = durations * factor
    coeffs = search.terms / factor ** np.arange(6)[None, :, None]
    ratios = search.ratios / factor ** np.arange(1, 4)
    traj = Trajectory.build(get_method(method).name, 'optimal', points, durations, boundary,
                            limits, coeffs, ratios, dropped_waypoints=dropped)
    if give_up is not None and traj.duration > give_up * (1.0 + CANNOT_WIN_RTOL):
        return None
    traj.optimizer = {'iterations': 0, 'passes': search.passes, 'message': 'converged',
                      'uniform_duration': None}
    return traj
