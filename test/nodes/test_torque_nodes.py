"""
Torque limits and a payload through both nodes (issue 25), in process, on the UR5.

* planner_node with ``limit_torque``: the torques of the published
  trajectory, computed here at 1 kHz by :class:`ArmDynamics` with the same
  payload, stay within the URDF's ``<limit effort>``; tool requests are
  refined and hold them too; a heavier payload plans slower.
* Bad torque and payload parameters are refused with the reason; a pose
  where gravity alone exceeds a limit is an ERROR naming the joint, and the
  node keeps serving.
* arm_sim_node carries the same payload: a plan limited to 80 % of the
  efforts plays without saturating, and the held torque is the payload's.
"""

import math
import re

from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Pose, PoseArray
from node_status import assert_planned
import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from scipy.spatial.transform import Rotation
from splines445_ros.nodes import topics
from splines445_ros.nodes.arm_sim_node import ArmSimNode
from splines445_ros.nodes.diagnostics import status_values
from splines445_ros.nodes.planner_node import PlannerNode
from splines445_ros.robot.dynamics import ArmDynamics
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.tools import vendor_robots as vr
from splines445_ros.tools.in_process import InProcessSystem, LocalRos, overrides, waypoint_message
from trajectory_msgs.msg import JointTrajectory
from urdf_reference import BatchedUrdfChain

EFFORT = np.array([150.0] * 3 + [28.0] * 3)  # the UR5 URDF's <limit effort>
# The share of it a plan uses by default (torque_headroom 0.1, doc/nodes.md).
SHARE = 0.9
READY = np.array(vr.UR5_READY)
GOAL = READY + [2.0, 0.3, -0.3, 0.0, 0.0, 0.0]
PAYLOAD = {'payload_mass': 10.0, 'payload_center_of_mass': [0.0, 0.0, 0.05],
           'payload_inertia': [0.05, 0.05, 0.02]}
# 8 rad/s instead of the URDF's 3.15, and no acceleration limit (the stand-in):
# the torque, not the velocity, sets the time of these moves.
PLANNER = {'kinematics': 'model', 'model_file': vr.ur5_urdf(), 'tool_frame': 'tool0',
           'base_frame': 'base_link', 'limit_torque': True, 'max_velocity': [8.0] * 6,
           'method': '555', 'timing': 'optimal', 'sample_period': 0.001,
           'max_path_deviation': 1e-3,
           # On time at the MuJoCo arm: one that arrives after its stamp starts part-way.
           'start_delay': 1.0}


def points(msg):
    """Return the positions, velocities and accelerations (K, n) of a trajectory message."""
    return tuple(np.array([getattr(p, name) for p in msg.points])
                 for name in ('positions', 'velocities', 'accelerations'))


def duration(msg):
    """Return the time_from_start of the last point [s]."""
    last = msg.points[-1].time_from_start
    return last.sec + 1e-9 * last.nanosec


def torque_ratios(msg, payload):
    """Return per joint the peak |torque| / planned limit of a 1 kHz trajectory message."""
    dynamics = ArmDynamics(load_robot_model(vr.ur5_urdf()), vr.UR5_JOINTS, 'tool0',
                           payload['payload_mass'], payload['payload_center_of_mass'],
                           payload['payload_inertia'] or None)
    return np.max(np.abs(dynamics.torques(*points(msg))), axis=0) / (SHARE * EFFORT)


def numbers(text):
    """Return a comma-separated status value as floats."""
    return np.array([float(v) for v in text.split(',')])


def tool_poses(q_start, offset):
    """Return a PoseArray from tool0 at ``q_start`` to ``offset`` [m] from it, same attitude."""
    fk = BatchedUrdfChain(vr.ur5_urdf(), 'base_link', 'tool0', list(vr.UR5_JOINTS))
    position, matrix = fk(np.array([q_start]))
    qx, qy, qz, qw = Rotation.from_matrix(matrix[0]).as_quat()
    msg = PoseArray()
    msg.header.frame_id = 'base_link'
    for point in (position[0], position[0] + offset):
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = (float(v) for v in point)
        pose.orientation.w, pose.orientation.x = float(qw), float(qx)
        pose.orientation.y, pose.orientation.z = float(qy), float(qz)
        msg.poses.append(pose)
    return msg


class Planner(LocalRos):
    """A planner_node alone and a client, in a namespace of their own (no arm hears it)."""

    def __init__(self, parameters, namespace='torque'):
        super().__init__()
        try:
            self.node = self.add(PlannerNode(context=self.context, namespace=namespace,
                                             parameter_overrides=overrides(parameters)))
            self.client = self.add(Node('torque_client', namespace=namespace,
                                        context=self.context))
            self.waypoints = self.client.create_publisher(JointTrajectory, topics.WAYPOINTS,
                                                          topics.REQUEST_QOS)
            self.status, self.trajectories = [], []
            self.client.create_subscription(DiagnosticStatus, 'planner_node/status',
                                            self.status.append, topics.STATUS_QOS)
            self.client.create_subscription(JointTrajectory, topics.JOINT_TRAJECTORY,
                                            self.trajectories.append, topics.LATCHED)
            assert self.spin_until(lambda: self.waypoints.get_subscription_count() >= 1
                                   and self.status, 10.0)
        except BaseException:
            self.close()
            raise

    def request(self, waypoints, **boundary):
        first, n_traj = len(self.status), len(self.trajectories)
        self.waypoints.publish(waypoint_message(vr.UR5_JOINTS, waypoints, **boundary))
        assert self.spin_until(lambda: any('request' in status_values(s)
                                           for s in self.status[first:]), 30.0)
        status = next(s for s in self.status[first:] if 'request' in status_values(s))
        if status.level == DiagnosticStatus.ERROR:
            return status, None
        assert self.spin_until(lambda: len(self.trajectories) > n_traj, 10.0)
        return status, self.trajectories[-1]

    def configure(self, values):
        return self.node.set_parameters_atomically(overrides(values))


@pytest.fixture(scope='module')
def planner():
    with Planner(PLANNER) as node:
        yield node


@pytest.fixture(scope='module')
def system():
    arm = {'simulation': 'dynamic', 'model_file': vr.ur5_urdf(), 'tool_frame': 'tool0',
           'initial_positions': list(vr.UR5_READY), **PAYLOAD}
    with InProcessSystem({**PLANNER, **PAYLOAD}, arm) as running:
        yield running


def test_the_plan_holds_the_urdf_efforts_with_the_payload(system):
    def loaded():
        return next((s for s in system.planner_status if 'robot' in status_values(s)), None)
    assert system.spin_until(lambda: loaded() is not None, 10.0)
    loaded = loaded()
    values = status_values(loaded)
    assert 'shoulder_pan_joint=150 (effort)' in values['limit_torque_sources']
    assert values['payload'] == '10 kg at [0, 0, 0.05] m in tool0'
    # No acceleration limit anywhere: the stand-in, named as such.
    assert 'elbow_joint=1000 (limit_torque)' in values['limit_acceleration_sources']
    n_arm = len(system.arm_status)
    status, msg = system.request(waypoint_message(vr.UR5_JOINTS, [READY, GOAL]))
    assert_planned(status)
    values = status_values(status)
    ratios = torque_ratios(msg, PAYLOAD)
    assert np.all(ratios <= 1.005), ratios
    assert np.max(ratios) >= 0.99, ratios                  # the torque binds ...
    np.testing.assert_allclose(numbers(values['peak_torque_ratio']), ratios, atol=5e-3)
    joint = vr.UR5_JOINTS[int(np.argmax(ratios))]
    assert values['binding'].startswith(f'{joint} torque ratio '), values['binding']
    # Planned to the efforts less the default headroom.
    np.testing.assert_allclose(numbers(values['limit_torque']), SHARE * EFFORT)
    assert values['torque_headroom'] == '0.1'
    system.wait_until_played(n_arm, duration(msg))
    # A tool request: timed along the line with the torque as a constraint, held;
    # then with a tool speed too.
    for speed, offset in ((0.0, [0.0, 0.25, -0.1]), (0.1, [0.0, -0.25, 0.1])):
        assert system.set_planner_parameters({'max_tool_speed': speed})[0].successful
        start = np.array(system.joint_states[-1].position)
        n_arm = len(system.arm_status)
        status, msg = system.request(tool_poses(start, offset))
        assert_planned(status)
        values = status_values(status)
        assert values['tool_construction'] == 'tool lines'
        ratios = torque_ratios(msg, PAYLOAD)
        assert np.all(ratios <= 1.005), ratios
        np.testing.assert_allclose(numbers(values['peak_torque_ratio']), ratios, atol=5e-3)
        if speed:
            assert float(values['max_tool_speed_reached']) <= speed * 1.001
        system.wait_until_played(n_arm, duration(msg))
    assert system.set_planner_parameters({'max_tool_speed': 0.0})[0].successful


def test_the_dynamic_arm_carries_the_payload_without_saturating(system):
    # Planned to the default share of the efforts: the PD loop has the rest.
    system.spin_for(0.6)   # the last trajectory's settling report
    start = np.array(system.joint_states[-1].position)
    n_arm = len(system.arm_status)
    status, msg = system.request(waypoint_message(vr.UR5_JOINTS, [start, READY]))
    assert_planned(status)
    assert np.max(numbers(status_values(status)['peak_torque_ratio'])) >= 0.99
    system.wait_until_played(n_arm, duration(msg))

    def report():
        """Return the arm's report of the trajectory, once settled."""
        return next((s for s in system.arm_status[n_arm:]
                     if 'settling_error' in status_values(s)), None)
    assert system.spin_until(lambda: report() is not None, 10.0)
    done = report()
    values = status_values(done)
    assert done.level == DiagnosticStatus.OK, done.message
    assert values['saturated_steps'] == '0'
    assert np.all(numbers(values['peak_effort']) <= EFFORT)
    # At rest the arm holds the payload: its torque is gravity with the payload.
    state = system.joint_states[-1]
    q = np.array(state.position)
    zero = np.zeros(6)
    robot = load_robot_model(vr.ur5_urdf())
    loaded = ArmDynamics(robot, vr.UR5_JOINTS, 'tool0', 10.0, (0.0, 0.0, 0.05))
    bare = ArmDynamics(robot, vr.UR5_JOINTS, 'tool0')
    held = np.array(state.effort)
    np.testing.assert_allclose(held[1:3], loaded.torques(q, zero, zero)[1:3], atol=1.0)
    assert np.max(np.abs(held - bare.torques(q, zero, zero))) > 10.0


def test_the_arm_refuses_bad_payloads(system):
    for values, reason in (
            ({'payload_mass': -1.0}, 'payload_mass = -1.0: must be >= 0'),
            ({'payload_inertia': [1.0, 1.0, 1.0, 1.0]}, 'payload_inertia must be empty'),
            ({'payload_inertia': [1.0, 1.0, 5.0]}, 'break the triangle inequality'),
            ({'simulation': 'kinematic'}, 'needs simulation "dynamic"')):
        result = system.arm.set_parameters(overrides(values))[0]
        assert not result.successful and reason in result.reason, (values, result.reason)
    assert system.arm.parameters.config.payload_mass == 10.0
    with LocalRos() as ros:
        with pytest.raises(ValueError, match='needs simulation "dynamic"'):
            ArmSimNode(context=ros.context, parameter_overrides=overrides(
                {'payload_mass': 2.0}))
        with pytest.raises(ValueError, match='needs the frame that holds it: set tool_frame'):
            ArmSimNode(context=ros.context, parameter_overrides=overrides(
                {'simulation': 'dynamic', 'model_file': vr.ur5_urdf(),
                 'initial_positions': list(vr.UR5_READY), 'payload_mass': 2.0}))


def test_a_heavier_payload_plans_slower(planner):
    status, light = planner.request([READY, GOAL])
    assert status.level == DiagnosticStatus.OK, status.message
    # Integers as typed on the command line are taken for doubles.
    result = planner.configure({'payload_mass': 20, 'payload_center_of_mass': [0, 0, 0]})
    assert result.successful, result.reason
    try:
        status, heavy = planner.request([READY, GOAL])
        assert status.level == DiagnosticStatus.OK, status.message
        assert 'torque' in status_values(status)['binding']
        assert duration(heavy) > 1.3 * duration(light), (duration(heavy), duration(light))
        ratios = torque_ratios(heavy, {'payload_mass': 20.0,
                                       'payload_center_of_mass': [0.0, 0.0, 0.0],
                                       'payload_inertia': []})
        assert np.all(ratios <= 1.005) and np.max(ratios) >= 0.99, ratios
    finally:
        assert planner.configure({'payload_mass': 0.0}).successful


@pytest.mark.parametrize('values, reason', [
    ({'payload_mass': -1.0}, r'payload_mass = -1.0: must be >= 0 and finite'),
    ({'payload_mass': math.nan}, r'payload_mass = nan'),
    ({'payload_mass': 1.0, 'payload_center_of_mass': [0.0, 0.1]},
     r'payload_center_of_mass must be 3 finite values'),
    ({'payload_mass': 1.0, 'payload_inertia': [0.1, 0.1, 0.1, 0.0]},
     r'payload_inertia must be empty \(a point mass\), 3 principal moments or 6 values'),
    ({'payload_center_of_mass': [0.0, 0.0, 0.1]},
     r'payload_center_of_mass is set but payload_mass is 0'),
    ({'max_effort': [100.0, 100.0]}, r'max_effort needs one value per joint \(6\)'),
    ({'max_effort': [-1.0] + [0.0] * 5}, r'max_effort\[0\] = -1.0: must be >= 0'),
    ({'kinematics': ''}, r'limit_torque needs kinematics "model"'),
    ({'limit_torque': False, 'payload_mass': 1.0},
     r'payload_mass is set but limit_torque is false'),
    ({'torque_headroom': 0.5}, r'torque_headroom = 0.5: must be in \[0, 0.5\)'),
    ({'torque_headroom': -0.1}, r'torque_headroom = -0.1: must be in'),
    ({'torque_headroom': math.nan}, r'torque_headroom = nan: must be in'),
    ({'limit_torque': False, 'torque_headroom': 0.2},
     r'torque_headroom is set but limit_torque is false'),
    ({'payload_mass': 1.0, 'tool_frame': ''},
     r'payload_mass = 1 kg needs the tool frame that holds the payload: tool_frame is not '
     r"set and the chain ends in 2 links: \['ee_link', 'tool0'\]"),
])
def test_bad_torque_parameters_are_refused_with_the_reason(planner, values, reason):
    result = planner.node.set_parameters_atomically(
        [Parameter(k, value=v) for k, v in values.items()])
    assert not result.successful
    assert re.search(reason, result.reason), result.reason
    assert planner.node.parameters.config.limit_torque
    assert planner.node.parameters.config.payload_mass == 0.0


def test_limit_torque_without_a_model_stops_the_node_and_integers_are_doubles():
    with LocalRos() as ros:
        with pytest.raises(ValueError, match=r'limit_torque needs kinematics "model"'):
            PlannerNode(context=ros.context, cli_args=['--ros-args', '-p',
                                                       'limit_torque:=true'])
        # Integers as typed on the command line, for doubles and double arrays.
        node = ros.add(PlannerNode(context=ros.context, namespace='typed', cli_args=[
            '--ros-args', '-p', 'kinematics:=model', '-p', f'model_file:={vr.ur5_urdf()}',
            '-p', 'tool_frame:=tool0', '-p', 'limit_torque:=true', '-p', 'payload_mass:=2',
            '-p', 'payload_center_of_mass:=[0,0,1]', '-p', 'payload_inertia:=[1,1,1]',
            '-p', 'max_effort:=[150.0,150.0,150.0,28.0,28.0,.inf]']))
        config = node.parameters.config
        assert config.payload_mass == 2.0 and config.payload_center_of_mass == (0.0, 0.0, 1.0)
        assert config.payload_inertia == (1.0, 1.0, 1.0)
        assert config.max_effort == (150.0, 150.0, 150.0, 28.0, 28.0, math.inf)
        assert isinstance(node.get_parameter('payload_mass').value, float)
        torque = node._robot.torque
        assert torque.max_torque[-1] == math.inf and torque.sources[0] == 'max_effort'


def test_gravity_beyond_a_limit_names_the_joint_and_the_node_keeps_serving(planner):
    assert planner.configure({'max_effort': [150.0, 1.0, 150.0, 28.0, 28.0, 28.0]}).successful
    try:
        status, _ = planner.request([READY, GOAL])
        assert status.level == DiagnosticStatus.ERROR
        values = status_values(status)
        assert values['overloaded_joint'] == 'shoulder_lift_joint'
        # The limit planned to: max_effort less the headroom.
        assert float(values['torque_limit']) == pytest.approx(SHARE)
        assert abs(float(values['gravity_torque'])) > 1
        assert "joint 'shoulder_lift_joint': gravity alone needs" in status.message
        assert 'max_effort less torque_headroom 0.1' in status.message
        assert 'at the pose [' in status.message
    finally:
        assert planner.configure({'max_effort': [0.0]}).successful
    # Torque limits are planned rest to rest: a moving end is refused, said so.
    status, _ = planner.request([READY, GOAL], end_velocity=[0.1] + [0.0] * 5)
    assert status.level == DiagnosticStatus.ERROR
    assert 'limit_torque plans rest to rest, but the request has end_velocity' in status.message
    status, msg = planner.request([READY, GOAL])
    assert_planned(status)
    assert np.all(torque_ratios(msg, {'payload_mass': 0.0, 'payload_center_of_mass': [0, 0, 0],
                                      'payload_inertia': []}) <= 1.005)


def test_a_torque_setup_is_not_used_for_other_torque_parameters():
    """A new payload while the description compiles: refused, not planned with the old one."""
    from dataclasses import replace
    from splines445_ros.service.model_planning import build_robot_setup
    from splines445_ros.service.planner_config import PlannerConfig
    from splines445_ros.service.request_planning import TorqueOptions
    config = PlannerConfig(kinematics='model', model_file=vr.ur5_urdf(), tool_frame='tool0',
                           joint_names=tuple(vr.UR5_JOINTS), max_velocity=(0.0,),
                           max_acceleration=(0.0,), max_jerk=(0.0,), max_effort=(0.0,) * 6,
                           limit_torque=True,
                           payload_mass=5.0)
    setup = build_robot_setup(config, robot=load_robot_model(vr.ur5_urdf()))
    assert isinstance(setup.torque_options(config), TorqueOptions)
    # The dynamics itself: plan() takes its gravity pass for the torques at rest.
    assert setup.torque_options(config).inverse_dynamics is setup.torque.dynamics
    # The headroom scales the limits planned to, with no new setup.
    for headroom in (config.torque_headroom, 0.0, 0.3):
        np.testing.assert_allclose(
            setup.torque_options(replace(config, torque_headroom=headroom)).max_torque,
            EFFORT * (1.0 - headroom), rtol=1e-12)
    assert config.torque_headroom == 0.1    # the default doc/nodes.md states
    for changed in ({'payload_mass': 10.0}, {'max_effort': (100.0,) * 6},
                    {'payload_center_of_mass': (0.0, 0.0, 0.1)}):
        with pytest.raises(ValueError, match='still being set up'):
            setup.torque_options(replace(config, **changed))
    assert setup.torque_options(replace(config, limit_torque=False)) is None


def test_a_tool_request_with_torque_limits_on_an_arm_whose_tool_frame_is_its_chain_tip():
    """
    The planner node's order on a Panda with ``tool_frame`` left empty and ``limit_torque``.

    The node takes the torque keywords from the user's config, then plans
    the tool request under ``effective(config)``, which names the chain tip
    as the tool frame.  The tool request took them again from that one,
    whose tool frame differs from the setup's: "still being set up", so
    every tool request of such an arm was refused.
    """
    from splines445_ros.service.model_planning import build_robot_setup, plan_model_tool_request
    from splines445_ros.service.planner_config import PlannerConfig
    config = PlannerConfig.from_values({'kinematics': 'model', 'model_file': vr.panda_urdf(),
                                        'joint_names': list(vr.PANDA_ARM_JOINTS),
                                        'max_velocity': [0.0], 'max_acceleration': [0.0],
                                        'max_jerk': [0.0], 'limit_torque': True})
    setup = build_robot_setup(config)
    assert config.tool_frame == '' and setup.tool_frame != ''
    torque = setup.torque_options(config)
    kinematics = setup.kinematics
    position, quaternion = kinematics.tool.pose(
        kinematics.robot.default_seed(kinematics.joints))
    start = np.concatenate([position, quaternion])
    rows = np.array([start, start + [0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]])
    tool_path = plan_model_tool_request(setup, rows, None, setup.effective(config), torque)
    assert np.all(tool_path.trajectory.torque_ratios <= 1.005)


# The UR5 with its joints damped and with dry friction, per joint [N m s/rad], [N m].
DAMPING = np.array([8.0, 8.0, 8.0, 1.0, 1.0, 1.0])
FRICTION = np.array([3.0, 3.0, 3.0, 0.5, 0.5, 0.5])


def damped_ur5(folder):
    """Write the UR5's URDF with DAMPING and FRICTION in its <dynamics> tags; return its path."""
    with open(vr.ur5_urdf(), encoding='utf-8') as file:
        text = file.read()
    parts = text.split('<dynamics damping="0.0" friction="0.0"/>')
    assert len(parts) == 7
    out = parts[0]
    for d, f, part in zip(DAMPING, FRICTION, parts[1:]):
        out += f'<dynamics damping="{d}" friction="{f}"/>' + part
    path = folder / 'ur5_damped.urdf'
    path.write_text(out, encoding='utf-8')
    return str(path)


def motor_ratios(msg, model_file):
    """
    Return per joint the peak of the motor's torque, damping and friction, over its limit.

    The friction, up to ``F``, opposes the motion: it adds to the torque on
    the side the joint moves to, and is not counted on to help the other
    way (nor at rest).
    """
    q, qd, qdd = points(msg)
    rigid = ArmDynamics(load_robot_model(model_file), vr.UR5_JOINTS, 'tool0').torques(q, qd, qdd)
    tau = rigid + DAMPING * qd
    motor = np.maximum(tau + np.where(qd > 0.0, FRICTION, 0.0),
                       np.where(qd < 0.0, FRICTION, 0.0) - tau)
    return np.max(motor, axis=0) / (SHARE * EFFORT)


def test_a_damped_arms_damping_and_friction_count_against_its_efforts(tmp_path):
    model_file = damped_ur5(tmp_path)
    with Planner({**PLANNER, 'model_file': model_file}, namespace='damped') as planner:
        loaded = next(s for s in planner.status if 'robot' in status_values(s))
        counted = status_values(loaded)['torque_counts_friction']
        assert 'shoulder_pan_joint=8/3/0' in counted and 'wrist_3_joint=1/0.5/0' in counted
        status, msg = planner.request([READY, GOAL])
        assert_planned(status)
        ratios = motor_ratios(msg, model_file)
        assert np.all(ratios <= 1.005), ratios
        assert np.max(ratios) >= 0.99, ratios
        np.testing.assert_allclose(numbers(status_values(status)['peak_torque_ratio']), ratios,
                                   atol=5e-3)
        # Counting the rigid-body torque alone: faster, and beyond the efforts.
        assert planner.configure({'torque_counts_friction': False}).successful
        status, rigid_msg = planner.request([READY, GOAL])
        assert_planned(status)
        assert duration(rigid_msg) < duration(msg)
        assert np.max(motor_ratios(rigid_msg, model_file)) > 1.02
        # Without limit_torque it is refused, not silently ignored.
        result = planner.configure({'limit_torque': False})
        assert not result.successful
        assert 'torque_counts_friction is set but limit_torque is false' in result.reason
