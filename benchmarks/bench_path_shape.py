"""
A faster path by its time's gradient (issue 38, an experiment), one run; not in ``make bench``.

plan() times the natural cubic through the waypoints at their rest-to-rest
times.  ``path_shape.py`` gives the exact gradient of the fastest v/a
profile's time T along that path with respect to its shape (family 'a':
the knot durations; family 'b1': those and one bulge factor per segment)
and moves the shape with a budget of Adam steps.  The question: what do a
few evaluations gain, what does the plan built on the faster path gain
and shake, and what does it cost in planning time?

Fresh random requests every run (``bench_seeds``; drawn as
``bench_inner_knots.py`` draws them: 5 to 50 waypoints, 3 to 7 joints,
v in [1, 3] rad/s, a in [5, 15] rad/s^2), j = 20 a.  First the module
checks itself on the first :data:`CHECKED` requests at random shapes: T
against the package's own profile (``PathLimits`` + ``traversal_times``
on the same spline and grid) and the gradient against central
differences.  Then, per family and budget of evaluations (default
:data:`BUDGETS`), each over the start path's or the default plan's, on
the same request:

* path T / T0: the objective (the profile on the grid), and TOPP-RA (its
  default grid, ``toppra.SplineInterpolator`` of the same natural cubic)
  along the found path over TOPP-RA along the start path;
* the plan: ``plan(points, '555', 'optimal', v, a, 20 a)`` with its path
  replaced by the found one (:func:`shaped_path`), its duration over the
  default plan's and over TOPP-RA's (``bench_planning.toppra_trajectory``),
  the 4 Hz shaking (peak, residual) over TOPP-RA's (``shaking.py``), and
  whether every limit held (``within_limits(rtol=1e-9)``);
* the extra planning time: the optimiser's wall time over plan()'s, and
  the patched plan()'s own over plan()'s (best of :data:`REPEATS`, every
  call of the request in turn: ``wall_time.interleaved_best_of``).  The
  start durations are not counted: plan() computes them anyway.

Usage: ``python benchmarks/bench_path_shape.py [budgets]`` (budgets comma
separated, default ``10,20,40``); ``SPLINES445_BENCH_SEED=<seed>`` repeats a
run, ``SPLINES445_BENCH_CASES=<count>`` sets how many requests (default 8).
Set ``OPENBLAS_NUM_THREADS=1`` on a shared machine: small BLAS calls with
spinning threads took 100+ ms there.
"""

from contextlib import contextmanager
import logging
import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_arm_moves import construction_path  # noqa: E402, I100
from bench_inner_knots import random_case  # noqa: E402, I100
from bench_planning import toppra_trajectory  # noqa: E402
import bench_seeds  # noqa: E402
import numpy as np  # noqa: E402
import path_shape  # noqa: E402
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.constraints import (  # noqa: E402
    GriddedPath, JointAcceleration, JointVelocity)
from splines445_ros.planning.path_following import inner_knots  # noqa: E402
from splines445_ros.planning.speed_profile.path_velocity import (  # noqa: E402
    PathLimits, traversal_times)
from splines445_ros.planning.spline.natural_cubic import natural_cubic_spline  # noqa: E402
from wall_time import interleaved_best_of  # noqa: E402

N_CASES = 8
BUDGETS = (10, 20, 40)
JERK_RATIO = 20.0
REPEATS = 3
# Requests checked at random shapes (log h and mu normal with these spreads).
CHECKED = 2
CHECK_SPREAD = {'log_h': 0.2, 'mu': 0.3}
CHECK_STEP = 1e-6           # central differences
CHECK_TOLERANCE = 1e-4      # max |error| / max |gradient| above it: a kink hit, or a bug
# Random streams of the run's seed (bench_seeds.generator).
CASES_STREAM, CHECK_STREAM = 0, 1


def package_time(pieces, points, vmax, amax, grid):
    """Return T of the package's own profile along the natural cubic (pieces, points)."""
    cubic, s = construction_path(np.concatenate([[0.0], np.cumsum(pieces)]), points, grid)
    path = GriddedPath.of_ppoly(cubic, s)
    x = PathLimits(path, (JointVelocity(vmax), JointAcceleration(amax))).profile(np.ones(s.size))
    return traversal_times(x, np.diff(s))[-1]


def toppra_time(pieces, points, vmax, amax):
    """Return TOPP-RA's duration (its default grid) along the natural cubic (pieces, points)."""
    import toppra
    import toppra.algorithm
    import toppra.constraint as tc
    knots = np.concatenate([[0.0], np.cumsum(pieces)])
    path = toppra.SplineInterpolator(knots, points, bc_type='natural')
    constraints = [tc.JointVelocityConstraint(np.column_stack([-vmax, vmax])),
                   tc.JointAccelerationConstraint(np.column_stack([-amax, amax]))]
    instance = toppra.algorithm.TOPPRA(constraints, path, parametrizer='ParametrizeConstAccel')
    return instance.compute_trajectory().duration


@contextmanager
def shaped_path(points, durations, mu=None):
    """
    Within the block, plan() on ``points`` starts from this path instead of its own.

    ``inner_knots._Path`` looks up ``rest_to_rest_durations`` and
    ``natural_cubic_spline`` in the module ``inner_knots`` at call time:
    the first returns ``durations``, the second family b1's cubic with the
    bulge factors ``mu`` (the plain natural cubic when None).  Restored on
    leaving (one thread: nothing else plans meanwhile).
    """
    original = inner_knots.rest_to_rest_durations, inner_knots.natural_cubic_spline

    def given_durations(waypoints, limits):
        if not np.array_equal(waypoints, points):
            raise ValueError('shaped_path: plan() asked for the durations of other waypoints')
        return np.array(durations, float)

    def spline(knots, waypoints):
        if mu is None:
            return natural_cubic_spline(knots, waypoints)
        return path_shape.b1_spline(knots, waypoints, mu)

    inner_knots.rest_to_rest_durations = given_durations
    inner_knots.natural_cubic_spline = spline
    try:
        yield
    finally:
        inner_knots.rest_to_rest_durations, inner_knots.natural_cubic_spline = original


def plan_default(points, vmax, amax):
    """Return plan()'s default trajectory of the request, j = :data:`JERK_RATIO` a."""
    return plan(points, '555', 'optimal', max_velocity=vmax, max_acceleration=amax,
                max_jerk=JERK_RATIO * amax)


def plan_shaped(points, vmax, amax, start, shaped):
    """Return plan()'s trajectory with its path replaced by ``shaped``'s (a path_shape.Shaped)."""
    with shaped_path(points, shaped.durations(start), shaped.mu(start)):
        return plan_default(points, vmax, amax)


def check(cases, rng):
    """Print T against the package's and the gradient against central differences."""
    worst_time, worst_grad, worst_scale = 0.0, 0.0, 0.0
    for points, vmax, amax in cases:
        start = path_shape.start_durations(points, vmax, amax, JERK_RATIO)
        for family in path_shape.FAMILIES:
            theta = rng.normal(0.0, CHECK_SPREAD['log_h'],
                               path_shape.parameter_count(family, start))
            theta[start.size:] *= CHECK_SPREAD['mu'] / CHECK_SPREAD['log_h']
            total, grad = path_shape.time_and_gradient(family, theta, start, points, vmax, amax)
            pieces, every = path_shape.natural_path(family, theta, start, points)
            own = package_time(pieces, every, vmax, amax, path_shape.GRID[family])
            worst_time = max(worst_time, abs(total / own - 1.0))
            differences = np.empty_like(theta)
            for k in range(theta.size):
                step = np.zeros_like(theta)
                step[k] = CHECK_STEP
                above, below = (path_shape.time_and_gradient(family, theta + sign * step, start,
                                                             points, vmax, amax, gradient=False)
                                for sign in (1.0, -1.0))
                differences[k] = (above - below) / (2.0 * CHECK_STEP)
            scale = np.max(np.abs(differences))
            worst_grad = max(worst_grad, np.max(np.abs(grad - differences)) / scale)
            worst_scale = max(worst_scale, abs(grad[:start.size].sum()) / scale)
    verdict = ('below' if worst_grad <= CHECK_TOLERANCE
               else 'ABOVE (a kink of T hit, or a bug: look before trusting the figures)')
    print(f'Check on the first {len(cases)} requests, both families, random shapes: '
          f'|T / package T - 1| <= {worst_time:.1e}; gradient vs central differences '
          f'(step {CHECK_STEP:g}), max |error| / max |gradient| = {worst_grad:.1e}, {verdict} '
          f'{CHECK_TOLERANCE:g}; |sum dT/dlog h| / max |gradient| <= {worst_scale:.1e} '
          '(scale invariance)')


def median_worst(values, digits=4):
    """Return 'median (largest)' of ``values``: every figure here is worse when larger."""
    return f'{np.median(values):.{digits}f} ({np.max(values):.{digits}f})'


def run_case(points, vmax, amax, budgets):
    """Return {row: figures} of one request (module docstring), and print its line."""
    start = path_shape.start_durations(points, vmax, amax, JERK_RATIO)
    top = toppra_trajectory(points, vmax, amax)
    reference = shaking_figures(of_toppra(top), top.duration, amax)
    variants = [(family, budget) for family in path_shape.FAMILIES for budget in budgets]
    # The optimiser is deterministic: the timed calls below repeat these results.
    shapes = {variant: path_shape.optimise(variant[0], start, points, vmax, amax, variant[1])
              for variant in variants}
    calls = [lambda: plan_default(points, vmax, amax)]
    for variant in variants:
        calls.append(lambda v=variant: path_shape.optimise(v[0], start, points, vmax, amax,
                                                           v[1]))
        calls.append(lambda v=variant: plan_shaped(points, vmax, amax, start, shapes[v]))
    timed = interleaved_best_of(calls, REPEATS)
    t_default, default = timed[0]
    start_top = {family: toppra_time(*path_shape.natural_path(
        family, np.zeros(path_shape.parameter_count(family, start)), start, points), vmax, amax)
        for family in path_shape.FAMILIES}
    rows = {'default': {'plan': 1.0, 'top': default.duration / top.duration,
                        'shaking': shaking_ratios(default, reference, amax)[:2],
                        'held': default.within_limits(rtol=1e-9)}}
    cells = []
    for index, (family, budget) in enumerate(variants):
        t_opt, shaped = timed[1 + 2 * index]
        t_plan, traj = timed[2 + 2 * index]
        along = toppra_time(*path_shape.natural_path(family, shaped.theta, start, points),
                            vmax, amax)
        rows[f'{family}, {budget} evaluations'] = {
            'grid': shaped.time / shaped.start_time, 'toppra': along / start_top[family],
            'plan': traj.duration / default.duration, 'top': traj.duration / top.duration,
            'shaking': shaking_ratios(traj, reference, amax)[:2],
            'held': traj.within_limits(rtol=1e-9), 'extra': t_opt / t_default,
            'patched': t_plan / t_default}
        cells.append(f'{shaped.time / shaped.start_time:.4f} / '
                     f'{along / start_top[family]:.4f} -> {traj.duration / default.duration:.4f}'
                     f' +{t_opt / t_default:.2f}x')
    print(f'| {len(points)} x {points.shape[1]} | {1e3 * t_default:.1f} | '
          f'{default.duration / top.duration:.4f} | ' + ' | '.join(cells) + ' |')
    sys.stdout.flush()
    return rows


def main():
    """Run the experiment and print the tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    seed = bench_seeds.run_seed()
    budgets = (tuple(int(b) for b in sys.argv[1].split(',')) if len(sys.argv) > 1
               else BUDGETS)
    count = bench_seeds.case_count(N_CASES)
    rng = bench_seeds.generator(CASES_STREAM)
    cases = [random_case(rng) for _ in range(count)]
    print(f'{count} random requests (seed {seed}, stream {CASES_STREAM}), j = {JERK_RATIO:g} a; '
          f'path shape by the exact gradient of T (benchmarks/path_shape.py), budgets '
          f'{", ".join(map(str, budgets))} evaluations')
    check(cases[:CHECKED], bench_seeds.generator(CHECK_STREAM))
    print()
    print('Per request: plan() [ms], plan() / TOPP-RA; per family and budget: path T / T0 '
          '(grid / TOPP-RA) -> plan / default plan, + optimiser time / plan() time')
    print('| N x n | plan() [ms] | plan() / TOPP-RA | '
          + ' | '.join(f'{f} {b}' for f in path_shape.FAMILIES for b in budgets) + ' |')
    print('|---' * (3 + len(path_shape.FAMILIES) * len(budgets)) + '|')
    results = [run_case(points, vmax, amax, budgets) for points, vmax, amax in cases]
    print()
    print(f'Medians (worst) over the {count} requests; path T / T0: the objective on the grid and '
          "TOPP-RA along the same path; shaking at 4 Hz over TOPP-RA's; extra time: the "
          "optimiser / plan(), median (max); patched plan(): its own time / plan()'s")
    print('| plan | path T / T0 (grid) | path T / T0 (TOPP-RA) | plan / default plan | '
          'plan / TOPP-RA | 4 Hz peak | 4 Hz residual | limits held | extra time / plan() | '
          'patched plan() / plan() |')
    print('|---' * 10 + '|')
    for row in results[0]:
        figures = [result[row] for result in results]

        def column(key, digits=4):
            if key not in figures[0]:
                return '-'
            return median_worst([f[key] for f in figures], digits)

        shaking = np.array([f['shaking'] for f in figures])
        print(f'| {row} | {column("grid")} | {column("toppra")} | {column("plan")} | '
              f'{column("top")} | {median_worst(shaking[:, 0], 2)} | '
              f'{median_worst(shaking[:, 1], 2)} | {sum(f["held"] for f in figures)}/{count} | '
              f'{column("extra", 2)} | {column("patched", 2)} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
