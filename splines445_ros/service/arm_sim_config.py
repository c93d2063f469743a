"""Validated configuration of the simulated arm (pure Python, no rclpy)."""

from dataclasses import dataclass, replace
import math
from typing import Tuple

from .planner_config import check_payload, DEFAULT_JOINTS
from .validated_config import ValidatedConfig
from ..robot.model_drives import DEFAULT_BANDWIDTH, DEFAULT_DAMPING_RATIO
from ..robot.user_text import show
from ..sim.mujoco_model import PlanarArmModel

MIN_PUBLISH_RATE = 0.001
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


@dataclass(frozen=True)
class ArmSimConfig(ValidatedConfig):
    """Parameters of ``arm_sim_node``."""

    joint_names: Tuple[str, ...] = DEFAULT_JOINTS
    link_lengths: Tuple[float, ...] = (1.1, 0.9)
    initial_positions: Tuple[float, ...] = (0.0, 0.0, 0.0)
    publish_rate: float = 50.0
    frame_id: str = 'base_link'
    simulation: str = 'kinematic'
    model_file: str = ''
    tool_site: str = ''
    physics_rate: float = 1000.0
    gravity: bool = BUILT_IN.gravity
    link_masses: Tuple[float, ...] = BUILT_IN.link_masses
    rotor_inertia: Tuple[float, ...] = BUILT_IN.rotor_inertia
    joint_damping: Tuple[float, ...] = BUILT_IN.joint_damping
    joint_friction: Tuple[float, ...] = BUILT_IN.joint_friction
    joint_stiffness: Tuple[float, ...] = BUILT_IN.joint_stiffness
    spring_damping_ratio: float = BUILT_IN.spring_damping_ratio
    torque_limits: Tuple[float, ...] = (1000.0, 400.0, 30.0)
    actuator_time_constant: float = 0.002
    kp: Tuple[float, ...] = (90000.0, 16000.0, 1000.0)
    kd: Tuple[float, ...] = (4000.0, 700.0, 20.0)
    # model_file: the drives from the model (see nodes/arm_sim_model.py).
    tool_frame: str = ''
    control_bandwidth: float = DEFAULT_BANDWIDTH
    control_damping_ratio: float = DEFAULT_DAMPING_RATIO
    # dynamic: a payload held by the tool frame (see _validate_payload).
    payload_mass: float = 0.0
    payload_center_of_mass: Tuple[float, ...] = (0.0, 0.0, 0.0)
    payload_inertia: Tuple[float, ...] = ()

    # joint_names [''] (not set): every actuated joint of model_file, else the
    # built-in arm's joint1..3.
    PARAMETER_DEFAULTS = {'joint_names': ('',)}

    def with_defaults(self):
        """Return the config with joint_names resolved when not set and no model_file."""
        if not self.model_file and tuple(self.joint_names) in ((), ('',)):
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
        return bool(self.model_file) and tuple(self.joint_names) in ((), ('',))

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
        if len(self.initial_positions) != n or not _finite(self.initial_positions):
            raise ValueError(f'initial_positions must be {n} finite angles, got '
                             f'{show(self.initial_positions)}')
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

    def _validate_common(self):
        self.require_positive('link_lengths', 2)
        self.require_in_range('publish_rate', MIN_PUBLISH_RATE, MAX_PUBLISH_RATE, 'Hz')
        if self.simulation == 'dynamic' and self.publish_rate < MIN_DYNAMIC_PUBLISH_RATE:
            raise ValueError(f'publish_rate = {self.publish_rate}: the dynamic simulation '
                             'steps its physics at every publication, so it needs at least '
                             f'{MIN_DYNAMIC_PUBLISH_RATE:g} Hz')
        if self.simulation not in SIMULATIONS:
            raise ValueError(f'simulation must be one of {list(SIMULATIONS)}, got '
                             f'{show(self.simulation)}')
        self.require_in_range('physics_rate', MIN_PHYSICS_RATE, MAX_PHYSICS_RATE, 'Hz')
        if not isinstance(self.gravity, bool):
            raise ValueError(f'gravity must be true or false, got {show(self.gravity)}')
        self.require_in_range('actuator_time_constant', 0.0, MAX_TIME_CONSTANT, 's')
        self.require_in_range('control_bandwidth', 0.1, 200.0, 'Hz')
        self.require_in_range('control_damping_ratio', 0.05, 5.0)
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

    def _validate_model_file(self, n=None):
        """With model_file: per-joint arrays one per joint, or unset (from the model)."""
        if len(set(self.joint_names)) != len(self.joint_names):
            raise ValueError(f'joint_names has duplicates: {show(self.joint_names)}')
        self._validate_common()
        if not self.from_model('initial_positions'):
            if not _finite(self.initial_positions) or (
                    n is not None and len(self.initial_positions) != n):
                raise ValueError(f'initial_positions must be {n or "one per joint"} finite '
                                 f'angles, got {show(self.initial_positions)}')
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
        self.require_in_range('spring_damping_ratio', 0.0, 2.0)

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
