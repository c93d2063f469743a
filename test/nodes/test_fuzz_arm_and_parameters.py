"""Fuzz arm_sim_node on joint_trajectory, and parameter updates on both nodes."""

import math
import os

from diagnostic_msgs.msg import DiagnosticStatus
from fuzz_messages import arm_trajectories, JOINTS
from hypothesis import given, HealthCheck, settings, strategies as st
from node_status import assert_planned
import numpy as np
import pytest
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter
from splines445_ros.service.arm_sim_config import ArmSimConfig
from splines445_ros.service.planner_config import PlannerConfig
from splines445_ros.tools.in_process import InProcessSystem, overrides, waypoint_message

N_MESSAGES = int(os.environ.get('SPLINES445_FUZZ_EXAMPLES', '2000')) // 2
ARM = {'sent': 0, 'good': 0, 'bad': 0}
PARAMETERS = {'tried': 0, 'accepted': 0, 'rejected': 0, 'undeclared': 0}


@pytest.fixture(scope='module')
def system():
    with InProcessSystem() as s:
        yield s
    print(f'\narm fuzz: {ARM}\nparameter fuzz: {PARAMETERS}')


@settings(max_examples=N_MESSAGES, suppress_health_check=list(HealthCheck), deadline=None)
@given(case=arm_trajectories())
def test_every_arm_trajectory_gets_one_status(system, case):
    msg, good = case
    ARM['sent'] += 1
    ARM['good' if good else 'bad'] += 1
    n = len(system.arm_status)
    system.trajectory_publisher.publish(msg)
    assert system.spin_until(lambda: len(system.arm_status) > n, 10.0), 'no status'
    assert len(system.arm_status) == n + 1
    status = system.arm_status[n]
    # Accepted: OK, or WARN (late, far ahead, or ending with a velocity); refused: ERROR.
    assert (status.level != DiagnosticStatus.ERROR) == good, status.message
    state = system.arm.position
    assert state.shape == (3,) and np.all(np.isfinite(state))


def test_arm_is_alive_and_publishing(system):
    n = len(system.joint_states)
    assert system.spin_until(lambda: len(system.joint_states) > n + 3, 5.0)
    assert np.all(np.isfinite(system.joint_states[-1].position))


values = st.one_of(
    st.booleans(), st.integers(-5, 300000), st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(['445', '434', 'uniform', 'optimal', 'fixed', '', 'joint1', 'base_link']),
    st.lists(st.floats(-1e3, 1e3) | st.sampled_from([math.nan, math.inf, 0.0, -1.0]),
             min_size=1, max_size=4),
    st.lists(st.sampled_from(['joint1', 'joint2', 'joint3', 'x', '']), min_size=1, max_size=4))
PLANNER_NAMES = [*PlannerConfig.__dataclass_fields__, 'no_such_parameter']
ARM_NAMES = [*ArmSimConfig.__dataclass_fields__, 'no_such_parameter']


@settings(max_examples=max(N_MESSAGES // 2, 50), suppress_health_check=list(HealthCheck),
          deadline=None)
@given(which=st.sampled_from(['planner', 'arm']), data=st.data())
def test_parameter_updates_never_break_a_node(system, which, data):
    node = system.planner if which == 'planner' else system.arm
    names = PLANNER_NAMES if which == 'planner' else ARM_NAMES
    updates = data.draw(st.lists(st.tuples(st.sampled_from(names), values),
                                 min_size=1, max_size=3))
    PARAMETERS['tried'] += 1
    try:
        # set_parameters applies the list one by one (not atomically).
        results = node.set_parameters([Parameter(n, value=v) for n, v in updates])
    except ParameterNotDeclaredException:
        PARAMETERS['undeclared'] += 1
        results = []
    for result in results:
        PARAMETERS['accepted' if result.successful else 'rejected'] += 1
        if not result.successful:
            assert result.reason
    # Whatever happened, the configuration in force is valid and is the one the
    # parameters give ("not set" values resolved the same way).
    config = node.parameters.config
    config.validate()
    from_parameters = type(config).from_values(
        {name: node.get_parameter(name).value for name in config.__dataclass_fields__})
    assert from_parameters == config


def test_planner_still_plans_after_parameter_fuzz(system):
    # Back to the defaults, every parameter at once (the fuzz may have left, say,
    # position limits that no plan meets).
    defaults = PlannerConfig()
    result = system.planner.set_parameters_atomically(overrides(
        {name: getattr(defaults, name) for name in PlannerConfig.__dataclass_fields__}))
    assert result.successful, result.reason
    assert list(JOINTS) == list(defaults.joint_names)
    status, trajectory = system.request(waypoint_message(JOINTS, [[0, 0, 0], [0.5, 0.2, 0.1]]))
    assert_planned(status)
