"""
Torque limits and payload (issue 25): 555 optimal with torque limits against TOPP-RA, one run.

For every 6-7-joint arm of example-robot-data (``bench_arms.py``: UR3, UR5,
UR10, Panda, xArm7, Z1, Kinova, the TALOS arm; the skipped URDFs are listed
with their reasons), random reachable joint paths (fresh every run, the seed
printed first: ``bench_seeds.py``; 5 to 30 waypoints, a random walk from the
ready pose with steps uniform in +-0.3 rad per joint, clipped to the joint
ranges less 0.05 rad), each planned with payload 0 and with the rated
payload (the vendor's, but at most :data:`PAYLOAD_SHARE` of what the
URDF's efforts hold at rest at every waypoint of the arm's paths; a point
mass 0.1 m from the flange along the tool frame's z).  A path that a
planner refuses (gravity above an effort somewhere on it) is listed as
refused, with the reason.  Limits: velocity and torque from the URDF
(``<limit velocity>``, ``<limit effort>``); no acceleration limit in
effect (plan() needs one: :data:`NO_ACCELERATION_LIMIT` rad/s^2 on every
joint); jerk :data:`JERK_RATIO` times a typical acceleration (below).
The inverse dynamics is :class:`splines445_ros.robot.dynamics.
ArmDynamics` (MuJoCo RNE, payload included), the same for both planners:
ours is given the ArmDynamics itself (its torques, and its ``gravity``
pass for the torques at rest), TOPP-RA its ``torques``.  The rigid-body
torque alone on both sides (``include_damping`` False, unlike the planner
node's default ``torque_counts_friction``): TOPP-RA's canonical form has no
term in the path speed itself, where the joints' damping ``D q' sdot`` is;
``bench_torque_arm.py`` plans with it.

* Today's practice: one constant acceleration limit ``a`` common to all
  joints (jerk :data:`JERK_RATIO` times it), the largest (bisection over
  :data:`BISECTION_RANGE`) for which 555 optimal without torque limits
  keeps every 1 kHz torque sample within its limit on that path.
* Ours: ``plan(points, '555', 'optimal', max_velocity, max_acceleration,
  max_jerk, max_torque, inverse_dynamics)``; and the same with
  ``inner_knots=0`` (knots at the waypoints only, slowed down uniformly for
  the torque), for comparison.  The typical acceleration of each joint is
  the largest its motors give it on that path: its peak in TOPP-RA's
  torque-limited plan (:func:`typical_accelerations`); max_jerk is
  :data:`JERK_RATIO` times that, a ramp of 20 ms to it.  (Until issue 25's
  second stop it was today's ``a``, the cautious worst case: ramps of
  0.1-0.5 s to the accelerations the torque allows, and the jerk bound most
  plans.)
* TOPP-RA: toppra's ``JointVelocityConstraint`` and ``JointTorqueConstraint``
  (the same inverse dynamics, one sample per call, no dry friction) on its
  chord spline (``own_path.chord_spline``: its cubic spline through the
  waypoints over normalised chord length), default grid,
  ``ParametrizeConstAccel``; no jerk limit.  Its default Collocation holds
  the torque at its grid points only: checked here at 1 kHz, and its
  Interpolation discretisation shown next to it.

* ``speed_profile='time_optimal'`` (issue 38, ``planning/path_following/time_optimal.py``):
  the same limits, the torque a row of the third-order profile, timed in
  turn with TOPP-RA and ours; its figures in a table of their own, with
  its 1 kHz peak torque.

* TOPP-RA along our path (issue 38, ``own_path.py``): the same velocity
  and torque constraints on the geometric path of our plan, re-parameterised
  by arc length: our duration over its is what the speed profile gives away.

Per arm and payload, the figures of issue 38 (``bench_figures.py``; median
and worst): duration over TOPP-RA's, over TOPP-RA's along our path, that
one over TOPP-RA's, the shaking of a lightly damped 4 and 8 Hz mode (peak
and residual, ``shaking.py``), planning times ours / TOPP-RA (each best of
:data:`REPEATS`, timed in turn); then the peak 1 kHz torque / limit of all,
how much shorter ours is than today's practice, and whether every v/a/j
limit held.  Targets: duration median at most 1.05 x TOPP-RA's; our 1 kHz
torque peak at most 1.005 x its limit.

Usage: ``python benchmarks/bench_torque.py``; SPLINES445_BENCH_FULL=1 for
:data:`FULL_CASES` paths per arm instead of :data:`CASES`;
``SPLINES445_BENCH_CASES=<count>`` any count, ``SPLINES445_BENCH_SEED``
repeats a run, ``SPLINES445_BENCH_ARMS=UR5,Panda`` only those arms.
"""

import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_arms  # noqa: E402, I100
import bench_figures  # noqa: E402
import bench_seeds  # noqa: E402
import numpy as np  # noqa: E402, I100
import own_path  # noqa: E402, I100
from shaking import of_toppra, shaking_figures, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.constraints.torque import (  # noqa: E402 - [s] the 1 kHz torque check
    CHECK_PERIOD)
from splines445_ros.robot.dynamics import ArmDynamics, effort_limits  # noqa: E402, I100
from wall_time import interleaved_best_of  # noqa: E402

CASES = 10
FULL_CASES = 40
POINTS = (5, 30)
STEP = 0.3                      # [rad] largest random-walk step per joint
RANGE_MARGIN = 0.05             # [rad] kept from each end of a joint's range
PAYLOAD_OFFSET = (0.0, 0.0, 0.1)    # [m] payload centre of mass in the tool frame
NO_ACCELERATION_LIMIT = 1e3     # [rad/s^2] plan() needs one; never binds
JERK_RATIO = 50.0               # jerk limit = JERK_RATIO * typical acceleration
MIN_TYPICAL = 1e-3              # [rad/s^2] floor of a joint's typical acceleration
BINDS = 0.99                    # a limit this close is reported as reached
REPEATS = 3
BISECTION_RANGE = (0.1, NO_ACCELERATION_LIMIT)     # [rad/s^2] constant acceleration
BISECTION_STEPS = 12
PAYLOAD_SHARE = 0.9             # payload <= this * what the URDF efforts hold on the paths


def joint_limits(robot, joints, margin=RANGE_MARGIN):
    """
    Return the URDF limits of ``joints``: (lower, upper) less ``margin``, velocity, effort.

    Each (n,); the ranges are those of the random walks (:func:`random_path`).
    """
    infos = [robot.joint(j) for j in joints]
    lower = np.array([j.lower for j in infos]) + margin
    upper = np.array([j.upper for j in infos]) - margin
    return lower, upper, np.array([j.velocity for j in infos]), effort_limits(robot, joints)


def random_path(rng, ready, lower, upper):
    """Return a random walk (N, n) from ``ready`` within [lower, upper]."""
    n_points = int(rng.integers(POINTS[0], POINTS[1] + 1))
    points = [np.array(ready, dtype=float)]
    for _ in range(n_points - 1):
        step = rng.uniform(-STEP, STEP, len(ready))
        points.append(np.clip(points[-1] + step, lower, upper))
    return np.array(points)


def arm_paths(arm, cases, offset=0):
    """Return ``cases`` random walks of ``arm`` (:func:`random_path`), stream + ``offset``."""
    lower, upper, _, _ = joint_limits(arm.robot, arm.joints)
    rng = bench_seeds.generator(arm.stream + offset)
    return [random_path(rng, arm.ready, lower, upper) for _ in range(cases)]


def toppra_torque(points, vmax, tau_max, torques, interpolation=False):
    """
    TOPP-RA with velocity and torque limits on its chord spline; its trajectory.

    ``interpolation``: toppra's Interpolation discretisation of the torque
    constraint instead of its default Collocation.  None when it finds none.
    """
    path = own_path.chord_spline(points)
    constraints = own_path.velocity_torque(vmax, tau_max, torques, interpolation)
    try:
        return own_path.toppra_on(path, constraints)
    except RuntimeError:
        return None


def sampled(position, velocity, acceleration, duration):
    """Sample times every :data:`CHECK_PERIOD` (end included) and q, qd, qdd there."""
    t = np.linspace(0.0, duration, int(np.ceil(duration / CHECK_PERIOD)) + 1)
    return position(t), velocity(t), acceleration(t)


def peak_torque(samples, torques, tau_max):
    """Largest |tau| / limit over 1 kHz samples, per joint (n,)."""
    return np.max(np.abs(torques(*samples)) / tau_max, axis=0)


def ours_samples(traj):
    """1 kHz samples of a splines445 Trajectory."""
    return sampled(*(lambda t, d=d: traj.evaluate(t, d) for d in range(3)), traj.duration)


def toppra_samples(top):
    """1 kHz samples of a toppra trajectory."""
    return sampled(top.eval, top.evald, top.evaldd, top.duration)


def bisected_acceleration(points, vmax, torques, tau_max):
    """
    Today's practice on ``points``: (a, its trajectory) for the largest constant acceleration.

    One acceleration limit ``a`` common to all joints, jerk
    :data:`JERK_RATIO` ``* a``, no torque limit; ``a`` the largest in
    :data:`BISECTION_RANGE` whose 555 optimal plan keeps every 1 kHz torque
    sample within its limit (the top of the range when even that does).
    """
    n = points.shape[1]

    def attempt(log_a):
        a = np.full(n, np.exp(log_a))
        traj = plan(points, '555', 'optimal', max_velocity=vmax, max_acceleration=a,
                    max_jerk=JERK_RATIO * a)
        return traj, np.max(peak_torque(ours_samples(traj), torques, tau_max)) <= 1.0

    low, high = np.log(BISECTION_RANGE[0]), np.log(BISECTION_RANGE[1])
    best, feasible = attempt(high)
    if feasible:
        return np.exp(high), best
    best, feasible = attempt(low)
    if not feasible:
        raise ValueError(f'no constant acceleration of at least {BISECTION_RANGE[0]} holds')
    for _ in range(BISECTION_STEPS):
        middle = 0.5 * (low + high)
        traj, feasible = attempt(middle)
        if feasible:
            low, best = middle, traj
        else:
            high = middle
    return np.exp(low), best


def typical_accelerations(top):
    """Each joint's largest |acceleration| (n,) in the toppra trajectory ``top``, 1 kHz samples."""
    t = np.arange(0.0, top.duration, CHECK_PERIOD)
    return np.maximum(np.max(np.abs(top.evaldd(t)), axis=0), MIN_TYPICAL)


def binding(traj, ours_peak):
    """Which limits the plan reaches (ratio >= :data:`BINDS`): 'v', 'j', 'tau' or '-'."""
    vaj = np.max(traj.limit_ratios(), axis=(0, 1))
    names = [name for name, ratio in (('v', vaj[0]), ('a', vaj[1]), ('j', vaj[2]),
                                      ('tau', ours_peak)) if ratio >= BINDS]
    return ' '.join(names) or '-', vaj


def run_row(name, robot, joints, tool, payload, paths, vmax, tau_max):
    """
    Plan every path with one payload, print a line per path; return (figures (C, 20), refused).

    ``refused``: a list of (case, reason) where a planner found no plan.
    """
    dynamics = ArmDynamics(robot, joints, tool, payload_mass=payload,
                           payload_center_of_mass=PAYLOAD_OFFSET)
    n = len(joints)
    rows, refused = [], []
    for case, points in enumerate(paths):
        try:
            row, line = run_case(points, vmax, tau_max, dynamics, n)
        except (ValueError, RuntimeError) as exc:
            refused.append((case, str(exc).splitlines()[0][:160]))
            print(f'| {name} | {payload:.2f} | {case} | {len(points)} | refused: '
                  f'{refused[-1][1]} |')
            continue
        rows.append(row)
        print(f'| {name} | {payload:.2f} | {case} | {len(points)} | ' + line + ' |')
        sys.stdout.flush()
    return np.array(rows).reshape(-1, 2 * len(bench_figures.NAMES) + 10), refused


def run_case(points, vmax, tau_max, dynamics, n):
    """Return (figures, table cells) of one path: ours, TOPP-RA, along our path, constant a."""
    torques = dynamics.torques
    try:
        typical, slow = bisected_acceleration(points, vmax, torques, tau_max)
    except ValueError:
        typical, slow = np.nan, None    # no constant acceleration holds: shown as nan
    first = toppra_torque(points, vmax, tau_max, torques)
    if first is None:
        raise RuntimeError('TOPP-RA found no parametrisation')
    # TOPP-RA's plan sets our jerk limits; then the three are timed in turn.
    jerk = JERK_RATIO * typical_accelerations(first)
    limits = {'max_velocity': vmax, 'max_acceleration': np.full(n, NO_ACCELERATION_LIMIT),
              'max_jerk': jerk, 'max_torque': tau_max, 'inverse_dynamics': dynamics}
    (t_top, top), (t_ours, traj), (t_optimal, optimal) = interleaved_best_of((
        lambda: toppra_torque(points, vmax, tau_max, torques),
        lambda: plan(points, '555', 'optimal', **limits),
        lambda: plan(points, '555', 'optimal', speed_profile='time_optimal', **limits)), REPEATS)
    if top is None:
        raise RuntimeError('TOPP-RA found no parametrisation')
    try:
        own = own_path.toppra_along(traj, own_path.velocity_torque(vmax, tau_max, torques))
    except RuntimeError:
        own = None      # shown as nan: TOPP-RA found no profile along our path
    knots_only = plan(points, '555', 'optimal', inner_knots=0, **limits)
    try:
        optimal_own = own_path.toppra_along(
            optimal, own_path.velocity_torque(vmax, tau_max, torques)).duration
    except RuntimeError:
        optimal_own = np.nan
    fine = toppra_torque(points, vmax, tau_max, torques, interpolation=True)
    if fine is None:
        raise RuntimeError('TOPP-RA (Interpolation) found no parametrisation')
    ours_peak = np.max(peak_torque(ours_samples(traj), torques, tau_max))
    knots_peak = np.max(peak_torque(ours_samples(knots_only), torques, tau_max))
    top_peak = np.max(peak_torque(toppra_samples(top), torques, tau_max))
    fine_peak = np.max(peak_torque(toppra_samples(fine), torques, tau_max))
    own_peak = (np.nan if own is None
                else np.max(peak_torque(toppra_samples(own), torques, tau_max)))
    own_duration = np.nan if own is None else own.duration
    # Shaking in units of the constant acceleration (common to all joints: the
    # ratios do not depend on it).
    scale = np.full(n, typical if slow is not None else 1.0)
    reference = shaking_figures(of_toppra(top), top.duration, scale)
    figures = bench_figures.figures(traj.duration, own_duration, top.duration,
                                    shaking_ratios(traj, reference, scale), t_ours, t_top)
    binds, vaj = binding(traj, ours_peak)
    slow_duration = np.nan if slow is None else slow.duration
    row = figures + [ours_peak, top_peak, fine.duration / top.duration, fine_peak,
                     1.0 - traj.duration / slow_duration, knots_only.duration / top.duration,
                     knots_peak, own_peak, float(traj.within_limits(rtol=1e-9))]
    # speed_profile='time_optimal' (issue 38): its figures and its 1 kHz peak torque.
    row += bench_figures.figures(optimal.duration, optimal_own, top.duration,
                                 shaking_ratios(optimal, reference, scale), t_optimal, t_top)
    row += [np.max(peak_torque(ours_samples(optimal), torques, tau_max))]
    line = (f'{typical:.1f} | {top.duration:.3f} | {fine.duration:.3f} | {own_duration:.3f} '
            f'| {traj.duration:.3f} | {figures[0]:.3f} | {figures[1]:.3f} '
            f'| {figures[bench_figures.PEAK_4HZ]:.2f} '
            f'| {slow_duration:.3f} | {1e3 * t_top:.0f} | {1e3 * t_ours:.0f} '
            f'| {knots_only.duration:.3f} | {ours_peak:.4f} / {knots_peak:.4f} '
            f'| {top_peak:.3f} / {fine_peak:.3f} / {own_peak:.3f} '
            f'| {vaj[0]:.2f} / {vaj[1]:.2f} / {vaj[2]:.2f} | {binds}')
    return row, line


def bench_payload(arm, paths):
    """
    Return (payload [kg], what the URDF efforts hold on the paths' waypoints [kg]).

    The payload is the vendor's rated one, but at most :data:`PAYLOAD_SHARE`
    of the largest point mass (at :data:`PAYLOAD_OFFSET`) whose gravity the
    URDF's efforts hold at every waypoint of ``paths`` (at rest) where they
    hold the arm itself: some URDFs' efforts are not the arm's (the TALOS
    arm's: 22 N m at the shoulder, 3 N m at the wrist), and a payload they
    cannot hold has no plan.
    """
    bare = ArmDynamics(arm.robot, arm.joints, arm.tool)
    loaded = ArmDynamics(arm.robot, arm.joints, arm.tool, payload_mass=1.0,
                         payload_center_of_mass=PAYLOAD_OFFSET)
    held = np.inf
    for q in np.concatenate(paths):
        g0 = np.asarray(bare.gravity(q), float)
        per_kg = np.abs(np.asarray(loaded.gravity(q), float) - g0)
        room = arm.effort - np.abs(g0)
        if np.any(room < 0.0):
            continue    # the arm alone is too heavy here: that path is refused anyway
        with np.errstate(divide='ignore'):
            held = min(held, float(np.min(np.where(per_kg > 0.0, room / per_kg, np.inf))))
    return min(arm.rated_payload, PAYLOAD_SHARE * max(held, 0.0)), held


def main():
    """Run the comparison and print the tables."""
    full = os.environ.get('SPLINES445_BENCH_FULL') == '1'
    seed, cases, arms = bench_arms.start_run(FULL_CASES if full else CASES)
    print('Command: ' + ('SPLINES445_BENCH_FULL=1 ' if full else '')
          + f'{bench_seeds.VARIABLE}={seed} python benchmarks/bench_torque.py')
    print(f'Settings: seed {seed}; {cases} paths per arm, {POINTS[0]}-{POINTS[1]} waypoints '
          f'(random walk from the ready pose, steps uniform in +-{STEP} rad, clipped to the '
          f'joint ranges less {RANGE_MARGIN} rad), the same paths for both payloads; payload 0 '
          f'and rated (at most {PAYLOAD_SHARE:g} of what the URDF efforts hold at rest at '
          f'every waypoint), a point mass at {PAYLOAD_OFFSET} m in the tool frame; velocity and '
          'torque limits from the URDF; max_acceleration '
          f'{NO_ACCELERATION_LIMIT:g} rad/s^2 on every joint (plan() needs one: no '
          'acceleration limit in effect); max_jerk = '
          f"{JERK_RATIO:g} times each joint's typical acceleration, its peak in TOPP-RA's "
          "torque-limited plan (TOPP-RA: no jerk limit); today's practice a = the largest "
          'constant acceleration (common to all joints) whose torque-free plan holds the '
          f'torque on the path (bisection: {BISECTION_STEPS} log-halvings of '
          f'{BISECTION_RANGE} rad/s^2, jerk {JERK_RATIO:g} a); torque checked every '
          f'{1e3 * CHECK_PERIOD:g} ms; planning times best of {REPEATS}, timed in turn; '
          'TOPP-RA: default grid, ParametrizeConstAccel, Collocation (its default; '
          'Interpolation shown too); TOPP-RA along our path: the same velocity and torque '
          "constraints on our plan's geometric path (own_path.py); "
          "ours: plan(..., '555', 'optimal', max_torque=..., inverse_dynamics=dynamics) (the "
          'ArmDynamics: its gravity pass at rest; TOPP-RA dynamics.torques), default inner '
          'knots (inner_knots=0 shown too).')
    print()
    print('| arm | payload [kg] | case | N | constant a [rad/s^2] | TOPP-RA [s] '
          '| TOPP-RA Interpolation [s] | TOPP-RA along our path [s] | ours [s] '
          "| ours / TOPP-RA | ours / TOPP-RA along our path | ours 4 Hz peak / TOPP-RA's "
          '| constant a [s] '
          '| TOPP-RA planning [ms] | ours planning [ms] | ours inner_knots=0 [s] '
          '| ours peak torque (default / inner_knots=0) '
          '| TOPP-RA peak torque (Collocation / Interpolation / along our path) '
          f'| ours v / a / j ratios | ours at (>= {BINDS:g}) |')
    print(bench_figures.rule(20))
    summary = []
    for arm in arms:
        _, _, vmax, tau_max = joint_limits(arm.robot, arm.joints)
        paths = arm_paths(arm, cases)
        rated, held = bench_payload(arm, paths)
        for payload in (0.0, rated):
            rows, refused = run_row(arm.name, arm.robot, arm.joints, arm.tool, payload, paths,
                                    vmax, tau_max)
            summary.append((arm.name, payload, held, rows, refused))
    print_summary(summary, cases)
    return 0


def print_summary(summary, cases):
    """Print the summary tables and the targets of :func:`main`'s rows."""
    k = len(bench_figures.NAMES)
    print()
    print('Summary per arm and payload: the figures of issue 38 (ours / TOPP-RA Collocation on '
          'its chord spline, median / worst over the paths planned; along our path: TOPP-RA with '
          'the same constraints on our path; shaking: benchmarks/shaking.py)')
    print('| arm | payload [kg] (held at every waypoint) | paths planned / refused | '
          + bench_figures.header() + ' |')
    print(bench_figures.rule(3 + k))
    for name, payload, held, rows, refused in summary:
        cells = bench_figures.summary(rows[:, :k]) if len(rows) else ' | '.join(['-'] * k)
        print(f'| {name} | {payload:.2f} ({held:.1f}) | {len(rows)} / {len(refused)} | '
              + cells + ' |')
    print()
    print("The same paths with speed_profile='time_optimal' "
          '(planning/path_following/time_optimal.py: the torque a row of the third-order '
          'profile), and its peak torque / limit at 1 kHz')
    print('| arm | payload [kg] | ' + bench_figures.header() + ' | peak torque |')
    print(bench_figures.rule(3 + k))
    for name, payload, _, rows, _ in summary:
        if len(rows):
            print(f'| {name} | {payload:.2f} | '
                  + bench_figures.summary(rows[:, k + 9:2 * k + 9])
                  + f' | {np.max(rows[:, 2 * k + 9]):.4f} |')
    print()
    print('Torques and the other plans (peak torques / limit at 1 kHz, max over the paths):')
    print('| arm | payload [kg] | ours peak torque | TOPP-RA peak torque | TOPP-RA along our '
          'path peak torque | TOPP-RA Interpolation: duration / Collocation median, peak '
          'torque | shorter than constant a: median / worst | inner_knots=0: duration / '
          'TOPP-RA median / worst, peak torque | v/a/j limits held (exact peaks) |')
    print(bench_figures.rule(9))
    met_duration = met_torque = met_planning = True
    for name, payload, _, rows, refused in summary:
        for case, reason in refused:
            print(f'| {name} | {payload:.2f} | path {case} refused: {reason} | | | | | | |')
        if not len(rows):
            continue
        extra = rows[:, k:]
        median = np.median(rows, axis=0)
        met_duration &= median[0] <= 1.05
        met_planning &= median[k - 1] <= 1.0
        met_torque &= max(np.max(extra[:, 0]), np.max(extra[:, 6]),
                          np.max(extra[:, 2 * k + 9 - k])) <= 1.005
        print(f'| {name} | {payload:.2f} | {np.max(extra[:, 0]):.4f} | {np.max(extra[:, 1]):.3f} '
              f'| {np.max(extra[:, 7]):.3f} '
              f'| {np.median(extra[:, 2]):.3f}, {np.max(extra[:, 3]):.3f} '
              f'| {100 * np.nanmedian(extra[:, 4]):.1f} % / {100 * np.nanmin(extra[:, 4]):.1f} % '
              f'| {np.median(extra[:, 5]):.3f} / {np.max(extra[:, 5]):.3f}, '
              f'{np.max(extra[:, 6]):.4f} | {bool(np.all(extra[:, 8]))} |')
    print()
    print(f'({cases} paths drawn per arm.)')
    print("Duration median <= 1.05 x TOPP-RA's on every row: "
          + ('met' if met_duration else 'NOT met'))
    print("Planning time median <= TOPP-RA's on every row: "
          + ('met' if met_planning else 'NOT met'))
    print('Our peak torque <= 1.005 x its limit at 1 kHz on every path: '
          + ('met' if met_torque else 'NOT met'))


if __name__ == '__main__':
    sys.exit(main())
