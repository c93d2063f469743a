"""
What issue 38's shaking target costs in time, on straight moves: a lower bound, by LP (one run).

Issue 38 asks for plans no longer than TOPP-RA's *and* shaking a 4 Hz and an
8 Hz mode at most 0.5 (peak) and 0.2 (residual) times as much as TOPP-RA
does (:mod:`shaking`).  No mechanism measured so far does both.  This bench
asks whether any can: on a straight rest-to-rest move the set of all
trajectories is convex in time, so a linear programme gives the *least*
shaking that any trajectory of a given duration can have, and the *shortest*
duration at which the target can hold at all.

A straight move from ``q0`` to ``q1`` is ``q(t) = q0 + u(t) (q1 - q0)`` with
a scalar ``u`` from 0 to 1, at rest at both ends.  Its limits are the
tightest joint's: ``u' <= min_i v_i / |d_i|``, the same for ``a`` and ``j``.
Each joint's mode is driven by ``u'' d_i`` and :mod:`shaking` divides its
deflection by ``a_i / w**2``, so the figure of the move is the one of ``u``
over the acceleration-limiting joint's: every joint count reduces to this
scalar problem, exactly.

The programme (:func:`least_shaking`) samples ``u''`` every millisecond (the
rate :mod:`shaking` samples at) and joins the samples by straight lines, so
the jerk limit is ``|a_{k+1} - a_k| <= j dt`` and velocity and position
integrate exactly (trapezoid and Simpson-like weights).  Each mode is its
exact response to that input (first-order hold: the matrix exponential of
the augmented system), as two state rows per sample, so the peak over the
samples and the residual (the free ringing over the periods :mod:`shaking`
watches after the end) are linear.  The objective is the smallest ``t`` with
every mode's peak ``<= t`` times its bound and residual ``<= t`` times its
bound.  A trajectory's figures from :mod:`shaking` (which holds each 1 ms
sample constant) agree with the programme's to about 1e-5 of TOPP-RA's (the
bench prints the largest difference: it checks itself).
The one approximation: between two samples ``u''`` is a straight line; any
jerk-limited ``u''`` has the same samples (all :mod:`shaking` sees) as its
straight-line interpolant, which also holds the limits, and moves the end
position by ``O(j dt**2 T)`` (about 1e-5 of the move).

Rows, per random move (``bench_inner_knots``' limits: v in [1, 3] rad/s,
a in [5, 15] rad/s**2, j = 20 a; 3 to 7 joints; each joint moving
``U(-L, L)`` with ``L`` in [0.5, 3] rad), all over TOPP-RA's duration on the
same move:

* the shortest duration any trajectory has with these v/a/j limits (the
  jerk limit alone already costs this over TOPP-RA's, which has none);
* ``plan()``'s default and ``speed_profile=time_optimal``: duration, 4 Hz
  peak, and the least 4 Hz peak any trajectory of that duration can have;
* the shortest duration at which the target can hold: at 4 Hz, at 8 Hz,
  and at both (peak <= 0.5, residual <= 0.2 of TOPP-RA's; bisection on the
  duration to 0.5 %).

A second table asks the same of waypoint requests (``bench_inner_knots``'
random requests, their first :data:`WAYPOINTS` points), where the path is
free: the programme is solved per joint, each passing its waypoint values
at time_optimal's waypoint times (stretched to TOPP-RA's duration where
shorter), with samples :data:`WAYPOINT_STEP` apart and the mode's exact
response to a straight-line acceleration between them.  Fixing the times
makes it a restriction, not a bound: its trajectory *exists* (checked at
0.1 ms: waypoints, v, a, j), so where it meets the target, the target is
physically reachable at that duration, by a path other than plan()'s.
That trajectory is C2 with a jerk limit (its jerk steps every sample), not
C4 as plan()'s are.

Usage: ``python benchmarks/bench_shaking_bound.py`` (``SPLINES445_BENCH_SEED``
repeats a run, ``SPLINES445_BENCH_CASES`` sets how many moves and requests;
default 8 and 4).
"""

import logging
import os
import time

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_inner_knots import random_case  # noqa: E402, I100
from bench_planning import toppra_trajectory  # noqa: E402
import bench_seeds  # noqa: E402
import highspy  # noqa: E402
import numpy as np  # noqa: E402
from scipy import sparse  # noqa: E402
from scipy.linalg import expm  # noqa: E402
import shaking  # noqa: E402
from shaking import of_toppra, of_trajectory, shaking_figures  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402

N_CASES = 8
CASES_STREAM = 38
WAYPOINTS_STREAM = 39
DT = 1.0 / shaking.RATE
JERK_RATIO = 20.0
PEAK_TARGET = 0.5
RESIDUAL_TARGET = 0.2
WAYPOINTS = 10  # the waypoint requests' first points: the programme grows with the duration
WAYPOINT_STEP = 0.004  # s between the programme's samples on waypoint requests
N_WAYPOINT_CASES = 4
BISECTION = 0.005  # relative width at which the shortest duration is reported
LP_SOLVERS = ({'solver': 'ipm'}, {'solver': 'simplex'}, {'solver': 'ipm', 'run_crossover': 'off'},
              {'solver': 'simplex', 'simplex_strategy': 4})  # :func:`_solve`, in turn
LP_SECONDS = 60.0  # per solve: a bench's bound, not a result (a solve that stops is no answer)


def mode_model(frequency, step, zeta=shaking.ZETA):
    """
    Return (Ad, B0, B1): the mode of :mod:`shaking` over one ``step``, input linear in between.

    ``x_{k+1} = Ad x_k + B0 a_k + B1 a_{k+1}`` is exact for an acceleration
    that is a straight line between the samples (first-order hold; the
    matrix exponential of the augmented system), state ``(x, x')``.
    """
    w = 2.0 * np.pi * frequency
    augmented = np.zeros((4, 4))
    augmented[:2, :2] = np.array([[0.0, 1.0], [-w * w, -2.0 * zeta * w]]) * step
    augmented[1, 2] = -step
    augmented[2, 3] = 1.0
    exponential = expm(augmented)
    return exponential[:2, :2], exponential[:2, 2] - exponential[:2, 3], exponential[:2, 3]


class _Rows:
    """Sparse rows of a linear programme, appended in blocks."""

    def __init__(self):
        self.rows, self.cols, self.vals, self.rhs = [], [], [], []

    def add(self, cols, vals, rhs):
        """Append one row per entry of ``rhs``; ``cols``/``vals`` are (rows, terms)."""
        cols = np.atleast_2d(cols)
        first = len(self.rhs)
        self.rows.append(np.repeat(np.arange(first, first + cols.shape[0]), cols.shape[1]))
        self.cols.append(cols.ravel())
        self.vals.append(np.broadcast_to(vals, cols.shape).ravel())
        self.rhs.extend(np.broadcast_to(rhs, (cols.shape[0],)))

    def matrix(self, n_variables):
        """Return the rows as a CSR matrix and their right-hand side."""
        return (sparse.coo_matrix((np.concatenate(self.vals),
                                   (np.concatenate(self.rows), np.concatenate(self.cols))),
                                  shape=(len(self.rhs), n_variables)).tocsr(),
                np.asarray(self.rhs, float))


def least_shaking(step, marks, values, vmax, amax, jmax, modes):
    """
    Return (t, accelerations): the least shaking of one joint through its waypoints.

    The joint is at rest at the first and the last sample and at ``values[i]``
    at sample ``marks[i]`` (samples ``step`` apart, the last mark the end);
    it holds ``vmax``, ``amax`` and ``jmax``.  ``modes`` is a list of
    (frequency, peak bound, residual bound or None) in :mod:`shaking`'s units
    (the static deflection at ``amax``).  ``t`` is the smallest factor with
    every peak and residual ``<= t`` times its bound (module docstring);
    (None, None) when no trajectory holds the limits or HiGHS fails.
    Variables are scaled to order one (acceleration over ``amax``, velocity
    over ``vmax``, position over ``vmax step``, the deflection in the
    figure's unit ``amax / w**2`` and its rate in ``amax / w``): unscaled,
    HiGHS failed on some of these programmes.
    """
    m = int(marks[-1]) + 1
    acc = np.arange(m)
    vel = m + acc
    pos = 2 * m + acc
    states = [3 * m + 2 * (m * k + acc) for k in range(len(modes))]
    factor = 3 * m + 2 * m * len(modes)
    n_variables = factor + 1
    k = acc[:-1]
    h = amax * step / vmax
    eq = _Rows()
    eq.add([[acc[0]], [acc[-1]], [vel[0]], [vel[-1]]], [1.0], 0.0)
    # v_{k+1} = v_k + (a_k + a_{k+1}) step / 2 and p_{k+1} = p_k + v_k step
    # + (2 a_k + a_{k+1}) step**2 / 6: exact for a straight line between samples
    eq.add(np.column_stack([vel[k + 1], vel[k], acc[k], acc[k + 1]]),
           [1.0, -1.0, -h / 2.0, -h / 2.0], 0.0)
    eq.add(np.column_stack([pos[k + 1], pos[k], vel[k], acc[k], acc[k + 1]]),
           [1.0, -1.0, -1.0, -h / 3.0, -h / 6.0], 0.0)
    eq.add(pos[np.asarray(marks)][:, None], [1.0], np.asarray(values, float) / (vmax * step))
    ub = _Rows()
    ub.add(np.column_stack([acc[k + 1], acc[k]]), [1.0, -1.0], jmax * step / amax)
    ub.add(np.column_stack([acc[k + 1], acc[k]]), [-1.0, 1.0], jmax * step / amax)
    for (frequency, peak, residual), state in zip(modes, states):
        ad, b0, b1 = mode_model(frequency, step)
        w = 2.0 * np.pi * frequency
        unit = np.array([1.0, w])
        ad = ad * unit[None, :] / unit[:, None]
        b0, b1 = b0 * w * w / unit, b1 * w * w / unit
        eq.add([[state[0]], [state[0] + 1]], [1.0], 0.0)
        for i in range(2):
            eq.add(np.column_stack([state[k + 1] + i, state[k], state[k] + 1, acc[k],
                                    acc[k + 1]]),
                   [1.0, -ad[i, 0], -ad[i, 1], -b0[i], -b1[i]], 0.0)
        every = np.column_stack([state, np.full(m, factor)])
        ub.add(every, [1.0, -peak], 0.0)
        ub.add(every, [-1.0, -peak], 0.0)
        if residual is not None:
            ringing = [np.eye(2)]
            for _ in range(int(np.ceil(shaking.RESIDUAL_PERIODS / (frequency * step)))):
                ringing.append(ad @ ringing[-1])
            first = np.array([power[0] for power in ringing])
            end = np.tile([state[-1], state[-1] + 1, factor], (len(first), 1))
            ub.add(end, np.column_stack([first, np.full(len(first), -residual)]), 0.0)
            ub.add(end, np.column_stack([-first, np.full(len(first), -residual)]), 0.0)
    a_eq, b_eq = eq.matrix(n_variables)
    a_ub, b_ub = ub.matrix(n_variables)
    bounds = np.full((n_variables, 2), -np.inf)
    bounds[:, 1] = np.inf
    bounds[acc] = (-1.0, 1.0)
    bounds[vel] = (-1.0, 1.0)
    bounds[factor] = (0.0, np.inf)
    cost = np.zeros(n_variables)
    cost[factor] = 1.0
    x = _solve(cost, sparse.vstack([a_eq, a_ub]).tocsr(),
               np.concatenate([b_eq, np.full(b_ub.size, -np.inf)]),
               np.concatenate([b_eq, b_ub]), bounds)
    if x is None:
        return None, None
    return float(x[factor]), x[acc] * amax


def _solve(cost, rows, lower, upper, bounds):
    """
    Return the minimiser of ``cost x`` with ``lower <= rows x <= upper``, or None.

    HiGHS's presolve crashed (a segmentation fault, in scipy 1.17's HiGHS
    and in highspy 1.15) on some of these programmes, so it is off.  The
    interior point method first (3-4 x faster here); where it fails or finds
    no solution (it declared some feasible programmes infeasible), the dual
    simplex, whose "infeasible" is final; where that fails too, the interior
    point method without crossover (its solution within HiGHS's tolerances:
    the waypoint table checks its trajectories at 0.1 ms), then the primal
    simplex.
    """
    for options in LP_SOLVERS:
        highs = highspy.Highs()
        highs.setOptionValue('output_flag', False)
        highs.setOptionValue('time_limit', LP_SECONDS)
        highs.setOptionValue('presolve', 'off')
        for name, value in options.items():
            highs.setOptionValue(name, value)
        highs.passModel(cost.size, rows.shape[0], rows.nnz, 2, 1, 0.0, cost,
                        bounds[:, 0], bounds[:, 1], lower, upper,
                        rows.indptr[:-1].astype(np.int32), rows.indices.astype(np.int32),
                        rows.data, np.zeros(cost.size, np.int32))
        highs.run()
        status = highs.getModelStatus()
        if status == highspy.HighsModelStatus.kOptimal:
            return np.asarray(highs.getSolution().col_value)
        if status == highspy.HighsModelStatus.kInfeasible and options['solver'] == 'simplex':
            return None
    return None


def shortest_steps(low, holds):
    """Return the least step count >= ``low`` at which ``holds(steps)``, to :data:`BISECTION`."""
    high = max(low, 1)
    while not holds(high):
        low, high = high, int(np.ceil(high * 1.25)) + 1
    while high - low > max(1, BISECTION * high):
        middle = (low + high) // 2
        if holds(middle):
            high = middle
        else:
            low = middle
    return high


def random_move(rng):
    """One straight request: start and end (n,), v, a limits (n,)."""
    n_joints = int(rng.integers(3, 8))
    reach = rng.uniform(0.5, 3.0)
    start = rng.uniform(-1.0, 1.0, n_joints)
    return (start, start + rng.uniform(-reach, reach, n_joints),
            rng.uniform(1.0, 3.0, n_joints), rng.uniform(5.0, 15.0, n_joints))


def scalar_limits(start, end, vmax, amax):
    """Return ``u``'s v, a, j limits: the tightest joint's (module docstring)."""
    span = np.abs(end - start)
    span = np.where(span > 0.0, span, np.inf)
    a = float(np.min(amax / span))
    return float(np.min(vmax / span)), a, JERK_RATIO * a


def measure(rng, checks):
    """Return one move's figures (dict), appending the programme's self-check to ``checks``."""
    start, end, vmax, amax = random_move(rng)
    waypoints = np.vstack([start, end])
    top = toppra_trajectory(waypoints, vmax, amax)
    reference = shaking_figures(of_toppra(top), top.duration, amax)
    v, a, j = scalar_limits(start, end, vmax, amax)
    row = {}

    def steps_of(duration):
        return int(np.ceil(duration / DT - 1e-9))

    def solve(steps, frequencies, peak_share=1.0, residual_share=None):
        modes = [(f, peak_share * reference[f][0],
                  None if residual_share is None else residual_share * reference[f][1])
                 for f in frequencies]
        return least_shaking(DT, [0, steps], [0.0, 1.0], v, a, j, modes)

    def target_holds(steps, frequencies):
        least = solve(steps, frequencies, PEAK_TARGET, RESIDUAL_TARGET)[0]
        return least is not None and least <= 1.0 + 1e-9

    fastest = shortest_steps(steps_of(top.duration) - 1,
                             lambda n: solve(n, [])[0] is not None)
    row['fastest'] = fastest * DT / top.duration
    for name, options in (('default', {}), ('time_optimal', {'speed_profile': 'time_optimal'})):
        traj = plan(waypoints, '555', 'optimal', max_velocity=vmax, max_acceleration=amax,
                    max_jerk=JERK_RATIO * amax, **options)
        ours = shaking_figures(of_trajectory(traj), traj.duration, amax)
        least, samples = solve(steps_of(traj.duration), [4.0])
        row[name] = (traj.duration / top.duration, ours[4.0][0] / reference[4.0][0],
                     np.nan if least is None else least)
        if least is not None:
            joints = np.outer(samples, end - start)
            measured = shaking_figures(_acceleration_of(joints, DT), len(samples) * DT - DT,
                                       amax)[4.0][0]
            checks.append(abs(measured / reference[4.0][0] - least))
    for name, frequencies in (('4 Hz', [4.0]), ('8 Hz', [8.0]), ('both', [4.0, 8.0])):
        steps = shortest_steps(fastest, lambda n: target_holds(n, frequencies))
        row[name] = steps * DT / top.duration
    return row


def _acceleration_of(samples, step):
    """``acceleration_of`` (:mod:`shaking`) of the programme's samples (m, n), ``step`` apart."""
    times = np.arange(len(samples)) * step
    return lambda t: np.column_stack([np.interp(t, times, column) for column in samples.T])


def measure_waypoints(rng, checks):
    """
    Return one waypoint request's figures: the default, time_optimal, the programme's trajectory.

    The programme's trajectory passes every waypoint at time_optimal's times
    (stretched to TOPP-RA's duration where shorter, rounded to
    :data:`WAYPOINT_STEP`), each joint on its own (any path), and
    has the least of both modes' shaking (:func:`least_shaking` against the
    issue's target).  Its figures are measured again by :mod:`shaking`, and
    its largest waypoint error and v/a/j ratios go to ``checks``.
    """
    waypoints, vmax, amax = random_case(rng)
    waypoints = waypoints[:WAYPOINTS]
    top = toppra_trajectory(waypoints, vmax, amax)
    reference = shaking_figures(of_toppra(top), top.duration, amax)

    def ratios(acceleration_of, duration):
        ours = shaking_figures(acceleration_of, duration, amax)
        return [duration / top.duration] + [ours[f][i] / reference[f][i]
                                            for f in shaking.FREQUENCIES for i in (0, 1)]

    row = {}
    for name, options in (('default', {}), ('time_optimal', {'speed_profile': 'time_optimal'})):
        traj = plan(waypoints, '555', 'optimal', max_velocity=vmax, max_acceleration=amax,
                    max_jerk=JERK_RATIO * amax, **options)
        row[name] = ratios(of_trajectory(traj), traj.duration)
    # time_optimal's waypoint times, stretched to TOPP-RA's duration where shorter (the
    # target's bound: at time_optimal's own, rounding the times to the samples can make
    # its tight v/a/j infeasible)
    duration = max(traj.duration, top.duration)
    steps = int(np.ceil(duration / WAYPOINT_STEP))
    marks = np.round(traj.waypoint_times / traj.duration * steps).astype(int)
    waypoints = np.delete(waypoints, traj.dropped_waypoints, axis=0)  # as the times count them
    modes = [(f, PEAK_TARGET * reference[f][0], RESIDUAL_TARGET * reference[f][1])
             for f in shaking.FREQUENCIES]
    solved = [least_shaking(WAYPOINT_STEP, marks, waypoints[:, i], vmax[i], amax[i],
                            JERK_RATIO * amax[i], modes) for i in range(len(vmax))]
    if any(samples is None for _, samples in solved):
        row['programme'] = [np.nan] * 5
        return row
    samples = np.column_stack([samples for _, samples in solved])
    row['programme'] = ratios(_acceleration_of(samples, WAYPOINT_STEP), steps * WAYPOINT_STEP)
    checks.append(_check(samples, waypoints, marks, vmax, amax))
    return row


def _check(samples, waypoints, marks, vmax, amax):
    """Return the waypoint error and the v, a, j ratios of the programme's trajectory, 0.1 ms."""
    fine = 0.1e-3
    grid = np.arange(0.0, (len(samples) - 1) * WAYPOINT_STEP + fine / 2, fine)
    acc = _acceleration_of(samples, WAYPOINT_STEP)(grid)
    vel = np.vstack([0.0 * acc[0], np.cumsum(acc[1:] + acc[:-1], axis=0) * fine / 2])
    pos = waypoints[0] + np.vstack([0.0 * acc[0],
                                    np.cumsum(vel[1:] + vel[:-1], axis=0) * fine / 2])
    at = np.round(marks * WAYPOINT_STEP / fine).astype(int)
    jerk = np.abs(np.diff(samples, axis=0)) / WAYPOINT_STEP
    return (np.max(np.abs(pos[at] - waypoints)), np.max(np.abs(vel) / vmax),
            np.max(np.abs(acc) / amax), np.max(jerk / (JERK_RATIO * amax)))


def _percent(values):
    """Median / worst of ratios, as a table cell (a programme HiGHS failed on is left out)."""
    return f'{np.nanmedian(values):.3f} / {np.nanmax(values):.3f}'


def main():
    """Run the straight moves, then the waypoint requests, and print their tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    seed = bench_seeds.run_seed()
    n_cases = bench_seeds.case_count(N_CASES)
    rng = bench_seeds.generator(CASES_STREAM)
    rows, checks = [], []
    started = time.perf_counter()
    for _ in range(n_cases):
        rows.append(measure(rng, checks))
    print(f'{n_cases} random straight rest-to-rest moves (seed {seed}, stream {CASES_STREAM}), '
          f"j = {JERK_RATIO:g} a; every figure over TOPP-RA's on the same move, "
          'median / worst (the worst is the largest).')
    print()
    print('| what | duration | 4 Hz peak | least 4 Hz peak at that duration (moves whose LP '
          'failed: left out) |')
    print('|---|---|---|---|')
    print(f'| shortest with v/a/j (no shaking bound) | {_percent([r["fastest"] for r in rows])} '
          '| | |')
    for name in ('default', 'time_optimal'):
        values = np.array([r[name] for r in rows])
        failed = int(np.sum(np.isnan(values[:, 2])))
        print(f'| `plan()` {name} | {_percent(values[:, 0])} | {_percent(values[:, 1])} '
              f'| {_percent(values[:, 2])} ({failed} of {len(values)} left out) |')
    print()
    print(f'Shortest duration at which any trajectory has peak <= {PEAK_TARGET:g} and residual '
          f"<= {RESIDUAL_TARGET:g} of TOPP-RA's (issue 38's target), over TOPP-RA's:")
    print()
    print('| modes | median / worst | moves at <= 1.00 |')
    print('|---|---|---|')
    for name in ('4 Hz', '8 Hz', 'both'):
        values = np.array([r[name] for r in rows])
        print(f'| {name} | {_percent(values)} | {int(np.sum(values <= 1.0))} of {len(values)} |')
    print()
    print(f"Self-check: the programme's least peak against shaking.py's figure of its own "
          f"trajectory differs by at most {max(checks, default=np.nan):.1e} (of TOPP-RA's peak). "
          f'{time.perf_counter() - started:.0f} s.')
    print()
    n_waypoint_cases = bench_seeds.case_count(N_WAYPOINT_CASES)
    rng = bench_seeds.generator(WAYPOINTS_STREAM)
    rows, checks = [], []
    for _ in range(n_waypoint_cases):
        rows.append(measure_waypoints(rng, checks))
    print(f"{n_waypoint_cases} random waypoint requests (bench_inner_knots' requests, their first "
          f'{WAYPOINTS} waypoints; stream {WAYPOINTS_STREAM}), j = {JERK_RATIO:g} a, over '
          "TOPP-RA's on the same request, median / worst. The programme's trajectory passes the "
          "waypoints at time_optimal's times (stretched to TOPP-RA's duration where shorter), "
          'each joint on its own, with the least shaking at both modes (measured again at '
          f'1 kHz); HiGHS failed on {sum(np.isnan(r["programme"][0]) for r in rows)}.')
    print()
    print('| what | duration | ' + shaking.shaking_header() + ' | meets the target |')
    print('|---|---|---|---|---|---|---|')
    for name, label in (('default', '`plan()` default'), ('time_optimal', '`plan()` time_optimal'),
                        ('programme', "the least shaking at time_optimal's waypoint times")):
        values = np.array([r[name] for r in rows])
        meets = np.sum((values[:, 1] <= PEAK_TARGET) & (values[:, 2] <= RESIDUAL_TARGET)
                       & (values[:, 3] <= PEAK_TARGET) & (values[:, 4] <= RESIDUAL_TARGET))
        print(f'| {label} | ' + ' | '.join(_percent(values[:, i]) for i in range(5))
              + f' | {meets} of {len(values)} |')
    if checks:
        worst = np.max(np.array(checks), axis=0)
        print()
        print(f"Check of the programme's trajectories (0.1 ms): waypoints missed by at most "
              f'{worst[0]:.1e} rad; v, a, j at most {worst[1]:.4f}, {worst[2]:.4f}, '
              f'{worst[3]:.4f} of their limits. {time.perf_counter() - started:.0f} s in all.')


if __name__ == '__main__':
    main()
