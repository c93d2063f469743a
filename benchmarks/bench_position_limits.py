"""
Moves from limit to limit: how many the default plans, and the price where it changes profile.

Random requests whose waypoints run one way per joint (2-6 waypoints, 2-7
joints, steps of 0.3-1 rad, v 1-3, a 5-15, j = 20 a), with
``min_position`` / ``max_position`` at their waypoints' range: every joint
starts on one limit and ends on the other.  The smoothed inner-knot
spline used to start some joint a hair the wrong way on more than half of
them (its jerk at a rest end was whatever the fit gave); step 4 of
``planning/path_following/inner_knots.py`` now sets such a jerk to 0
(``END_JERK_SIGN``; both are run, on the same requests).  A knots-only
optimum that wins and does so gets a knot next to each rest end, moved to
turn that jerk along the joint's chord (``path_following/rest_ends.py``),
or, where no turn is shorter, plan() returns the inner-knot plan.
Where a plan still leaves the limits, its knots are moved to pull it back
within them (``path_following/position_limit_knots.py``); where no move
does, plan() gives the knots-only
optimum's plan, the time-optimal profile's, or the chord-length
durations' of timing "uniform" (``planner._other_profile_within``).

Printed: how far the smoothed plan leaves the range (a creep: under 1e-3
rad; more: a swing of its path), how many requests plan() plans within
the limits and how, and on those planned another way, the plan over the smoothed
plan the same request gets without limits and over TOPP-RA (its chord
spline through the waypoints, v/a only): duration, shaking of a 4 Hz and an 8 Hz
mode (peak while moving and residual after the stop, benchmarks/shaking.py)
and planning time over the plan without limits (the two in turn, best of 3
each: ``wall_time.timed_against``).  Printed second, before those
tables: what the switch does to the same requests' plans without limits
(the default and ``vibration_frequency`` 4 and 1.5 Hz), the ratios of the
plans it changes.

Printed last: random walks (a joint turning at a waypoint overshoots it)
with one joint's limit cut into its widest swing past the waypoints (at a
share drawn from 0.1-0.9 of the swing), where the smoothed plan leaves the
limit in the middle of a move: how plan() plans them with the knots moved
within the limits and without (``planner._pulled_within`` switched off:
the other plans, or a refusal), and the pulled plans over the plan without
limits and over the plan before.

Run: ``python benchmarks/bench_position_limits.py`` (part of ``make bench``;
``SPLINES445_BENCH_SEED`` repeats a run, ``SPLINES445_BENCH_CASES`` sets the
count).
"""

import logging
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

from bench_planning import toppra_trajectory  # noqa: E402
import bench_seeds  # noqa: E402, I100
import numpy as np  # noqa: E402, I100
from shaking import FREQUENCIES, of_toppra, of_trajectory, shaking_figures  # noqa: E402
from splines445_ros.planning import plan, planner  # noqa: E402
from splines445_ros.planning.path_following import inner_knots  # noqa: E402
from splines445_ros.planning.planner import position_limit_slack  # noqa: E402
from wall_time import timed_against  # noqa: E402

N_CASES = 80
CASES_STREAM = 61
WALKS_STREAM = 62
# A smoothed plan past its range by less than this [rad] creeps; more is a swing.
CREEP = 1e-3
# The vibration_frequency [Hz] of the switch's other rows.
SHAPED = (4.0, 1.5)
# The other plans: the knots-only optimum turned at its rest ends (optimizer
# 'end_knots'), the inner-knot plan where no turn was shorter
# ('knots_only_skipped'), the plan with its knots moved within the limits
# ('position_limit_knots'), then three by what their speed_profile_reason says.
END_KNOTS = 'end knots'
INNER_KNOTS = 'inner-knot plan'
PULLED = 'knots moved within'
KNOTS_ONLY = 'knots at the waypoints only'
TIME_OPTIMAL = 'time_optimal'
CHORDS = 'timing "uniform"'
OTHER_PLANS = (END_KNOTS, INNER_KNOTS, PULLED, KNOTS_ONLY, TIME_OPTIMAL, CHORDS)


def one_way_request(rng):
    """Waypoints that run one way per joint, and v/a/j limits."""
    n, count = int(rng.integers(2, 8)), int(rng.integers(2, 7))
    steps = rng.uniform(0.3, 1.0, (count, n)) * rng.choice([-1.0, 1.0], n)
    amax = rng.uniform(5.0, 15.0, n)
    return np.cumsum(steps, axis=0), {'max_velocity': rng.uniform(1.0, 3.0, n),
                                      'max_acceleration': amax, 'max_jerk': 20.0 * amax}


def walk_request(rng):
    """Return a random walk (3-6 waypoints, 2-4 joints, steps of up to 1 rad) and v/a/j limits."""
    n = int(rng.integers(2, 5))
    points = np.cumsum(rng.uniform(-1.0, 1.0, (int(rng.integers(3, 7)), n)), axis=0)
    amax = rng.uniform(5.0, 15.0, n)
    return points, {'max_velocity': rng.uniform(1.0, 3.0, n), 'max_acceleration': amax,
                    'max_jerk': 20.0 * amax}


def cut_swing(free, points, share):
    """Return (low, high): one joint's limit ``share`` into the widest swing past the waypoints."""
    f_low, f_high = free.position_extrema()[:2]
    above, below = f_high - points.max(axis=0), points.min(axis=0) - f_low
    low, high = np.full(points.shape[1], -np.inf), np.full(points.shape[1], np.inf)
    if above.max() >= below.max():
        j = int(np.argmax(above))
        high[j] = points[:, j].max() + (1.0 - share) * above[j]
    else:
        j = int(np.argmax(below))
        low[j] = points[:, j].min() - (1.0 - share) * below[j]
    return low, high


def kind_of(traj):
    """Return how plan() planned ``traj`` within its limits, in a few words."""
    optimizer = traj.optimizer or {}
    for key, kind in (('position_limit_knots', PULLED), ('end_knots', END_KNOTS),
                      ('knots_only_skipped', INNER_KNOTS)):
        if key in optimizer:
            return kind
    reason = optimizer.get('speed_profile_reason')
    return next((kind for kind in OTHER_PLANS if reason and kind in reason), 'as without limits')


def within(points, limits, low, high):
    """Return plan()'s 555 optimal plan within [low, high], or None where it refuses."""
    try:
        return plan(points, '555', 'optimal', min_position=low, max_position=high, **limits)
    except ValueError:
        return None


def cut_swings(requests):
    """
    Plan each walk with its cut limit, with and without the pull; return counts and ratios.

    ``({kind: count} now, {kind: count} before, rows)``; a row per pulled
    plan: its duration, 4 Hz peak and 4 Hz residual over the plan without
    limits, then the plan before's over the same (NaN where refused), then
    the planning time with the limits less without [ms] (the two in turn,
    best of 3 each: ``wall_time.timed_against``).
    """
    now, before, rows = {}, {}, []
    saved = planner._pulled_within
    for points, limits, share in requests:
        free = plan(points, '555', 'optimal', **limits)
        low, high = cut_swing(free, points, share)
        f_low, f_high = free.position_extrema()[:2]
        if np.all(f_low >= low) and np.all(f_high <= high):
            continue    # no swing past the waypoints
        (t_free, _), (t_pulled, pulled) = timed_against(
            lambda: plan(points, '555', 'optimal', **limits),
            lambda: within(points, limits, low, high))
        planner._pulled_within = lambda traj, options, points: None
        try:
            plans = [pulled, within(points, limits, low, high)]
        finally:
            planner._pulled_within = saved
        for counts, traj in zip((now, before), plans):
            kind = 'refused' if traj is None else kind_of(traj)
            counts[kind] = counts.get(kind, 0) + 1
        if plans[0] is None or kind_of(plans[0]) != PULLED:
            continue
        amax = limits['max_acceleration']
        reference = figures_of(of_trajectory(free), free.duration, amax)[:3]
        ratios = [figures_of(of_trajectory(t), t.duration, amax)[:3] / reference
                  if t is not None else np.full(3, np.nan) for t in plans]
        rows.append(np.concatenate(ratios + [[1e3 * (t_pulled - t_free)]]))
    return now, before, np.array(rows)


def print_cut_swings(requests):
    """Print :func:`cut_swings`' table."""
    now, before, rows = cut_swings(requests)
    total = sum(now.values())
    print()
    print(f'{len(requests)} random walks (stream {WALKS_STREAM}), one limit cut into the widest '
          f'swing (0.1-0.9 of it); {total} swing past their waypoints.  Planned with the knots '
          'moved within the limits (now) and without (before):')
    kinds = sorted(set(now) | set(before))
    print('| | ' + ' | '.join(kinds) + ' |')
    print('|' + '---|' * (len(kinds) + 1))
    for label, counts in (('now', now), ('before', before)):
        print(f'| {label} | ' + ' | '.join(str(counts.get(k, 0)) for k in kinds) + ' |')
    if not len(rows):
        return
    print()
    print('The pulled plans over the plan without limits, and the plan before on the same '
          'requests over it (median, range; before: where planned):')
    print('| plan | requests | duration | 4 Hz peak | 4 Hz residual |')
    print('|---|---|---|---|---|')
    for label, block in (('knots moved within', rows[:, :3]), ('before', rows[:, 3:6])):
        block = block[np.all(np.isfinite(block), axis=1)]
        if not len(block):
            continue
        print(f'| {label} | {len(block)} | ' + ' | '.join(
            f'{np.median(c):.3g} ({c.min():.3g}-{c.max():.3g})' for c in block.T) + ' |')
    both = np.all(np.isfinite(rows[:, :6]), axis=1)
    longer = np.sum(rows[both, 0] > rows[both, 3] * (1.0 + 1e-9))
    print(f'Pulled plans longer than the plan before: {longer} of {int(both.sum())}')
    more = rows[:, 6]
    print(f'Planning of the pulled plans, more than without limits: {np.median(more):.0f} ms '
          f'(median; {more.min():.0f}-{more.max():.0f})')


def figures_of(acceleration_of, duration, amax):
    """[duration, 4 Hz peak, 4 Hz residual, 8 Hz peak, 8 Hz residual] of one trajectory."""
    figures = shaking_figures(acceleration_of, duration, amax)
    return np.array([duration] + [figures[f][k] for f in FREQUENCIES for k in (0, 1)])


def run(requests):
    """
    Plan every request with and without its limits; return the counts and the figures.

    ``{'creeps', 'swings', 'planned', 'excess', 'planning'}`` and the
    :data:`OTHER_PLANS`, which hold, per request planned that way, its
    figures over the smoothed plan without limits, over TOPP-RA, and the
    smoothed plan's over TOPP-RA.
    """
    out = {'creeps': 0, 'swings': 0, 'planned': 0, 'excess': [], 'planning': []}
    out.update({kind: [] for kind in OTHER_PLANS})
    for points, limits in requests:
        low, high = points.min(axis=0), points.max(axis=0)
        (t_free, free), (t_limited, limited) = timed_against(
            lambda: plan(points, '555', 'optimal', **limits),
            lambda: within(points, limits, low, high))
        q_low, q_high = free.position_extrema()[:2]
        slack = position_limit_slack(low, high).ravel()
        beyond = np.concatenate([low - q_low, q_high - high])
        if np.any(beyond > slack):
            out['excess'].append(float(beyond.max()))
            out['creeps' if out['excess'][-1] < CREEP else 'swings'] += 1
        if limited is None:
            continue    # refused (ValueError)
        out['planned'] += 1
        reason = limited.optimizer.get('speed_profile_reason')
        turned = 'end_knots' in limited.optimizer
        inner = 'knots_only_skipped' in limited.optimizer
        pulled = 'position_limit_knots' in limited.optimizer
        if not (reason or turned or inner or pulled):
            continue
        amax = limits['max_acceleration']
        top = toppra_trajectory(points, limits['max_velocity'], amax)
        ours = figures_of(of_trajectory(limited), limited.duration, amax)
        smoothed = figures_of(of_trajectory(free), free.duration, amax)
        theirs = figures_of(of_toppra(top), top.duration, amax)
        kind = (PULLED if pulled else END_KNOTS if turned else INNER_KNOTS if inner else
                next(kind for kind in OTHER_PLANS if kind in reason))
        out[kind].append((ours / smoothed, ours / theirs, smoothed / theirs))
        out['planning'].append([t_limited / t_free, 1e3 * (t_limited - t_free)])
    return out


def switch_effect(requests, **more):
    """
    Return (changed, ratios): the plans without limits END_JERK_SIGN changes, True over False.

    ``ratios`` per changed plan: duration, 4 Hz peak and residual, 8 Hz
    peak and residual (``more``: plan() arguments, e.g. a vibration_frequency).
    """
    ratios, changed = [], 0
    saved = inner_knots.END_JERK_SIGN
    for points, limits in requests:
        plans = []
        for flag in (False, True):
            inner_knots.END_JERK_SIGN = flag
            try:
                plans.append(plan(points, '555', 'optimal', **limits, **more))
            finally:
                inner_knots.END_JERK_SIGN = saved
        before, after = plans
        if before.ppoly.c.shape == after.ppoly.c.shape and np.array_equal(before.ppoly.c,
                                                                          after.ppoly.c):
            continue
        changed += 1
        amax = limits['max_acceleration']
        row = (figures_of(of_trajectory(after), after.duration, amax)
               / figures_of(of_trajectory(before), before.duration, amax))
        mode = more.get('vibration_frequency')
        if mode:
            # The residual at the mode the plan cancels.
            at = [shaking_figures(of_trajectory(t), t.duration, amax, (mode,))[mode][1]
                  for t in (after, before)]
            row = np.append(row, at[0] / at[1])
        ratios.append(row)
    return changed, np.array(ratios)


def main():
    """Draw the requests, plan each with and without limits, print the tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    bench_seeds.run_seed()
    n_cases = bench_seeds.case_count(N_CASES)
    rng = bench_seeds.generator(CASES_STREAM)
    requests = [one_way_request(rng) for _ in range(n_cases)]
    runs = {}
    saved = inner_knots.END_JERK_SIGN
    for flag in (False, True):
        inner_knots.END_JERK_SIGN = flag
        try:
            runs[flag] = run(requests)
        finally:
            inner_knots.END_JERK_SIGN = saved
    print(f"{n_cases} one-way requests (stream {CASES_STREAM}), limits at the waypoints' "
          'range, 555 optimal, j = 20 a; step 4 of inner_knots as the fit gives the jerk at '
          'the rest ends (END_JERK_SIGN False) and along the path (True, the default):')
    print('| END_JERK_SIGN | smoothed plan leaves the range: creep (< 1e-3 rad) | swing '
          '| its excess [rad]: median / largest | planned within the limits | knots-only optimum '
          'with a knot next to each rest end | the inner-knot plan (no turn shorter) | its knots '
          'moved within the limits | with knots at the waypoints only | with time_optimal | with '
          'timing "uniform" |')
    print('|---|---|---|---|---|---|---|---|---|---|---|')
    for flag, out in runs.items():
        excess = out['excess']
        spread = (f'{np.median(excess):.2g} / {np.max(excess):.2g}' if excess else '-')
        print(f"| {flag} | {out['creeps']} | {out['swings']} | {spread} | {out['planned']} of "
              f'{n_cases} | ' + ' | '.join(str(len(out[kind])) for kind in OTHER_PLANS) + ' |')
    names = ['duration'] + [f'{f:g} Hz {kind}' for f in FREQUENCIES
                            for kind in ('peak', 'residual')]
    print()
    print('The same requests without limits: the plans END_JERK_SIGN changes, True over False '
          '(median, range):')
    print('| plan | changed | ' + ' | '.join(names) + ' | residual at its mode |')
    print('|' + '---|' * (len(names) + 3))
    for label, more in [('default', {})] + [(f'vibration_frequency={f:g}',
                                             {'vibration_frequency': f}) for f in SHAPED]:
        changed, ratios = switch_effect(requests, **more)
        cells = [f'{np.median(c):.4g} ({c.min():.4g}-{c.max():.4g})' for c in ratios.T]
        cells += ['-'] * (len(names) + 1 - len(cells))
        print(f'| {label} | {changed} of {n_cases} | ' + ' | '.join(cells) + ' |')
    for flag, out in runs.items():
        if not out['planning']:
            continue
        print()
        print(f'END_JERK_SIGN {flag}: the requests planned another way (median, range):')
        print('| plan / reference | requests | ' + ' | '.join(names) + ' |')
        print('|' + '---|' * (len(names) + 2))
        for kind in OTHER_PLANS:
            if not out[kind]:
                continue
            rows = np.array(out[kind])
            for k, label in enumerate((f'{kind} / smoothed (no limits)', f'{kind} / TOPP-RA',
                                       'smoothed (no limits) / TOPP-RA')):
                print(f'| {label} | {len(rows)} | ' + ' | '.join(
                    f'{np.median(c):.3g} ({c.min():.3g}-{c.max():.3g})' for c in rows[:, k].T)
                    + ' |')
        planning = np.array(out['planning'])
        print(f'Planning with the limits / without, on those: {np.median(planning[:, 0]):.2f} '
              f'({planning[:, 0].min():.2f}-{planning[:, 0].max():.2f}), '
              f'{np.median(planning[:, 1]):.0f} ms more ({planning[:, 1].min():.0f}-'
              f'{planning[:, 1].max():.0f})')
    walks = bench_seeds.generator(WALKS_STREAM)
    print_cut_swings([walk_request(walks) + (float(walks.uniform(0.1, 0.9)),)
                      for _ in range(n_cases)])
    return 0


if __name__ == '__main__':
    sys.exit(main())
