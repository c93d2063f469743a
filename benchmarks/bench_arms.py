"""
Every 6- and 7-joint arm of example-robot-data that MuJoCo loads (issue 38): the bench arms.

:func:`vendor_arms` walks every URDF below the PyPI package's ``robots``
folder (:mod:`splines445_ros.tools.vendor_robots` finds it), loads each
with :func:`~splines445_ros.robot.robot_model.load_robot_model` (the
project's MuJoCo import, as the nodes load a ``model_file``) and keeps an
arm when

* its actuated joints, less those of a gripper (names with ``finger``,
  ``gripper`` or ``jaw``), are 6 or 7 hinges on one chain from the world
  (:func:`~splines445_ros.robot.chain_tip.chain_tips` finds its tip: two
  arms, legs or a torso and a head are not one chain);
* every one has a URDF velocity and effort limit;
* it is not a variant already kept: same joints, same tool position at
  zero, same velocity and effort limits (``ur5_joint_limited_robot`` and
  ``ur5_gripper`` are the ``ur5_robot``'s arm, with other ranges or a
  gripper's links).  Files without ``limited``, ``gripper`` or
  ``collision`` in the name are looked at first.

Everything else is skipped with the reason; :func:`print_arms` prints both
lists.  Per arm: the tool frame (:data:`KNOWN`'s, else ``tool0`` where there
is one, else the chain's tip; among several, the first with ``tcp``,
``eef`` or ``end_effector`` in its name; the TALOS arm's tips are its
fingertips, so its tool is the gripper's base), the base frame (the model's root body),
a ready pose (the UR5's and the Panda's usual ones, see
``vendor_robots``; for the others the most dexterous of a fixed sample of
configurations: the largest smallest singular value of the tool Jacobian,
positions over the chain's reach, at least :data:`READY_MARGIN` from every
joint limit), joint velocity and effort from the URDF, acceleration and
jerk from the shipped ``config/<arm>_joint_limits.yaml`` where there is one
(UR5, Panda), else :data:`ACCELERATION_PER_VELOCITY` times the velocity
and :data:`JERK_PER_ACCELERATION` times that (the UR5 file's ratios:
4-8 rad/s^2 at 3.15 rad/s, jerk 10 a), and the vendor's rated payload.
"""

from dataclasses import dataclass, field
import glob
import importlib.metadata
import logging
import math
import os
import re
from typing import Optional
import zlib

import bench_seeds
import numpy as np
from splines445_ros.robot.chain_tip import chain_tips
from splines445_ros.robot.inverse_kinematics import ModelKinematics
from splines445_ros.robot.joint_limits_file import read_joint_limits_file, resolve_limits
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.tools import robot_seam_demo as rsd
from splines445_ros.tools import vendor_robots as vr

GRIPPER = re.compile(r'finger|gripper|jaw', re.IGNORECASE)
ARM_JOINTS = (6, 7)
VARIANT = re.compile(r'limited|gripper|collision')
ACCELERATION_PER_VELOCITY = 2.0     # [1/s] a = this * v where no limits file says
JERK_PER_ACCELERATION = 10.0        # [1/s] j = this * a where no limits file says
READY_SAMPLES = 4000                # configurations tried for a ready pose
READY_MARGIN = 0.3                  # [rad] a ready pose keeps this from every joint limit
READY_SEARCH_SEED = 0               # the ready search is the same every run: not a case
JACOBIAN_STEP = 1e-6                # [rad] finite differences of the tool pose
# Names and what is known of each arm by its file below robots/: (name, ready pose or None,
# tool frame or None, limits file stem or None, rated payload [kg] (the vendor's datasheet)).
KNOWN = {
    'ur_description/urdf/ur3_robot.urdf': ('UR3', vr.UR5_READY, 'tool0', None, 3.0),
    'ur_description/urdf/ur5_robot.urdf': ('UR5', vr.UR5_READY, 'tool0', 'ur5', 5.0),
    'ur_description/urdf/ur10_robot.urdf': ('UR10', vr.UR5_READY, 'tool0', None, 10.0),
    'panda_description/urdf/panda.urdf': ('Panda', vr.PANDA_READY, 'panda_hand_tcp', 'panda',
                                          3.0),
    'xarm_description/urdf/xarm7.urdf': ('xArm7', None, None, None, 3.5),
    'z1_description/urdf/z1.urdf': ('Z1', None, None, None, 2.0),
    'kinova_description/robots/kinova.urdf': ('Kinova j2s6s200', None, None, None, 1.6),
    'talos_data/robots/talos_left_arm.urdf': ('TALOS left arm', None,
                                              'gripper_left_base_link', None, 6.0),
}
DEFAULT_PAYLOAD = 1.0               # [kg] an arm not in KNOWN
TOOL_WORDS = ('tcp', 'eef', 'end_effector')
FINGERPRINT_DIGITS = 2              # [m] tool positions this close are one arm (UR3s: 0.4 mm)


@dataclass
class Arm:
    """One bench arm: its model, kinematics and limits."""

    name: str
    file: str                       # below example-robot-data's robots/
    robot: object                   # RobotModel
    joints: tuple                   # the planned (arm) joints' names
    tool: str
    base: str
    ready: np.ndarray
    velocity: np.ndarray            # (n,) [rad/s], URDF
    effort: np.ndarray              # (n,) [N m], URDF
    acceleration: np.ndarray        # (n,) [rad/s^2]
    jerk: np.ndarray                # (n,) [rad/s^3]
    limits_source: str
    rated_payload: float            # [kg]
    left_out: tuple = field(default=())     # gripper joints not planned
    notes: Optional[str] = None

    @property
    def stream(self):
        """Return the arm's stream of the run's seed (``bench_seeds.generator``): its CRC."""
        return zlib.crc32(self.name.encode())

    def kinematics(self):
        """Return a fresh ModelKinematics of the tool (no IK walk remembered)."""
        return ModelKinematics(self.robot, self.tool, self.base, self.joints, seed=self.ready)

    def plan_limits(self):
        """Return the v/a/j keyword arguments of plan() and plan_tool_path()."""
        return {'max_velocity': self.velocity, 'max_acceleration': self.acceleration,
                'max_jerk': self.jerk}


def robots_folder():
    """Return the absolute path of example-robot-data's ``robots`` folder."""
    return str(importlib.metadata.distribution(vr.DISTRIBUTION).locate_file(vr.ROBOTS_FOLDER))


def _candidates(folder):
    """Every URDF below ``folder``, relative, plain files before their variants."""
    files = [os.path.relpath(p, folder)
             for p in glob.glob(os.path.join(folder, '**', '*.urdf'), recursive=True)]
    return sorted(files, key=lambda f: (bool(VARIANT.search(os.path.basename(f))), f))


def _choose_tool(tips, wanted):
    if wanted:
        return wanted
    if 'tool0' in tips:
        return 'tool0'
    if len(tips) == 1:
        return tips[0]
    for word in TOOL_WORDS:
        named = [t for t in tips if word in t.lower()]
        if named:
            return named[0]
    return tips[0]


def _root_body(robot):
    mj, m = robot.mujoco, robot.model
    for b in range(1, m.nbody):
        if int(m.body_parentid[b]) == 0:
            return mj.mj_id2name(m, mj.mjtObj.mjOBJ_BODY, b) or ''
    return ''


def tool_jacobians(kin, q, step=JACOBIAN_STEP):
    """Return the tool Jacobians (K, 6, n) at joints ``q`` (K, n): position, then rotation."""
    q = np.atleast_2d(q)
    k, n = q.shape
    shifted = np.repeat(q[:, None, :], n + 1, axis=1)
    shifted[:, 1:, :] += step * np.eye(n)
    pos, mat = kin.forward_transform(shifted.reshape(-1, n))
    pos, mat = pos.reshape(k, n + 1, 3), mat.reshape(k, n + 1, 3, 3)
    dp = (pos[:, 1:] - pos[:, :1]) / step
    # Rotation: the skew part of R0^T R_i, over the step (a rotation vector rate).
    rel = np.swapaxes(mat[:, :1], -1, -2) @ mat[:, 1:]
    dr = 0.5 * np.stack([rel[..., 2, 1] - rel[..., 1, 2], rel[..., 0, 2] - rel[..., 2, 0],
                         rel[..., 1, 0] - rel[..., 0, 1]], axis=-1) / step
    return np.concatenate([dp, dr], axis=-1).transpose(0, 2, 1)


def dexterity(kin, q):
    """Smallest singular value of the tool Jacobian, positions over the reach, at ``q`` (K,)."""
    jac = tool_jacobians(kin, q)
    jac[:, :3, :] /= max(kin.tool.reach()[1], 1e-3)
    return np.linalg.svd(jac, compute_uv=False)[:, -1]


def dexterous_pose(kin, samples=READY_SAMPLES, margin=READY_MARGIN):
    """Return the most dexterous of a fixed sample of configurations inside the ranges."""
    lower = np.where(np.isfinite(kin.lower), kin.lower, -math.pi) + margin
    upper = np.where(np.isfinite(kin.upper), kin.upper, math.pi) - margin
    lower, upper = np.minimum(lower, upper), np.maximum(lower, upper)
    rng = np.random.default_rng(READY_SEARCH_SEED)
    q = rng.uniform(lower, upper, (samples, len(lower)))
    return q[int(np.argmax(dexterity(kin, q)))]


def _fingerprint(robot, arm_infos, tool):
    chain = robot.frame_chain(tool, tuple(j.name for j in arm_infos))
    pos, _ = chain.transform(np.zeros(len(arm_infos)))
    return (tuple(j.name for j in arm_infos), tuple(np.round(pos, FINGERPRINT_DIGITS)),
            tuple((j.velocity, j.effort) for j in arm_infos))


def _limits(key, names, velocity):
    """(acceleration, jerk, source) of the arm: its shipped limits file, else the ratios."""
    if key:
        limits = resolve_limits(names, dict(zip(names, velocity)),
                                read_joint_limits_file(rsd.limits_file(key)))
        return (np.asarray(limits.acceleration, float), np.asarray(limits.jerk_limits(), float),
                f'config/{key}_joint_limits.yaml')
    acceleration = ACCELERATION_PER_VELOCITY * velocity
    return (acceleration, JERK_PER_ACCELERATION * acceleration,
            f'a = {ACCELERATION_PER_VELOCITY:g} v, j = {JERK_PER_ACCELERATION:g} a')


def _arm(folder, relative, kept):
    """Return (Arm or None, reason it is skipped)."""
    known = KNOWN.get(relative)
    try:
        robot = load_robot_model(os.path.join(folder, relative))
    except Exception as exc:  # noqa: B902 - any load failure is a reason to skip
        return None, f'not loaded: {str(exc).splitlines()[0][-120:]}'
    infos = [robot.joint(n) for n in robot.joint_names]
    left_out = tuple(j.name for j in infos if GRIPPER.search(j.name))
    arm = [j for j in infos if j.name not in left_out]
    if len(arm) not in ARM_JOINTS:
        return None, (f'{len(arm)} actuated joints' + (f' besides the gripper {left_out}'
                                                       if left_out else ''))
    if any(j.kind != 'hinge' for j in arm):
        return None, 'a prismatic joint in the arm'
    tips, reason = chain_tips(robot, arm)
    if not tips:
        return None, reason
    missing = [j.name for j in arm if not j.velocity or not j.effort]
    if missing:
        return None, f'no URDF velocity or effort limit on {missing}'
    tool = _choose_tool(tips, known[2] if known else None)
    fingerprint = _fingerprint(robot, arm, tool)
    if fingerprint in kept:
        return None, f'the same arm as {kept[fingerprint]}'
    names = tuple(j.name for j in arm)
    name = known[0] if known else os.path.splitext(os.path.basename(relative))[0]
    velocity = np.array([j.velocity for j in arm], float)
    effort = np.array([j.effort for j in arm], float)
    acceleration, jerk, source = _limits(known[3] if known else None, names, velocity)
    base = _root_body(robot)
    kin = ModelKinematics(robot, tool, base, names)
    if known and known[1] is not None:
        ready, notes = np.array(known[1], float), 'ready: the usual pose'
    else:
        ready = dexterous_pose(kin)
        notes = 'ready: the most dexterous sampled pose'
    kept[fingerprint] = relative
    return Arm(name, relative, robot, names, tool, base, ready, velocity, effort, acceleration,
               jerk, source, known[4] if known else DEFAULT_PAYLOAD, left_out, notes), ''


def vendor_arms(only=None):
    """
    Return (arms, skipped): the bench arms, and (file, reason) for every other URDF.

    ``only``: a comma-separated list of arm names to keep (the environment
    variable ``SPLINES445_BENCH_ARMS`` when None; all when empty); the
    others are listed as skipped ("not asked for").
    """
    if only is None:
        only = os.environ.get('SPLINES445_BENCH_ARMS', '')
    wanted = {w.strip().lower() for w in only.split(',') if w.strip()}
    folder = robots_folder()
    quiet = logging.getLogger().manager.disable
    logging.disable(logging.WARNING)    # the humanoids' import notes are not the bench's
    import mujoco
    warn = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(lambda text: None)  # nor MuJoCo's (it would write a log file)
    try:
        arms, skipped, kept = [], [], {}
        for relative in _candidates(folder):
            arm, reason = _arm(folder, relative, kept)
            if arm is None:
                skipped.append((relative, reason))
            elif wanted and arm.name.lower() not in wanted:
                skipped.append((relative, f'{arm.name}: not asked for (SPLINES445_BENCH_ARMS)'))
            else:
                arms.append(arm)
    finally:
        logging.disable(quiet)
        mujoco.set_mju_user_warning(warn)
    return arms, skipped


def start_run(default_cases):
    """
    Begin an arm bench: quiet toppra, draw the run's seed, load and print the arms.

    Returns (seed, cases, arms): ``bench_seeds.run_seed()``, the case count
    (``bench_seeds.case_count(default_cases)``) and :func:`vendor_arms`'.
    """
    logging.getLogger('toppra').setLevel(logging.ERROR)
    seed = bench_seeds.run_seed()
    cases = bench_seeds.case_count(default_cases)
    arms, skipped = vendor_arms()
    print_arms(arms, skipped)
    return seed, cases, arms


def print_arms(arms, skipped):
    """Print the arms kept (one line each) and the files skipped with their reasons."""
    names = ', '.join(a.name for a in arms)
    print(f'Arms: every 6-7-joint arm of example-robot-data {_version()} (benchmarks/'
          f'bench_arms.py): {names}')
    for a in arms:
        grip = f'; gripper joints not planned: {list(a.left_out)}' if a.left_out else ''
        print(f'  {a.name}: {a.file}, {len(a.joints)} joints, tool {a.tool}, base {a.base}, '
              f'{a.notes} {np.round(a.ready, 3).tolist()}, v/effort from the URDF, a/j: '
              f'{a.limits_source}, rated payload {a.rated_payload:g} kg{grip}')
    print(f'  skipped ({len(skipped)}): '
          + '; '.join(f'{os.path.basename(f)}: {why}' for f, why in skipped))


def _version():
    try:
        return importlib.metadata.version(vr.DISTRIBUTION)
    except importlib.metadata.PackageNotFoundError:
        return '(not installed)'
