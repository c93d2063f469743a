"""
Torque limits and payload (issue 25): 555 optimal with torque limits against TOPP-RA, one run.

For the UR5 and the Franka Panda (example-robot-data's URDFs), random
reachable joint paths (fixed seed; 5 to 30 waypoints, a random walk from
the ready pose with steps uniform in +-0.3 rad per joint, clipped to the
joint ranges less 0.05 rad), each planned with payload 0 and with the
rated payload (UR5 5 kg, Panda 3 kg; a point mass 0.1 m from the flange
along the tool frame's z).  Limits: velocity and torque from the URDF
(``<limit velocity>``, ``<limit effort>``); no acceleration limit in
effect (plan() needs one: :data:`NO_ACCELERATION_LIMIT` rad/s^2 on every
joint); jerk :data:`JERK_RATIO` times a typical acceleration (below).
The inverse dynamics is :class:`splines445_ros.robot.dynamics.
ArmDynamics` (MuJoCo RNE, payload included), the same for both planners:
ours is given the ArmDynamics itself (its torques, and its ``gravity``
pass for the torques at rest), TOPP-RA its ``torques``.

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
  own cubic spline through the waypoints over normalised chord length,
  default grid, ``ParametrizeConstAccel``; no jerk limit.  Its default
  Collocation holds the torque at its grid points only: checked here at
  1 kHz, and its Interpolation discretisation shown next to it.

Per robot and payload: durations ours / TOPP-RA (median, worst), planning
times ours / TOPP-RA (each best of :data:`REPEATS`, timed in turn; median ratio), the
peak 1 kHz torque / limit of both, how much shorter ours is than today's
practice, and the shaking of a lightly damped 4 and 8 Hz mode
(``shaking.py``; ours / TOPP-RA, medians).  Targets: duration median at
most 1.05 x TOPP-RA's; our 1 kHz torque peak at most 1.005 x its limit.

Usage: ``python benchmarks/bench_torque.py``; SPLINES445_BENCH_FULL=1 for
:data:`FULL_CASES` paths per robot instead of :data:`CASES`.
"""

import logging
import os
import sys

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import numpy as np  # noqa: E402
from shaking import of_toppra, shaking_figures, shaking_header, shaking_ratios  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.torque import CHECK_PERIOD  # noqa: E402 - [s] the 1 kHz torque check
from splines445_ros.robot.dynamics import ArmDynamics, effort_limits  # noqa: E402, I100
from splines445_ros.robot.robot_model import load_robot_model  # noqa: E402
from splines445_ros.tools import vendor_robots as vr  # noqa: E402
from wall_time import interleaved_best_of  # noqa: E402

SEED = 25
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
ROBOTS = (
    ('UR5', vr.ur5_urdf, vr.UR5_JOINTS, vr.UR5_READY, 'tool0', 5.0),
    ('Panda', vr.panda_urdf, vr.PANDA_ARM_JOINTS, vr.PANDA_READY, 'panda_hand_tcp', 3.0),
)


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


def toppra_torque(points, vmax, tau_max, torques, interpolation=False):
    """
    TOPP-RA with velocity and torque limits on its chord-length spline; its trajectory.

    ``interpolation``: toppra's Interpolation discretisation of the torque
    constraint instead of its default Collocation.
    """
    import toppra
    import toppra.algorithm
    import toppra.constraint
    chords = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    path = toppra.SplineInterpolator(chords / chords[-1], points)
    scheme = (toppra.constraint.DiscretizationType.Interpolation if interpolation
              else toppra.constraint.DiscretizationType.Collocation)
    constraints = [
        toppra.constraint.JointVelocityConstraint(np.column_stack([-vmax, vmax])),
        toppra.constraint.JointTorqueConstraint(torques, np.column_stack([-tau_max, tau_max]),
                                                np.zeros(len(vmax)), scheme)]
    instance = toppra.algorithm.TOPPRA(constraints, path, parametrizer='ParametrizeConstAccel')
    return instance.compute_trajectory()


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
    """Plan every path with one payload, print a line per path; return the figures (C, 13)."""
    dynamics = ArmDynamics(robot, joints, tool, payload_mass=payload,
                           payload_center_of_mass=PAYLOAD_OFFSET)
    torques = dynamics.torques
    n = len(joints)
    rows = []
    for case, points in enumerate(paths):
        typical, slow = bisected_acceleration(points, vmax, torques, tau_max)
        # TOPP-RA's plan sets our jerk limits; then both are timed in turn.
        jerk = JERK_RATIO * typical_accelerations(toppra_torque(points, vmax, tau_max, torques))
        (t_top, top), (t_ours, traj) = interleaved_best_of((
            lambda: toppra_torque(points, vmax, tau_max, torques),
            lambda: plan(points, '555', 'optimal', max_velocity=vmax,
                         max_acceleration=np.full(n, NO_ACCELERATION_LIMIT), max_jerk=jerk,
                         max_torque=tau_max, inverse_dynamics=dynamics)), REPEATS)
        knots_only = plan(points, '555', 'optimal', inner_knots=0, max_velocity=vmax,
                          max_acceleration=np.full(n, NO_ACCELERATION_LIMIT), max_jerk=jerk,
                          max_torque=tau_max, inverse_dynamics=dynamics)
        fine = toppra_torque(points, vmax, tau_max, torques, interpolation=True)
        ours_peak = np.max(peak_torque(ours_samples(traj), torques, tau_max))
        knots_peak = np.max(peak_torque(ours_samples(knots_only), torques, tau_max))
        top_peak = np.max(peak_torque(toppra_samples(top), torques, tau_max))
        fine_peak = np.max(peak_torque(toppra_samples(fine), torques, tau_max))
        # Shaking in units of the constant acceleration (common to all joints: the
        # ratios do not depend on it).
        scale = np.full(n, typical)
        reference = shaking_figures(of_toppra(top), top.duration, scale)
        shaking = shaking_ratios(traj, reference, scale)
        ratio = traj.duration / top.duration
        binds, vaj = binding(traj, ours_peak)
        rows.append([ratio, t_ours / t_top, ours_peak, top_peak, fine.duration / top.duration,
                     fine_peak, 1.0 - traj.duration / slow.duration,
                     knots_only.duration / top.duration, knots_peak] + shaking)
        print(f'| {name} | {payload:g} | {case} | {len(points)} | {typical:.1f} '
              f'| {top.duration:.3f} | {fine.duration:.3f} | {traj.duration:.3f} | {ratio:.3f} '
              f'| {slow.duration:.3f} | {1e3 * t_top:.0f} | {1e3 * t_ours:.0f} '
              f'| {knots_only.duration:.3f} | {ours_peak:.4f} / {knots_peak:.4f} '
              f'| {top_peak:.3f} / {fine_peak:.3f} '
              f'| {vaj[0]:.2f} / {vaj[1]:.2f} / {vaj[2]:.2f} | {binds} |')
        sys.stdout.flush()
    return np.array(rows)


def main():
    """Run the comparison and print the tables."""
    logging.getLogger('toppra').setLevel(logging.ERROR)
    full = os.environ.get('SPLINES445_BENCH_FULL') == '1'
    cases = FULL_CASES if full else CASES
    print('Command: ' + ('SPLINES445_BENCH_FULL=1 ' if full else '')
          + 'python benchmarks/bench_torque.py')
    print(f'Settings: seed {SEED}; {cases} paths per robot, {POINTS[0]}-{POINTS[1]} waypoints '
          f'(random walk from the ready pose, steps uniform in +-{STEP} rad, clipped to the '
          f'joint ranges less {RANGE_MARGIN} rad), the same paths for both payloads; payload 0 '
          f'and rated, a point mass at {PAYLOAD_OFFSET} m in the tool frame; velocity and '
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
          'Interpolation shown too); '
          "ours: plan(..., '555', 'optimal', max_torque=..., inverse_dynamics=dynamics) (the "
          'ArmDynamics: its gravity pass at rest; TOPP-RA dynamics.torques), default inner '
          'knots (inner_knots=0 shown too).')
    print()
    print('| robot | payload [kg] | case | N | constant a [rad/s^2] | TOPP-RA [s] '
          '| TOPP-RA Interpolation [s] | ours [s] | ours / TOPP-RA | constant a [s] '
          '| TOPP-RA planning [ms] | ours planning [ms] | ours inner_knots=0 [s] '
          '| ours peak torque (default / inner_knots=0) '
          '| TOPP-RA peak torque (Collocation / Interpolation) | ours v / a / j ratios '
          f'| ours at (>= {BINDS:g}) |')
    print('|' + '---|' * 17)
    rng = np.random.default_rng(SEED)
    summary = []
    for name, urdf, joints, ready, tool, rated in ROBOTS:
        robot = load_robot_model(urdf())
        lower, upper, vmax, tau_max = joint_limits(robot, joints)
        paths = [random_path(rng, ready, lower, upper) for _ in range(cases)]
        for payload in (0.0, rated):
            summary.append((name, payload,
                            run_row(name, robot, joints, tool, payload, paths, vmax, tau_max)))
    print()
    print('Summary (ratios ours / TOPP-RA Collocation unless stated; peak torques / limit at '
          '1 kHz; shaking: medians, benchmarks/shaking.py):')
    print('| robot | payload [kg] | cases | duration: median / worst | planning time: median '
          '| ours peak torque: max | TOPP-RA peak torque: max | TOPP-RA Interpolation: '
          'duration / Collocation median, peak torque max | shorter than constant a: median '
          '/ worst | inner_knots=0: duration median / worst, peak torque max | '
          + shaking_header() + ' |')
    print('|' + '---|' * 14)
    met_duration = met_torque = met_planning = True
    for name, payload, rows in summary:
        median = np.median(rows, axis=0)
        met_duration &= median[0] <= 1.05
        met_planning &= median[1] <= 1.0
        met_torque &= max(np.max(rows[:, 2]), np.max(rows[:, 8])) <= 1.005
        print(f'| {name} | {payload:g} | {len(rows)} | {median[0]:.3f} / {np.max(rows[:, 0]):.3f} '
              f'| {median[1]:.2f} | {np.max(rows[:, 2]):.4f} | {np.max(rows[:, 3]):.3f} '
              f'| {median[4]:.3f}, {np.max(rows[:, 5]):.3f} '
              f'| {100 * median[6]:.1f} % / {100 * np.min(rows[:, 6]):.1f} % '
              f'| {median[7]:.3f} / {np.max(rows[:, 7]):.3f}, {np.max(rows[:, 8]):.4f} | '
              + ' | '.join(f'{value:.2f}' for value in median[9:]) + ' |')
    print()
    print("Duration median <= 1.05 x TOPP-RA's on every row: "
          + ('met' if met_duration else 'NOT met'))
    print("Planning time median <= TOPP-RA's on every row: "
          + ('met' if met_planning else 'NOT met'))
    print('Our peak torque <= 1.005 x its limit at 1 kHz on every path: '
          + ('met' if met_torque else 'NOT met'))
    return 0


if __name__ == '__main__':
    sys.exit(main())
