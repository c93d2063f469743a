"""
Values a mode ignores are said, not kept silent (``ValidatedConfig.unused``).

The arm's expectations come from the parameter descriptions users read
(``ros2 param describe``; doc/nodes.md): a row that starts "dynamic" is a
physics value, "dynamic, built-in arm" the planar arm's own.  The planner's
are written out here, each with the mode that uses it and one that does not.
"""

from dataclasses import fields

import pytest
from splines445_ros.service.arm_sim_config import ArmSimConfig
from splines445_ros.service.parameter_table import row_of
from splines445_ros.service.planner_config import PlannerConfig

# A valid value other than the default for each of the arm's mode-bound fields.
ARM_VALUES = {
    'link_lengths': (1.0, 0.8), 'tool_site': 'tool', 'physics_rate': 2000.0, 'gravity': False,
    'link_masses': (5.0, 4.0, 1.0), 'rotor_inertia': (0.2, 0.1, 0.01),
    'joint_damping': (1.0, 1.0, 0.1), 'joint_friction': (0.5, 0.5, 0.05),
    'joint_stiffness': (1e5, 1e5, 1e3), 'spring_damping_ratio': 0.3,
    'torque_limits': (900.0, 300.0, 20.0), 'actuator_time_constant': 0.01,
    'kp': (1e4, 1e4, 100.0), 'kd': (100.0, 100.0, 1.0), 'tool_frame': 'tool0',
    'control_bandwidth': 5.0, 'control_damping_ratio': 0.7,
}
# Refused rather than ignored: a payload on the kinematic arm, and its centre of mass
# or inertia without a mass.
PAYLOAD = {'payload_mass', 'payload_center_of_mass', 'payload_inertia'}


def _described(prefix):
    return {f.name for f in fields(ArmSimConfig)
            if row_of(f).description.startswith(prefix)}


def test_every_described_mode_bound_arm_field_has_a_value_here():
    described = _described('dynamic') | _described('`model_file`, dynamic')
    assert described - PAYLOAD <= set(ARM_VALUES)
    for name, value in (('payload_mass', 1.0), ('payload_inertia', (0.1, 0.1, 0.1))):
        with pytest.raises(ValueError):
            ArmSimConfig.from_values({'simulation': 'kinematic', name: value})


@pytest.mark.parametrize('name', sorted(ARM_VALUES))
def test_the_kinematic_arm_says_it_ignores_physics_values(name):
    base = {'simulation': 'kinematic'}
    needs_model = row_of(next(f for f in fields(ArmSimConfig) if f.name == name)
                         ).description.startswith('`model_file`')
    if needs_model:
        base['model_file'] = 'arm.xml'  # refused without it
    config = ArmSimConfig.from_values({**base, name: ARM_VALUES[name]})
    physics = name in _described('dynamic') | _described('`model_file`, dynamic')
    # link_lengths draws the built-in kinematic arm's tool_pose: used.
    assert (name in config.unused()) == physics, config.unused()
    if physics:
        assert 'simulation is kinematic' in config.unused()[name]
    assert ArmSimConfig.from_values(base).unused() == {}


@pytest.mark.parametrize('name', sorted(ARM_VALUES))
def test_the_dynamic_arm_uses_them_and_a_model_file_not_the_built_in_arms(name):
    built_in_only = _described('dynamic, built-in arm') | {'link_lengths'}
    if not row_of(next(f for f in fields(ArmSimConfig) if f.name == name)
                  ).description.startswith('`model_file`'):
        built_in = ArmSimConfig.from_values({'simulation': 'dynamic', name: ARM_VALUES[name]})
        assert built_in.unused() == {}
    if name == 'spring_damping_ratio' or name in ('kp', 'kd', 'torque_limits'):
        return  # per joint of the model, or not checked with a model: nothing more here
    model = ArmSimConfig.from_values({'simulation': 'dynamic', 'model_file': 'arm.xml',
                                      name: ARM_VALUES[name]})
    assert (name in model.unused()) == (name in built_in_only), model.unused()
    if name in built_in_only:
        assert 'model_file is set' in model.unused()[name]


# (field, value, a mode that uses it, a mode that ignores it)
PLANNER_CASES = [
    ('link_lengths', (1.0, 0.8), {'kinematics': 'planar_3dof'}, {'kinematics': ''}),
    ('max_path_deviation', 0.01, {'kinematics': 'planar_3dof'}, {'kinematics': ''}),
    ('max_orientation_deviation', 0.01, {'kinematics': 'planar_3dof'}, {'kinematics': ''}),
    ('max_inserted_waypoints', 10, {'kinematics': 'planar_3dof'}, {'kinematics': ''}),
    ('max_refinement_time', 5.0, {'kinematics': 'planar_3dof'}, {'kinematics': ''}),
]


@pytest.mark.parametrize('name, value, used, ignored', PLANNER_CASES)
def test_the_planner_says_which_values_its_mode_ignores(name, value, used, ignored):
    assert name not in PlannerConfig.from_values({**used, name: value}).unused()
    config = PlannerConfig.from_values({**ignored, name: value})
    assert list(config.unused()) == [name]
    # At its default it is not mentioned, whatever the mode.
    assert PlannerConfig.from_values(ignored).unused() == {}


@pytest.mark.parametrize('name, value, mode', [
    ('sample_period', 0.002, {'output': 'knots'}), ('inner_knots', 2, {'method': '445'})])
def test_values_a_goal_may_use_are_not_said_to_be_unused(name, value, mode):
    # A goal's overrides may set output sampled, or method 555 with timing optimal.
    assert PlannerConfig.from_values({**mode, name: value}).unused() == {}


def test_a_tool_site_under_a_tool_frame_is_said_to_be_unused():
    model = {'simulation': 'dynamic', 'model_file': 'arm.xml', 'tool_site': 'tool'}
    assert ArmSimConfig.from_values(model).unused() == {}
    both = ArmSimConfig.from_values({**model, 'tool_frame': 'tool0'}).unused()
    assert both == {'tool_site': "tool_frame 'tool0' overrides it"}
