"""
Validated configuration of the simulated arm (pure Python, no rclpy).

:class:`ArmSimConfig`'s fields are arm_sim_node's parameter table (see
:mod:`.parameter_table`; ``doc/nodes.md`` is generated from them), its
``validate`` the per-joint and cross-field checks.
"""

from dataclasses import dataclass, replace
import math
from typing import Tuple

from .parameter_table import parameter
from .planner_config import (check_payload, DEFAULT_JOINTS, MAX_PAYLOAD_MASS,
                             MAX_PAYLOAD_OFFSET, NOT_SET_NAMES)
from .validated_config import ValidatedConfig
from ..robot.user_text import show
from ..sim.model_drives import DEFAULT_BANDWIDTH, DEFAULT_DAMPING_RATIO
from ..sim.mujoco_model import PlanarArmModel
from ..sim.playback import MAX_MAGNITUDE

MIN_PUBLISH_RATE = 0.001
# The built-in (planar) arm's base frame: its tool poses and the planner's planar ones.
PLANAR_FRAME = 'base_link'
# The dynamic arm steps its physics in the publishing timer: at least this rate.
MIN_DYNAMIC_PUBLISH_RATE = 1.0
MAX_PUBLISH_RATE = 1000.0
SIMULATIONS = ('kinematic', 'dynamic')
MIN_PHYSICS_RATE = 1000.0
MAX_PHYSICS_RATE = 20000.0
MAX_KP = 1e8
MAX_KD = 1e7
MAX_TIME_CONSTANT = 1.0
# A step of the explicit PD loop must not overshoot: kd * dt / inertia below this.
MAX_KD_STEP = 1.0
# MuJoCo integrates the joint springs explicitly: omega * dt below this.
MAX_SPRING_STEP = 1.0
BUILT_IN = PlanarArmModel()


def _finite(values, low=-math.inf, high=math.inf, low_open=False):
    return all(math.isfinite(v) and (v > low if low_open else v >= low) and v <= high
               for v in values)


PER_JOINT = 'one value per joint, in `joint_names` order'


def _from_model(source):
    return (f' With `model_file`, the built-in default or all zeros = {source}, and 0 entries '
            'likewise, joint by joint.')


@dataclass(frozen=True)
class ArmSimConfig(ValidatedConfig):
    """
    Parameters of ``arm_sim_node``.

    Each field is a row of the node's parameter table (see
    :mod:`.parameter_table`): its default, description, declared "not set"
    value and bounds or choices, checked by :meth:`check_table`; the
    per-joint arrays and cross-field checks are :meth:`validate`'s.
    """

    joint_names: Tuple[str, ...] = parameter(
        DEFAULT_JOINTS, 'Names of the joints: shoulder, elbow, tool of the built-in arm; the '
        "joints of `model_file` to drive otherwise (any number). Not set (`['']`, the "
        'default): `[joint1, joint2, joint3]` for the built-in arm, every actuated joint of '
        '`model_file` in its order.', declared=NOT_SET_NAMES)
    link_lengths: Tuple[float, ...] = parameter(
        (1.1, 0.9), "Lengths d1, d2 of the two links [m] (the paper's arm).")
    initial_positions: Tuple[float, ...] = parameter(
        (0.0, 0.0, 0.0), f'Joint angles at start-up [rad], {PER_JOINT}.'
        + _from_model("the model's keyframe `home`, or its reference pose"))
    publish_rate: float = parameter(
        50.0, 'Rate of `joint_states` and `tool_pose` [Hz]; at least '
        f'{MIN_DYNAMIC_PUBLISH_RATE:g} Hz with `simulation: dynamic` (the physics is stepped '
        'in the publishing timer).', low=MIN_PUBLISH_RATE, high=MAX_PUBLISH_RATE, unit='Hz')
    frame_id: str = parameter(
        '', 'Frame of `tool_pose`; empty (the default) = the frame its poses are in: the '
        f"built-in arm's `{PLANAR_FRAME}`, with `model_file` its URDF root link (MJCF: "
        '`world`), as TF and RViz know it.')
    simulation: str = parameter(
        'kinematic', '`kinematic` (exact playback of the commanded state) or `dynamic` '
        '(MuJoCo physics with a joint controller); `config/planar_arm.yaml` and the demo use '
        '`dynamic`.', choices=SIMULATIONS)
    model_file: str = parameter(
        '', 'Path of a URDF or MJCF file to simulate (dynamic) or play (kinematic) instead of '
        'the built-in planar arm; alone it drives every actuated joint and takes torque limits '
        'and gains from the model; empty = the built-in arm.')
    tool_site: str = parameter(
        '', 'dynamic: MJCF site whose pose is published on `tool_pose` (built-in arm: `tool` '
        'when empty; `model_file`: no `tool_pose` when empty).')
    physics_rate: float = parameter(
        1000.0, 'dynamic: physics and controller rate [Hz].',
        low=MIN_PHYSICS_RATE, high=MAX_PHYSICS_RATE, unit='Hz')
    gravity: bool = parameter(
        BUILT_IN.gravity, 'dynamic, built-in arm: gravity along −y (the arm moves in a '
        'vertical plane).')
    link_masses: Tuple[float, ...] = parameter(
        BUILT_IN.link_masses, 'dynamic, built-in arm: masses of link 1, link 2 (uniform rods) '
        'and the tool (a point mass 0.15 m beyond joint 3) [kg].')
    rotor_inertia: Tuple[float, ...] = parameter(
        BUILT_IN.rotor_inertia, 'dynamic, built-in arm: motor rotor inertia reflected through '
        'the gear [kg m²] per joint (MuJoCo armature).')
    joint_damping: Tuple[float, ...] = parameter(
        BUILT_IN.joint_damping, 'dynamic, built-in arm: viscous joint friction [N m s/rad] per '
        'joint.')
    joint_friction: Tuple[float, ...] = parameter(
        BUILT_IN.joint_friction, 'dynamic, built-in arm: dry joint friction [N m] per joint.')
    joint_stiffness: Tuple[float, ...] = parameter(
        BUILT_IN.joint_stiffness, 'dynamic, built-in arm: spring between motor and link '
        '[N m/rad] per joint; 0 = rigid joint.')
    spring_damping_ratio: float = parameter(
        BUILT_IN.spring_damping_ratio, 'dynamic, built-in arm: damping of the joint springs, '
        'as a fraction of critical (not checked with `model_file`).',
        low=0.0, high=2.0, only_if='built_in')
    torque_limits: Tuple[float, ...] = parameter(
        (1000.0, 400.0, 30.0), f'dynamic: actuator torque limit [N m], > 0, {PER_JOINT}.'
        + _from_model('from the model (actuator `forcerange`, `ctrlrange` × gear, URDF '
                      '`<limit effort>`)'))
    actuator_time_constant: float = parameter(
        0.002, 'dynamic: first-order lag of the applied torque behind the command [s]; 0 = '
        'none.', low=0.0, high=MAX_TIME_CONSTANT, unit='s')
    kp: Tuple[float, ...] = parameter(
        (90000.0, 16000.0, 1000.0), 'dynamic: position gain of the PD loop [N m/rad], in '
        f'[0, {MAX_KP:g}], {PER_JOINT}.'
        + _from_model('from the joint inertia and `control_bandwidth`'))
    kd: Tuple[float, ...] = parameter(
        (4000.0, 700.0, 20.0), 'dynamic: velocity gain of the PD loop [N m s/rad], in '
        f'[0, {MAX_KD:g}], {PER_JOINT}.'
        + _from_model('from the joint inertia and `control_bandwidth`'))
    # model_file: the drives from the model (see nodes/arm_sim_model.py).
    tool_frame: str = parameter(
        '', '`model_file`, dynamic: link, body or site whose pose is published on `tool_pose` '
        '(overrides `tool_site`). A `model_file` played with `simulation: kinematic` publishes '
        'no `tool_pose`. Refused without `model_file`, as are `control_bandwidth` and '
        '`control_damping_ratio` other than their defaults: the built-in arm would ignore them.')
    control_bandwidth: float = parameter(
        DEFAULT_BANDWIDTH, '`model_file`, dynamic: natural frequency [Hz] of the PD loop that '
        'sets `kp` and `kd` from the joint inertia at the initial pose when they are not '
        'given.', low=0.1, high=200.0, unit='Hz')
    control_damping_ratio: float = parameter(
        DEFAULT_DAMPING_RATIO, '`model_file`, dynamic: damping ratio of that loop (1 = '
        'critical).', low=0.05, high=5.0)
    # dynamic: a payload held by the tool frame (see _validate_payload).
    payload_mass: float = parameter(
        0.0, f'dynamic: mass [kg] rigidly held by the tool frame, 0 to {MAX_PAYLOAD_MASS:g}; 0 '
        '(the default) = none. The tool frame is `tool_frame` or `tool_site` (built-in arm: '
        'the `tool` site on joint 3); a model file without either is refused. Simulated and '
        'known to the controller; refused with `simulation: kinematic`, which plays the '
        'commanded state whatever the arm carries.')
    payload_center_of_mass: Tuple[float, ...] = parameter(
        (0.0, 0.0, 0.0), "dynamic: the payload's centre of mass [m], x, y, z in the tool "
        f'frame, each within ±{MAX_PAYLOAD_OFFSET:g} m.')
    payload_inertia: Tuple[float, ...] = parameter(
        (), "dynamic: the payload's inertia [kg m²] about its centre of mass in the tool "
        "frame's axes: empty (the default) = a point mass, 3 principal moments, or 6 values "
        '`[ixx, iyy, izz, ixy, ixz, iyz]`.')

    def with_defaults(self):
        """Return the config with joint_names resolved when not set and no model_file."""
        if not self.model_file and tuple(self.joint_names) in ((), NOT_SET_NAMES):
            return replace(self, joint_names=DEFAULT_JOINTS)
        return self

    def from_model(self, name):
        """
        Return True when the per-joint array ``name`` is to come from ``model_file``.

        With a model file, the built-in arm's default values and all zeros
        mean "not set": the model's own values are used (0 entries in an
        explicit array likewise, joint by joint).
        """
        values = getattr(self, name)
        return bool(self.model_file) and (
            tuple(values) == tuple(getattr(_DEFAULTS, name)) or not any(values))

    @property
    def all_model_joints(self):
        """Return True when joint_names [''] asks for all of the model's actuated joints."""
        return bool(self.model_file) and tuple(self.joint_names) in ((), NOT_SET_NAMES)

    @property
    def built_in(self):
        """Return True for the built-in planar arm (no model_file)."""
        return not self.model_file

    @property
    def dynamic(self):
        """Return True when MuJoCo simulates the arm."""
        return self.simulation == 'dynamic'

    @property
    def timestep(self):
        """Return the physics time step [s]."""
        return 1.0 / self.physics_rate

    def planar_model(self):
        """Return the built-in arm's physical parameters."""
        return PlanarArmModel(
            link_lengths=self.link_lengths, link_masses=self.link_masses,
            rotor_inertia=self.rotor_inertia, joint_damping=self.joint_damping,
            joint_friction=self.joint_friction, joint_stiffness=self.joint_stiffness,
            spring_damping_ratio=self.spring_damping_ratio, gravity=self.gravity)

    def validate(self):
        """Raise ValueError with the reason when any value is unusable."""
        self.check_table()      # a value outside its bounds is refused with them, first
        self._refuse_model_only()
        names = self.joint_names
        if self.all_model_joints:
            self._validate_model_file()
            return
        if any(not isinstance(n, str) or not n for n in names) or (
                not self.model_file and len(names) != 3) or not names:
            raise ValueError(f'joint_names must be 3 non-empty names (the planar arm has 3 '
                             f'joints; any number with model_file), got {show(names)}')
        if len(set(names)) != len(names):
            raise ValueError(f'joint_names has duplicates: {show(names)}')
        n = len(names)
        self.require_positive('link_lengths', 2)
        if self.model_file:
            self._validate_model_file(n)
            return
        self._check_initial_positions(n)
        self._validate_common()
        self._validate_built_in()
        per_joint = (('torque_limits', 0.0, math.inf, True, 'positive'),
                     ('kp', 0.0, MAX_KP, False, f'in [0, {MAX_KP:g}]'),
                     ('kd', 0.0, MAX_KD, False, f'in [0, {MAX_KD:g}]'))
        for name, low, high, low_open, words in per_joint:
            values = getattr(self, name)
            if len(values) != n or not _finite(values, low, high, low_open):
                raise ValueError(f'{name} must be {n} values (one per joint), each {words}, '
                                 f'got {show(values)}')
        self._validate_discretisation()

    def _refuse_model_only(self):
        """
        Refuse, without ``model_file``, the values only a model file uses (helper-65).

        The built-in arm would ignore them: ``config/ur5.yaml`` loaded without
        ``-p model_file:=...`` simulated the planar arm, silently.
        """
        if self.model_file:
            return
        if self.tool_frame:
            raise ValueError(f'tool_frame {show(self.tool_frame)} needs model_file: the '
                             "built-in arm's tool is its `tool` site (tool_site); set "
                             'model_file, or leave tool_frame empty')
        for name, default in (('control_bandwidth', DEFAULT_BANDWIDTH),
                              ('control_damping_ratio', DEFAULT_DAMPING_RATIO)):
            if getattr(self, name) != default:
                raise ValueError(f'{name} = {show(getattr(self, name))} needs model_file: '
                                 'the built-in arm has its own gains (kp, kd), and it would '
                                 'be ignored')

    def unused(self):
        """
        Values the current mode ignores (:meth:`ValidatedConfig.unused`).

        The kinematic arm plays the commanded state: every dynamic-only value
        (physics, gains, torques, the built-in arm's masses, ``tool_site`` and
        ``tool_frame``, whose pose only the physics publishes for a model
        file) is ignored; with ``model_file``, so are the built-in arm's
        links and physical values, and ``tool_site`` under a ``tool_frame``,
        which overrides it.
        """
        unused = self._unused_where(
            ('link_lengths', 'gravity', 'link_masses', 'rotor_inertia', 'joint_damping',
             'joint_friction', 'joint_stiffness', 'spring_damping_ratio'), self.model_file,
            "model_file is set: the built-in arm's values are not used")
        unused.update(self._unused_where(('tool_site',), bool(self.tool_frame),
                                         f'tool_frame {show(self.tool_frame)} overrides it'))
        unused.update(self._unused_where(
            ('tool_site', 'physics_rate', 'gravity', 'link_masses', 'rotor_inertia',
             'joint_damping', 'joint_friction', 'joint_stiffness', 'spring_damping_ratio',
             'torque_limits', 'actuator_time_constant', 'kp', 'kd', 'tool_frame',
             'control_bandwidth', 'control_damping_ratio'), not self.dynamic,
            'simulation is kinematic: it plays the commanded state, with no physics, '
            'controller or tool_pose of a model'))
        return unused

    def _validate_common(self):
        # The bounds and choices of the parameter table: publish_rate, simulation,
        # physics_rate, ..., control_damping_ratio (the fields, in order).
        self.check_table()
        self.require_positive('link_lengths', 2)
        if self.simulation == 'dynamic' and self.publish_rate < MIN_DYNAMIC_PUBLISH_RATE:
            raise ValueError(f'publish_rate = {self.publish_rate}: the dynamic simulation '
                             'steps its physics at every publication, so it needs at least '
                             f'{MIN_DYNAMIC_PUBLISH_RATE:g} Hz')
        if not isinstance(self.gravity, bool):
            raise ValueError(f'gravity must be true or false, got {show(self.gravity)}')
        self._validate_payload()

    def _validate_payload(self):
        """
        Refuse a payload that is not a rigid body, or that the arm would silently ignore.

        The dynamic arm carries it (merged into the body of the tool frame:
        ``tool_site`` or ``tool_frame``, checked when the model is built);
        the kinematic arm plays the commanded state, which no payload
        changes: a payload there is refused.
        """
        check_payload(self.payload_mass, self.payload_center_of_mass, self.payload_inertia)
        if self.has_payload() and not self.dynamic:
            raise ValueError('a payload (payload_mass, payload_center_of_mass, '
                             'payload_inertia) needs simulation "dynamic": the kinematic arm '
                             'plays the commanded state, which no payload changes (got '
                             f'simulation {show(self.simulation)})')

    def has_payload(self):
        """Return True when the arm carries a payload (its other values need a mass)."""
        return self.payload_mass > 0.0

    def _check_initial_positions(self, n=None):
        """Refuse initial_positions unless ``n`` (None: any number) finite, bounded angles."""
        if not _finite(self.initial_positions, -MAX_MAGNITUDE, MAX_MAGNITUDE) or (
                n is not None and len(self.initial_positions) != n):
            raise ValueError(f'initial_positions must be {n or "one per joint"} finite angles '
                             f'of magnitude at most {MAX_MAGNITUDE:g}, got '
                             f'{show(self.initial_positions)}')

    def _validate_model_file(self, n=None):
        """With model_file: per-joint arrays one per joint, or unset (from the model)."""
        if len(set(self.joint_names)) != len(self.joint_names):
            raise ValueError(f'joint_names has duplicates: {show(self.joint_names)}')
        self._validate_common()
        if not self.from_model('initial_positions'):
            self._check_initial_positions(n)
        per_joint = (('torque_limits', MAX_KP * MAX_KD, 'in [0, inf) (0 = from the model)'),
                     ('kp', MAX_KP, f'in [0, {MAX_KP:g}] (0 = from the model)'),
                     ('kd', MAX_KD, f'in [0, {MAX_KD:g}] (0 = from the model)'))
        for name, high, words in per_joint:
            values = getattr(self, name)
            if self.from_model(name):
                continue
            if (n is not None and len(values) != n) or not _finite(values, 0.0, high):
                raise ValueError(f'{name} must be {n or "one per joint"} values, each {words}, '
                                 f'got {show(values)}')

    def _validate_built_in(self):
        arrays = (('link_masses', 0.0, True, 'positive'),
                  ('rotor_inertia', 0.0, False, '>= 0'),
                  ('joint_damping', 0.0, False, '>= 0'),
                  ('joint_friction', 0.0, False, '>= 0'),
                  ('joint_stiffness', 0.0, False, '>= 0 (0 = rigid)'))
        for name, low, low_open, words in arrays:
            values = getattr(self, name)
            if len(values) != 3 or not _finite(values, low, low_open=low_open):
                raise ValueError(f'{name} must be 3 values (the built-in arm), each {words}, '
                                 f'got {show(values)}')
        for j, (k, rotor) in enumerate(zip(self.joint_stiffness, self.rotor_inertia)):
            if k > 0.0 and rotor <= 0.0:
                raise ValueError(f'joint {j + 1} is elastic (joint_stiffness > 0): its '
                                 f'rotor_inertia must be positive, got {rotor}')

    def _validate_discretisation(self):
        """Reject gains and springs the built-in arm's fixed-step physics cannot carry."""
        dt = self.timestep
        links = self.planar_model().link_inertias()
        for j in range(3):
            k, rotor = self.joint_stiffness[j], self.rotor_inertia[j]
            inertia = rotor if k > 0.0 else rotor + links[j]
            if self.kd[j] * dt > MAX_KD_STEP * inertia:
                raise ValueError(
                    f'kd[{j}] = {self.kd[j]:g} is too high for physics_rate '
                    f'{self.physics_rate:g} Hz: kd * dt must stay below the driven '
                    f'inertia {inertia:.3g} kg m^2 (raise physics_rate or lower kd)')
            if k > 0.0:
                omega = math.sqrt(k * (1.0 / rotor + 1.0 / links[j]))
                if omega * dt > MAX_SPRING_STEP:
                    raise ValueError(
                        f'joint_stiffness[{j}] = {k:g} is too stiff for physics_rate '
                        f'{self.physics_rate:g} Hz (spring frequency {omega:.0f} rad/s; '
                        f'omega * dt must stay below {MAX_SPRING_STEP:g}: raise '
                        f'physics_rate, rotor_inertia, or lower the stiffness)')


_DEFAULTS = ArmSimConfig()
