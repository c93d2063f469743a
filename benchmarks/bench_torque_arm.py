"""
Torque limits and payload on the dynamic UR5 and every vendor arm: saturation, errors, 434/445/555.

The UR5 (example-robot-data's URDF) simulated as ``arm_sim_node`` simulates
it (``simulation: dynamic``, ``model_file`` the URDF, ``tool_frame: tool0``,
the model's torque limits and inertia gains, PD + inverse-dynamics
feed-forward, 2 ms actuator lag, physics at 1 kHz), holding the rated
payload: 5 kg, a point mass 0.1 m along tool0's z.  The payload goes into
the simulated model and into the controller's rigid model (its feed-forward
knows it), by ``arm_sim_model.add_payload`` as the node does; the gains are
those of the arm with its payload (``resolve_model_config``).  The planner's
inverse dynamics is :class:`splines445_ros.robot.dynamics.ArmDynamics` with
the same payload and, as ``planner_node``'s default ``torque_counts_friction``,
the joints' damping and dry friction (``include_damping``).

Paths (a fresh seed every run): random walks from the ready pose, 5 to 15 waypoints,
steps uniform in +-0.3 rad per joint, clipped to the joint ranges less
0.05 rad.  Plans:

* (A) ours: ``plan(points, '555', 'optimal', max_torque=0.9 <URDF effort>,
  inverse_dynamics=...)``, the limits less ``planner_node``'s default
  ``torque_headroom`` (0.1, room for the feedback's corrections; smoothing
  "auto": no windows with torque limits), velocity from the URDF,
  acceleration 1000 rad/s^2 (a stand-in: plan() needs one), jerk 50 ``a``
  with ``a`` the path's typical acceleration of ``bench_torque.py`` (the
  largest constant acceleration, common to all joints, whose torque-free
  plan holds the torque on the path);
* (A100) the same at the full efforts (``torque_headroom: 0``);
* (B) the kinematic plan: 555 optimal with ``config/ur5_joint_limits.yaml``
  (velocity from the URDF, acceleration 4 / 8 rad/s^2, jerk 40 / 80
  rad/s^3), no torque limit;
* (C) 434, 445 and 555 with uniform timing under A's limits (torque limits
  by the uniform slow-down), played twice: each at its own duration, and
  all on the slowest method's segment durations (``timing='fixed'``, as
  ``bench_smoothness.py``'s "same duration": only the spline shape differs).

Per play (1 s of holding after the end): saturated steps (the torque
command clipped at the actuator's limit), peak |tau| / limit (the
planner's own 1 kHz figure; the controller's demand before clipping,
feed-forward + PD; the applied torque; largest joint), max joint
tracking error while moving, max tool position error (``kin.forward`` of
the played against the planned joints, the whole run), how far the tool
leaves the planned tool path (distance to the nearest point of the path
sampled at 0.1 ms), the residual vibration (RMS joint error over the second
after the end), peak |dtau/dt| of the applied torque and the largest jump
of the commanded torque rate away from the ends, as
``bench_smoothness.py`` defines them (its ``Simulator.simulate``, reused).

Then every 6-7-joint arm of example-robot-data (``bench_arms.py``), each
built the same way from its URDF with ``bench_torque``'s payload (the rated
one, or less where the URDF efforts do not hold it) and its ready pose as
``initial_positions``: A and A100 on a few random walks of the arm's own
stream of the run's seed, one row per arm (saturation, peak applied torque,
the controller's demand, joint and tool error; :func:`every_arm`).

Run: ``make bench`` or ``python benchmarks/bench_torque_arm.py [--paths N] [--arm-paths N]``.
"""

import argparse
import os
import sys
import time

os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'  # no ROS here, but the rule holds

import bench_arms  # noqa: E402, I100
import bench_seeds  # noqa: E402
import bench_smoothness as smooth  # noqa: E402
import bench_torque  # noqa: E402
import numpy as np  # noqa: E402, I100
from scipy.spatial import cKDTree  # noqa: E402
from splines445_ros.planning import plan  # noqa: E402
from splines445_ros.planning.constraints.joint_torque import friction_on_sides  # noqa: E402
from splines445_ros.robot.dynamics import ArmDynamics  # noqa: E402
from splines445_ros.service.arm_sim_config import ArmSimConfig  # noqa: E402
from splines445_ros.service.arm_sim_model import add_payload, resolve_model_config  # noqa: E402
from splines445_ros.service.planner_config import DEFAULT_TORQUE_HEADROOM  # noqa: E402
from splines445_ros.sim.dynamic_sim import DynamicArm  # noqa: E402
from splines445_ros.sim.mujoco_model import load_arm_model  # noqa: E402
from splines445_ros.tools import robot_seam_demo as seam  # noqa: E402
from splines445_ros.tools import vendor_robots as vr  # noqa: E402

N_PATHS = 6
POINTS = (5, 15)
STEP = 0.3                      # [rad] largest random-walk step per joint
RANGE_MARGIN = 0.05             # [rad] kept from each end of a joint's range
TOOL = 'tool0'
PAYLOAD = 5.0                   # [kg] the UR5's rated payload
PAYLOAD_OFFSET = bench_torque.PAYLOAD_OFFSET    # [m] its centre of mass in tool0
NO_ACCELERATION_LIMIT = bench_torque.NO_ACCELERATION_LIMIT
JERK_RATIO = bench_torque.JERK_RATIO
SHARE = 1.0 - DEFAULT_TORQUE_HEADROOM     # A: max_torque = SHARE * effort
PATH_PERIOD = 1e-4              # [s] sampling of the planned tool path (off-path distance)
METHODS = ('434', '445', '555')
PLANS = {'A': f"torque-limited 555 optimal at {SHARE:g} x the limits (the node's default)",
         'A100': 'torque-limited 555 optimal at the limits',
         'B': "config's acceleration limits, no torque limit"}
MODES = ('own duration', 'same duration')
COLUMNS = (('sat', 'saturated steps', 1.0, '.0f'),
           ('plan_ratio', 'plan peak |tau|/limit', 1.0, '.3f'),
           ('demand', 'demand |tau|/limit', 1.0, '.3f'),
           ('ratio', 'peak |tau|/limit', 1.0, '.3f'),
           ('max', 'max joint err [mrad]', 1e3, '.3g'),
           ('tool_fk', 'tool err [mm]', 1e3, '.3g'), ('off_path', 'off path [mm]', 1e3, '.3g'),
           ('residual', 'residual [mrad]', 1e3, '.3g'),
           ('rate', 'peak |dtau/dt| [kN m/s]', 1e-3, '.3g'),
           ('jump', 'max jump dtau/dt [kN m/s]', 1e-3, '.3g'))


def random_path(rng, ready, lower, upper):
    """Return a random walk (N, n) from ``ready`` within [lower, upper]."""
    n_points = int(rng.integers(POINTS[0], POINTS[1] + 1))
    points = [np.array(ready, dtype=float)]
    for _ in range(n_points - 1):
        points.append(np.clip(points[-1] + rng.uniform(-STEP, STEP, len(ready)), lower, upper))
    return np.array(points)


class Recorder:
    """A DynamicArm that keeps the log of its last run."""

    def __init__(self, arm):
        """Wrap ``arm``."""
        self.arm = arm
        self.log = None

    def reset(self, *args):
        """Reset the arm."""
        self.arm.reset(*args)

    def run(self, q_d, v_d, a_d):
        """Run the arm and keep its log."""
        self.log = self.arm.run(q_d, v_d, a_d)
        return self.log


class ArmSimulator(smooth.Simulator):
    """A node's dynamic arm (the UR5) with a payload: ``bench_smoothness``' figures, the tool's."""

    def __init__(self, kin, model_file=None, joints=vr.UR5_JOINTS, initial=vr.UR5_READY,
                 tool=TOOL, payload=PAYLOAD):
        """Build the arm as arm_sim_node does (model file, tool frame, payload)."""
        config = ArmSimConfig(simulation='dynamic', model_file=model_file or vr.ur5_urdf(),
                              joint_names=tuple(joints),
                              initial_positions=tuple(float(v) for v in initial),
                              tool_frame=tool, payload_mass=float(payload),
                              payload_center_of_mass=PAYLOAD_OFFSET)
        config, self.sources = resolve_model_config(config)
        model = load_arm_model(config.joint_names, config.torque_limits,
                               config.actuator_time_constant, config.timestep,
                               model_file=config.model_file, tool_site=config.tool_site,
                               tool_frame=config.tool_frame)
        add_payload(model, config)
        self.model = model
        self.config = config
        self.limits = np.array(config.torque_limits)
        self.arm = Recorder(DynamicArm(model, config.kp, config.kd, config.torque_limits,
                                       design_pose=config.initial_positions))
        self.kin = kin
        self.dt = config.timestep
        self.wall = 0.0
        self.simulated = 0.0
        self.played = {}
        self.site_gap = 0.0
        # The rebuild knows rigid joints only (an elastic joint's target moves with its link).
        self.rebuildable = not np.any(self.arm.arm._elastic)
        self.clip_gap = 0.0
        self.design = None      # the inertia diagonal at the initial pose (demand)

    def demand(self, q, traj):
        """
        Return the peak |command| / limit the controller asked for before clipping.

        Rebuilt from the log (rigid joints): the feed-forward at the reference
        and the arm's friction compensation (``DynamicArm.friction_compensation``
        of the reference velocity and the position error) plus the PD terms
        on the measured state, mapped through ``M diag(M_0)^-1`` (``M`` at the
        reference, ``M_0`` at the initial pose, both read here from MuJoCo);
        on every step that did not saturate it must be the logged command
        (the largest gap is kept).
        """
        import mujoco
        arm, log = self.arm.arm, self.arm.log
        t = np.arange(len(q)) * self.dt
        clamped = np.minimum(t, traj.duration)
        v = traj.evaluate(clamped, 1)
        a = traj.evaluate(clamped, 2)
        moving = t <= traj.duration
        v[~moving] = 0.0
        a[~moving] = 0.0
        rigid, dofs = arm.arm.rigid, arm.arm.rigid_dof
        full = np.zeros((rigid.nv, rigid.nv))
        if self.design is None:     # M_0, once
            data = mujoco.MjData(rigid)
            data.qpos[arm.arm.rigid_qpos] = self.config.initial_positions
            mujoco.mj_forward(rigid, data)
            mujoco.mj_fullM(rigid, data, full)
            self.design = np.diag(full)[dofs].copy()
        design = self.design
        raw = np.empty_like(q)
        compensate = bool(np.any(arm.friction > 0.0))
        for k in range(len(q)):
            forward = arm.feedforward(q[k], v[k], a[k])
            mujoco.mj_fullM(rigid, arm.rigid_data, full)
            inertia = full[np.ix_(dofs, dofs)]
            error = q[k] - log['position'][k]
            if compensate:
                forward = forward + arm.friction_compensation(v[k], error)
            feedback = arm.kp * error + arm.kd * (v[k] - log['velocity'][k])
            raw[k] = forward + inertia @ (feedback / design)
        # Where it saturated the arm shares the limits out (DynamicArm.decoupled_command):
        # the rebuild is checked on the other steps.
        kept = ~log['saturated']
        if np.any(kept):
            self.clip_gap = max(self.clip_gap,
                                float(np.abs(raw[kept] - log['command'][kept]).max()))
        return float(np.max(np.abs(raw) / self.limits))

    def simulate(self, traj):
        """Play ``traj`` (bench_smoothness's figures), add torque ratio and tool figures."""
        row = smooth.Simulator.simulate(self, traj)
        log = self.arm.log
        t = np.arange(0.0, traj.duration + smooth.SETTLE, self.dt)
        q = traj.evaluate(np.minimum(t, traj.duration), 0)
        played = self.kin.forward(log['position'])[:, :3]
        planned = self.kin.forward(q)[:, :3]
        tool = np.linalg.norm(played - planned, axis=1)
        dense = np.linspace(0.0, traj.duration, int(np.ceil(traj.duration / PATH_PERIOD)) + 1)
        path = cKDTree(self.kin.forward(traj.evaluate(dense, 0))[:, :3])
        off_path, _ = path.query(played)
        moving = t <= traj.duration
        self.site_gap = max(self.site_gap, float(np.abs(tool[moving]
                                                        - log['tool_error'][moving]).max()))
        row.update({'demand': self.demand(q, traj) if self.rebuildable else np.nan,
                    'ratio': float(np.max(np.abs(log['effort']) / self.limits)),
                    'sat': row['saturated'], 'tool_fk': float(tool.max()),
                    'off_path': float(off_path.max())})
        return row


def torque_limits(points, dynamics, vmax, tau_max):
    """Return (the path's typical acceleration, plan()'s torque-limited keywords at the limits)."""
    n = points.shape[1]
    typical, _ = bench_torque.bisected_acceleration(points, vmax, dynamics.torques, tau_max)
    return typical, {'max_velocity': vmax, 'max_acceleration': np.full(n, NO_ACCELERATION_LIMIT),
                     'max_jerk': np.full(n, JERK_RATIO * typical),
                     'max_torque': tau_max, 'inverse_dynamics': dynamics}


class Case:
    """One path and its plans."""

    def __init__(self, points, dynamics, vmax, tau_max, config_limits):
        """Plan A, B and C on ``points``."""
        self.points = points
        self.typical, limits = torque_limits(points, dynamics, vmax, tau_max)
        started = time.perf_counter()
        self.plans = {'A': plan(points, '555', 'optimal',
                                **dict(limits, max_torque=SHARE * tau_max))}
        self.planning_a = time.perf_counter() - started
        self.plans['A100'] = plan(points, '555', 'optimal', **limits)
        self.plans['B'] = plan(points, '555', 'optimal', **config_limits)
        own = {m: plan(points, m, 'uniform', **limits) for m in METHODS}
        slowest = max(own.values(), key=lambda t: t.duration)
        same = {m: plan(points, m, 'fixed', durations=slowest.durations) for m in METHODS}
        self.uniform = {'own duration': own, 'same duration': same}
        self.plan_ratio = {}
        for traj in [*self.plans.values(), *own.values(), *same.values()]:
            self.plan_ratio[id(traj)] = motor_peak(bench_torque.ours_samples(traj), dynamics,
                                                   tau_max)


def motor_peak(samples, dynamics, tau_max):
    """
    Return the largest |tau| / limit over 1 kHz ``samples``: the motors' torque.

    ``dynamics``' torques (its damping with them when it counts it) and
    its dry friction (``dry_friction``, when it gives one) on the side each
    joint moves to, as the planner counts them (``friction_on_sides``).
    """
    q, qd, _ = samples
    tau = dynamics.torques(*samples)
    if dynamics.dry_friction is None:
        return float(np.max(np.abs(tau) / tau_max))
    up, down = friction_on_sides(dynamics.dry_friction(q), qd)
    return float(np.max(np.maximum(tau + up, down - tau) / tau_max))


ARM_PATHS = 3                   # random paths per arm in the every-arm table
ARM_STREAM_OFFSET = 25          # bench_torque's streams of an arm are its CRC + 0 and + 1


def every_arm(paths_per_arm):
    """
    Plan A and A100 on every vendor arm with its payload, play them; print a row per arm.

    Returns the simulators' largest gaps of the demand rebuild (``ArmSimulator.demand``).

    As for the UR5 above: each arm as ``arm_sim_node`` builds it from its URDF
    (the model's limits and inertia gains, ``tool_frame`` the bench tool,
    ``initial_positions`` the ready pose), carrying ``bench_torque``'s payload
    (the rated one, or less where the URDF efforts do not hold it), on random
    walks of the arm's own stream of the run's seed.
    """
    arms, _ = bench_arms.vendor_arms()
    print(f'\nEvery arm ({paths_per_arm} random paths each): A at {SHARE:g} x and A100 at the '
          'URDF efforts, played on the dynamic arm with the payload (saturated steps: sum '
          'over the paths; the rest: the largest)')
    print('| arm | payload [kg] | plans | A saturating paths (steps) | A peak |tau|/limit | '
          'A demand | A max joint err [mrad] | A tool err [mm] | A100 saturating paths (steps) '
          '| A100 peak |tau|/limit | A100 demand | duration A / A100 (median) |')
    print('|' + '---|' * 12)
    rows, simulators = [], []
    for arm in arms:
        paths = bench_torque.arm_paths(arm, paths_per_arm, ARM_STREAM_OFFSET)
        payload, _ = bench_torque.bench_payload(arm, paths)
        dynamics = ArmDynamics(arm.robot, arm.joints, arm.tool, payload_mass=payload,
                               payload_center_of_mass=PAYLOAD_OFFSET, include_damping=True)
        _, _, vmax, tau_max = bench_torque.joint_limits(arm.robot, arm.joints)
        sim = ArmSimulator(arm.kinematics(), os.path.join(bench_arms.robots_folder(), arm.file),
                           arm.joints, arm.ready, arm.tool, payload)
        simulators.append(sim)
        played = {'A': [], 'A100': []}
        ratios = []
        for points in paths:
            try:
                _, limits = torque_limits(points, dynamics, vmax, tau_max)
                plans = {'A': plan(points, '555', 'optimal',
                                   **dict(limits, max_torque=SHARE * tau_max)),
                         'A100': plan(points, '555', 'optimal', **limits)}
            except (ValueError, RuntimeError):
                continue    # bench_torque reports the refusals
            for name, traj in plans.items():
                played[name].append(sim.run(traj))
            ratios.append(plans['A'].duration / plans['A100'].duration)
        if not ratios:
            print(f'| {arm.name} | {payload:.2f} | 0 | every path refused |' + ' |' * 8)
            continue

        def figures(name):
            found = played[name]
            demand = max(r['demand'] for r in found)
            return (f'{sum(r["sat"] > 0 for r in found)} ({sum(r["sat"] for r in found):.0f})',
                    f'{max(r["ratio"] for r in found):.3f}',
                    'n/a' if np.isnan(demand) else f'{demand:.3f}')
        a_sat, a_peak, a_demand = figures('A')
        b_sat, b_peak, b_demand = figures('A100')
        rows.append((arm.name, played))
        print(f'| {arm.name} | {payload:.2f} | {len(ratios)} | {a_sat} | {a_peak} | {a_demand} | '
              f'{1e3 * max(r["max"] for r in played["A"]):.3g} | '
              f'{1e3 * max(r["tool_fk"] for r in played["A"]):.3g} | {b_sat} | {b_peak} | '
              f'{b_demand} | {np.median(ratios):.3f} |')
        sys.stdout.flush()
    saturating = [name for name, played in rows if any(r['sat'] > 0 for r in played['A'])]
    gaps = [sim.clip_gap for sim in simulators]
    names = ': ' + ', '.join(saturating) if saturating else ''
    unknown = any(np.isnan(r['demand']) for _, played in rows for r in played['A'])
    print(f"* A (the node's default headroom) saturates on {len(saturating)} of {len(rows)} "
          f'arms{names}' + (' (demand n/a: elastic joints, which the rebuild leaves out)'
                            if unknown else ''))
    return gaps


def cells(row):
    """Return the table cells of one row."""
    return ' | '.join(f'{row[key] * scale:{fmt}}' for key, _, scale, fmt in COLUMNS)


def header(first):
    """Return the header line and separator of a table whose first columns are ``first``."""
    names = list(first) + [c[1] for c in COLUMNS]
    return '| ' + ' | '.join(names) + ' |\n|' + '---|' * len(names)


def play(sim, case, traj):
    """Return the simulated row of ``traj`` with the planner's torque ratio."""
    row = sim.run(traj)
    row['plan_ratio'] = case.plan_ratio[id(traj)]
    return row


def main(argv=None):
    """Plan, play and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--paths', type=int, default=N_PATHS, help='random paths')
    parser.add_argument('--arm-paths', type=int, default=ARM_PATHS,
                        help='random paths per arm in the every-arm table (0: none)')
    args = parser.parse_args(argv)
    started = time.perf_counter()
    print(__doc__.strip().splitlines()[0])
    kin, config_limits, _ = seam.setup('ur5')
    robot = kin.robot
    joints = vr.UR5_JOINTS
    lower, upper, vmax, tau_max = bench_torque.joint_limits(robot, joints, RANGE_MARGIN)
    dynamics = ArmDynamics(robot, joints, TOOL, payload_mass=PAYLOAD,
                           payload_center_of_mass=PAYLOAD_OFFSET, include_damping=True)
    sim = ArmSimulator(kin)
    print(f'UR5, payload {PAYLOAD:g} kg at {PAYLOAD_OFFSET} m in {TOOL} (simulated model and '
          'controller feed-forward, by arm_sim_model.add_payload; planner: ArmDynamics); '
          f'torque limits {tau_max.tolist()} N m (URDF effort); physics at '
          f'{1.0 / sim.dt:.0f} Hz, actuator lag {1e3 * sim.config.actuator_time_constant:g} ms')
    for name, text in sim.sources.items():
        print(f'* {name}: {text}')
    print(f'* config/ur5_joint_limits.yaml: a {config_limits["max_acceleration"].tolist()} '
          f'rad/s^2, j {config_limits["max_jerk"].tolist()} rad/s^3, v '
          f'{np.round(config_limits["max_velocity"], 3).tolist()} rad/s')
    rng = bench_seeds.generator()
    paths = [random_path(rng, vr.UR5_READY, lower, upper) for _ in range(args.paths)]
    print(f'* {len(paths)} paths (seed {bench_seeds.run_seed()}), {POINTS[0]}-{POINTS[1]} '
          'waypoints, steps '
          f'+-{STEP} rad; A and C: a {NO_ACCELERATION_LIMIT:g} rad/s^2 (stand-in), jerk '
          f"{JERK_RATIO:g} x the path's typical acceleration (bench_torque.py)")
    planning_started = time.perf_counter()
    cases = [Case(p, dynamics, vmax, tau_max, config_limits) for p in paths]
    planning = time.perf_counter() - planning_started
    sys.stdout.flush()

    print(f'\nA (555 optimal, torque-limited at {SHARE:g} x the limits), A100 (the same at '
          "the limits) and B (555 optimal, the config's a and j, no torque limit) on the "
          'dynamic UR5 with the payload, per path')
    print(header(('case', 'N', 'plan', 'a typ [rad/s^2]', 'duration [s]')))
    rows = {name: [] for name in PLANS}
    for k, case in enumerate(cases):
        for name in PLANS:
            traj = case.plans[name]
            row = play(sim, case, traj)
            rows[name].append(row)
            print(f'| {k} | {len(case.points)} | {name} | {case.typical:.2f} '
                  f'| {traj.duration:.3f} | {cells(row)} |')
        sys.stdout.flush()
    print('\nSummary:')
    for name, what in PLANS.items():
        saturating = [r for r in rows[name] if r['sat'] > 0]
        text = (f'{len(saturating)}/{len(rows[name])} paths saturate '
                f'({sum(r["sat"] for r in rows[name])} steps in all); peak |tau|/limit '
                f'max {max(r["ratio"] for r in rows[name]):.3f} (controller\'s demand '
                f'{max(r["demand"] for r in rows[name]):.3f}, planner\'s 1 kHz '
                f'{max(r["plan_ratio"] for r in rows[name]):.3f}); tool error max '
                f'{1e3 * max(r["tool_fk"] for r in rows[name]):.3g} mm, off path max '
                f'{1e3 * max(r["off_path"] for r in rows[name]):.3g} mm')
        if saturating:
            text += (f'; on the saturating paths: tool error max '
                     f'{1e3 * max(r["tool_fk"] for r in saturating):.3g} mm, off path max '
                     f'{1e3 * max(r["off_path"] for r in saturating):.3g} mm')
        print(f'* {name} ({what}): {text}')
    for a, b in (('A', 'B'), ('A', 'A100')):
        ratios = np.array([c.plans[a].duration / c.plans[b].duration for c in cases])
        print(f'* duration {a} / {b}: median {np.median(ratios):.3f}, range '
              f'{np.min(ratios):.3f} to {np.max(ratios):.3f}')
    print(f'* A planning time median {1e3 * np.median([c.planning_a for c in cases]):.0f} ms')
    sys.stdout.flush()

    verdicts = []
    for mode in MODES:
        print(f'\nC: uniform timing under the torque limits, {mode}: mean over the paths '
              '(saturated steps: sum; |tau|/limit: the largest)')
        print(header(('method', 'duration [s]')))
        found = {m: [play(sim, c, c.uniform[mode][m]) for c in cases] for m in METHODS}
        for m in METHODS:
            mean = {key: np.mean([r[key] for r in found[m]]) for key, *_ in COLUMNS}
            mean['sat'] = sum(r['sat'] for r in found[m])
            for key in ('plan_ratio', 'demand', 'ratio'):
                mean[key] = max(r[key] for r in found[m])
            duration = np.mean([c.uniform[mode][m].duration for c in cases])
            print(f'| {m} | {duration:.3f} | {cells(mean)} |')
        for a, b in (('445', '434'), ('555', '434'), ('555', '445')):
            line = smooth.verdict(found, a, b)
            print(line)
            verdicts.append(f'{mode}: {line}')
        sys.stdout.flush()
    gaps = every_arm(args.arm_paths) if args.arm_paths > 0 else []
    print(f'Demand rebuilt from the log against the logged command where it did not '
          f'saturate: largest difference {max([sim.clip_gap, *gaps]):.3g} N m')
    print(f"Tool error by kin.forward against the simulator's own tool-site error while "
          f'moving: largest difference {1e6 * sim.site_gap:.3g} um')
    print(f'Real-time factor: {sim.simulated:.0f} s simulated in {sim.wall:.1f} s of stepping; '
          f'planning {planning:.1f} s; whole run {time.perf_counter() - started:.0f} s')
    return 0


if __name__ == '__main__':
    sys.exit(main())
