"""
The MuJoCo arm and its controller, without ROS, against hand-derived physics.

* A controller-free rollout of the built-in arm (links 2 and 3 nearly
  massless, arm hanging) swings with the period of a physical pendulum
  (rod plus rotor inertia): lengths, masses, centre of mass, gravity's
  direction and the armature all enter it.
* The controller's feed-forward (MuJoCo's inverse dynamics) equals the
  gravity torques and the tool joint's torque computed by hand.
* Elastic joints: the spring frequency of a held motor matches the stiffness.
* The step-log metrics, the vectorised playback and the model errors.
"""

import math

import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.service.arm_sim_config import ArmSimConfig
from splines445_ros.sim.dynamic_sim import DynamicArm, TrackingMetrics
from splines445_ros.sim.mujoco_model import (GRAVITY, load_arm_model, PlanarArmModel,
                                             stiffness_for_frequency, TOOL_OFFSET)
from splines445_ros.sim.playback import SampledTrajectory

mujoco = pytest.importorskip('mujoco')
JOINTS = ('joint1', 'joint2', 'joint3')


def build(model, limits=(1e4, 1e4, 1e4), lag=0.0, timestep=0.001, kp=(0, 0, 0), kd=(0, 0, 0)):
    arm_model = load_arm_model(JOINTS, limits, lag, timestep, planar=model)
    return DynamicArm(arm_model, kp, kd, limits)


def zero_crossings(t, x):
    """Return the times where x crosses zero upwards (linear interpolation)."""
    k = np.nonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))[0]
    return t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])


def test_free_swing_has_the_period_of_a_physical_pendulum():
    m1, d1, rotor = 20.0, 1.1, 0.5
    model = PlanarArmModel(link_masses=(m1, 1e-3, 1e-3), rotor_inertia=(rotor, 0.0, 0.0),
                           joint_damping=(0.0,) * 3, joint_friction=(0.0,) * 3)
    arm = build(model)
    m, d = arm.model, arm.data
    amplitude = 0.03
    hanging = -0.5 * math.pi  # gravity is along -y
    d.qpos[:] = [hanging + amplitude, 0.0, 0.0]
    times, angles = [], []
    for k in range(4000):  # no controller: ctrl stays 0, MuJoCo alone moves the arm
        mujoco.mj_step(m, d)
        times.append((k + 1) * m.opt.timestep)
        angles.append(d.qpos[0] - hanging)
    crossings = zero_crossings(np.array(times), np.array(angles))
    period = np.mean(np.diff(crossings))
    inertia = m1 * d1 ** 2 / 3.0 + rotor  # rod about its end plus the rotor
    expected = 2.0 * math.pi * math.sqrt(inertia / (m1 * GRAVITY * 0.5 * d1))
    expected *= 1.0 + amplitude ** 2 / 16.0  # finite amplitude
    assert len(crossings) >= 2
    assert period == pytest.approx(expected, rel=2e-3)


def test_gravity_off_keeps_the_arm_still():
    arm = build(PlanarArmModel(gravity=False))
    arm.data.qpos[:] = [0.3, 0.5, 0.2]
    for _ in range(200):
        mujoco.mj_step(arm.model, arm.data)
    np.testing.assert_allclose(arm.data.qpos, [0.3, 0.5, 0.2], atol=1e-12)


def hand_gravity(model, q):
    """Gravity torques (3,) of the planar arm, derived by hand (potential m g y)."""
    (d1, d2), (m1, m2, m3) = model.link_lengths, model.link_masses
    c1, c12, c123 = math.cos(q[0]), math.cos(q[0] + q[1]), math.cos(q[0] + q[1] + q[2])
    r = TOOL_OFFSET
    g3 = m3 * r * c123
    g2 = m2 * 0.5 * d2 * c12 + m3 * (d2 * c12 + r * c123)
    g1 = m1 * 0.5 * d1 * c1 + m2 * (d1 * c1 + 0.5 * d2 * c12) + m3 * (
        d1 * c1 + d2 * c12 + r * c123)
    return GRAVITY * np.array([g1, g2, g3])


@pytest.mark.parametrize('q', [[0.0, 0.0, 0.0], [0.4, 1.2, -0.7], [-1.0, 2.0, 0.5]])
def test_feedforward_holds_against_gravity(q):
    model = PlanarArmModel()
    arm = build(model)
    tau = arm.feedforward(np.array(q), np.zeros(3), np.zeros(3))
    np.testing.assert_allclose(tau, hand_gravity(model, q), rtol=1e-9, atol=1e-9)


def test_feedforward_of_the_tool_joint():
    model = PlanarArmModel()
    arm = build(model)
    q = np.array([0.3, 0.9, -0.4])
    v3, a3 = 1.3, -4.0
    tau = arm.feedforward(q, np.array([0.0, 0.0, v3]), np.array([0.0, 0.0, a3]))
    m3, r = model.link_masses[2], TOOL_OFFSET
    # Links 1 and 2 at rest: the tool is a point mass (MJCF: 1e-6 kg m^2 of its own)
    # swinging about joint 3, plus the rotor.
    inertia = m3 * r ** 2 + 1e-6 + model.rotor_inertia[2]
    expected = (inertia * a3 + model.joint_damping[2] * v3
                + m3 * GRAVITY * r * math.cos(q.sum()))
    assert tau[2] == pytest.approx(expected, rel=1e-9)


def test_elastic_joint_rings_at_the_frequency_of_its_stiffness():
    frequency = 8.0
    base = PlanarArmModel(link_masses=(20.0, 1e-3, 1e-3), joint_damping=(0.0,) * 3,
                          joint_friction=(0.0,) * 3, gravity=False)
    stiffness = stiffness_for_frequency(base, frequency)
    model = PlanarArmModel(**{**base.__dict__, 'joint_stiffness': stiffness,
                              'spring_damping_ratio': 0.0})
    arm = build(model)
    m, d, motor = arm.model, arm.data, arm.arm.motor_qpos[0]
    d.qpos[arm.arm.qpos[0]] = 0.01  # link deflected, motor held at 0 below
    t, x = [], []
    for k in range(1000):
        d.qpos[motor] = 0.0
        d.qvel[arm.arm.motor_dof[0]] = 0.0
        mujoco.mj_step(m, d)
        t.append(k * m.opt.timestep)
        x.append(d.qpos[arm.arm.qpos[0]])
    period = np.mean(np.diff(zero_crossings(np.array(t), np.array(x))))
    assert 1.0 / period == pytest.approx(frequency, rel=0.02)


def test_slow_trajectory_is_tracked_and_the_arm_settles():
    """
    With the node's defaults, a slow move is tracked to within the friction dead band.

    The feed-forward does not compensate dry friction, so the PD loop must
    build friction / kp of error before the joint moves: 10/90000, 4/16000
    and 0.2/1000 rad.  The tolerance is twice the largest (0.5 mrad); the
    arm must also settle at the goal within it.
    """
    config = ArmSimConfig()
    model = load_arm_model(JOINTS, config.torque_limits, config.actuator_time_constant,
                           config.timestep, planar=config.planar_model())
    arm = DynamicArm(model, config.kp, config.kd, config.torque_limits)
    deadband = np.array(config.joint_friction) / np.array(config.kp)
    traj = plan(np.array([[0.0, 0.5, 0.0], [0.3, 0.9, -0.3], [0.5, 0.6, 0.2]]), '445',
                'uniform', max_velocity=[0.3] * 3, max_acceleration=[1.0] * 3)
    t = np.arange(0.0, traj.duration + 0.5, config.timestep)
    clamped = np.minimum(t, traj.duration)
    q, v, a = (traj.evaluate(clamped, k) for k in range(3))
    v[t > traj.duration] = 0.0
    a[t > traj.duration] = 0.0
    arm.reset(q[0])
    log = arm.run(q, v, a)
    tolerance = 2.0 * deadband.max()
    assert np.abs(q - log['position']).max() < tolerance
    np.testing.assert_allclose(arm.positions(), q[-1], atol=tolerance)
    assert not log['saturated'].any()
    assert np.all(np.isfinite(log['effort']))
    # Without the feed-forward (gains only) the same move is tracked far worse.
    assert np.abs(log['effort']).max() > 50.0


def test_metrics_of_a_known_log():
    metrics = TrackingMetrics(2, 0.01)
    K = 5
    q_d = np.zeros((K, 2))
    position = np.tile([0.1, -0.2], (K, 1))
    effort = np.column_stack([np.arange(K) * 2.0, np.full(K, -3.0)])  # 200 N m/s on joint 1
    command = np.column_stack([np.array([0.0, 0.0, 1.0, 2.0, 3.0]), np.zeros(K)])
    log = {'position': position, 'effort': effort, 'command': command,
           'saturated': np.array([False, True, False, False, False])}
    metrics.update(q_d[:2], {k: v[:2] for k, v in log.items()})
    metrics.update(q_d[2:], {k: v[2:] for k, v in log.items()})  # across a chunk border
    summary = metrics.summary()
    np.testing.assert_allclose(summary['tracking_rms_error'], [0.1, 0.2])
    np.testing.assert_allclose(summary['tracking_max_error'], [0.1, 0.2])
    np.testing.assert_allclose(summary['peak_effort'], [8.0, 3.0])
    np.testing.assert_allclose(summary['peak_effort_rate'], [200.0, 0.0])
    # Command rate 0, 100, 100, 100 N m/s: one jump of 100 at the kink.
    np.testing.assert_allclose(summary['max_command_rate_jump'], [100.0, 0.0])
    assert summary['saturated_steps'] == 1


def test_metrics_follow_a_physics_step_change():
    # Effort ramps at 200 N m/s for 3 steps of 10 ms, then for 4 steps of 1 ms
    # (the physics rate changed mid-trajectory): the peak rate stays 200.
    metrics = TrackingMetrics(1, 0.01)
    times = np.concatenate([0.01 * np.arange(3), 0.02 + 0.001 * np.arange(1, 5)])
    effort = 200.0 * times[:, None]
    log = {'position': np.zeros((7, 1)), 'effort': effort, 'command': effort,
           'saturated': np.zeros(7, dtype=bool)}
    metrics.update(np.zeros((3, 1)), {k: v[:3] for k, v in log.items()})
    metrics.update(np.zeros((4, 1)), {k: v[3:] for k, v in log.items()}, timestep=0.001)
    summary = metrics.summary()
    np.testing.assert_allclose(summary['peak_effort_rate'], [200.0])
    np.testing.assert_allclose(summary['max_command_rate_jump'], [0.0], atol=1e-9)


def test_vectorised_playback_matches_the_scalar_one():
    rng = np.random.default_rng(3)
    times = np.cumsum(rng.uniform(0.05, 0.2, 8))
    for velocities, accelerations in ((False, False), (True, False), (True, True)):
        traj = SampledTrajectory(times, rng.normal(size=(8, 3)),
                                 rng.normal(size=(8, 3)) if velocities else None,
                                 rng.normal(size=(8, 3)) if accelerations else None)
        t = np.concatenate([[0.0], rng.uniform(0.0, times[-1], 40)])
        p, v, a = traj.states_at(t)
        for k, tk in enumerate(t):
            expected = traj.state_at(tk)
            for got, want in zip((p[k], v[k], a[k]), expected):
                np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
        p, v, a = traj.states_at([times[-1], times[-1] + 1.0])
        np.testing.assert_array_equal(p, [traj.positions[-1]] * 2)
        np.testing.assert_array_equal(v, 0.0)


def test_model_errors_say_what_is_wrong(tmp_path):
    bad_xml = tmp_path / 'bad.xml'
    bad_xml.write_text('<mujoco><worldbody><body><joint name="a"/></worldbody></mujoco>')
    other = tmp_path / 'other.xml'
    other.write_text('<mujoco><worldbody><body><joint name="hip" type="hinge"/>'
                     '<geom size="0.1" mass="1"/></body></worldbody></mujoco>')
    limits = (1.0, 1.0, 1.0)
    cases = [(str(tmp_path / 'missing.xml'), '', 'no such file'),
             (str(bad_xml), '', 'is not well-formed XML'),
             (str(other), '', "no joint(s) ['joint1', 'joint2', 'joint3']"),
             ('', 'nowhere', "no site 'nowhere'")]
    for path, site, reason in cases:
        with pytest.raises(ValueError, match=None) as error:
            load_arm_model(JOINTS, limits, 0.0, 0.001, model_file=path, tool_site=site)
        assert reason in str(error.value), (path, str(error.value))
