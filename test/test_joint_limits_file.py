"""Limits from the robot's description: URDF <limit velocity>, MoveIt joint_limits.yaml."""

import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest
from splines445_ros.arm.joint_limits_file import read_joint_limits_file, resolve_limits
from splines445_ros.arm.robot_model import load_robot_model
from splines445_ros.nodes.model_planning import build_robot_setup
from splines445_ros.nodes.planner_config import PlannerConfig
from splines445_ros.tools import vendor_robots as vr

# As MoveIt Setup Assistant writes it (moveit_resources style), for the UR5.
UR5_LIMITS_YAML = """
default_velocity_scaling_factor: 0.1
default_acceleration_scaling_factor: 0.1
joint_limits:
  shoulder_pan_joint:
    has_velocity_limits: true
    max_velocity: 2.0
    has_acceleration_limits: true
    max_acceleration: 5.0
    has_jerk_limits: true
    max_jerk: 50
  shoulder_lift_joint:
    has_velocity_limits: false
    max_velocity: 0
    has_acceleration_limits: true
    max_acceleration: 5.0
  elbow_joint:
    has_acceleration_limits: true
    max_acceleration: 6
  wrist_1_joint:
    has_acceleration_limits: true
    max_acceleration: 7.5
    has_position_limits: true
    min_position: -3.0
    max_position: 3.0
  wrist_2_joint:
    has_acceleration_limits: true
    max_acceleration: 7.5
  wrist_3_joint:
    has_acceleration_limits: true
    max_acceleration: 7.5
"""


@pytest.fixture(scope='module')
def ur5_velocity():
    robot = load_robot_model(vr.ur5_urdf())
    return {j.name: j.velocity for j in robot.joints}


def write(tmp_path, text, name='joint_limits.yaml'):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_urdf_velocity_and_moveit_file_combine(tmp_path, ur5_velocity):
    limits = resolve_limits(vr.UR5_JOINTS, ur5_velocity,
                            read_joint_limits_file(write(tmp_path, UR5_LIMITS_YAML)))
    # shoulder_pan from the file (2.0 beats the URDF's 3.15), the rest from the URDF.
    np.testing.assert_array_equal(limits.velocity, [2.0, 3.15, 3.15, 3.2, 3.2, 3.2])
    np.testing.assert_array_equal(limits.acceleration, [5.0, 5.0, 6.0, 7.5, 7.5, 7.5])
    assert limits.jerk[0] == 50.0 and np.all(np.isinf(limits.jerk[1:]))
    assert limits.sources['velocity'] == ('joint_limits_file',) + ('urdf',) * 5
    assert limits.sources['jerk'] == ('joint_limits_file',) + ('',) * 5
    report = limits.report()
    assert 'shoulder_pan_joint=2 (joint_limits_file)' in report['limit_velocity_sources']
    assert 'elbow_joint=3.15 (urdf)' in report['limit_velocity_sources']
    assert 'wrist_3_joint=none' in report['limit_jerk_sources']


def test_explicit_values_override_both(tmp_path, ur5_velocity):
    limits = resolve_limits(vr.UR5_JOINTS, ur5_velocity,
                            read_joint_limits_file(write(tmp_path, UR5_LIMITS_YAML)),
                            max_velocity=[1.0, 0, 0, 0, 0, 0.5],
                            max_acceleration=[0, 0, 0, 0, 0, 1.0], max_jerk=[])
    np.testing.assert_array_equal(limits.velocity, [1.0, 3.15, 3.15, 3.2, 3.2, 0.5])
    assert limits.sources['velocity'][0] == limits.sources['velocity'][5] == 'parameter'
    assert limits.acceleration[5] == 1.0 and limits.sources['acceleration'][4] == \
        'joint_limits_file'


def test_a_joint_without_acceleration_limit_is_named(ur5_velocity):
    with pytest.raises(ValueError, match="joint 'shoulder_pan_joint' has no acceleration limit"):
        resolve_limits(vr.UR5_JOINTS, ur5_velocity)
    with pytest.raises(ValueError, match="joint 'b' has no velocity limit"):
        resolve_limits(['a', 'b'], {'a': 1.0, 'b': 0.0}, max_acceleration=[1.0, 1.0])
    with pytest.raises(ValueError, match=r'max_velocity needs one value per joint \(2\)'):
        resolve_limits(['a', 'b'], max_velocity=[1.0])
    with pytest.raises(ValueError, match=r'max_jerk\[1\] = -1'):
        resolve_limits(['a', 'b'], {'a': 1, 'b': 1}, max_acceleration=[1, 1], max_jerk=[0, -1])


@pytest.mark.parametrize('text, match', [
    ('joint_limits:\n  j:\n    has_velocity_limits: true\n    max_vel: 2\n',
     r"joint 'j' has unknown key\(s\) \['max_vel'\]"),
    ('joint_limits:\n  j:\n    has_velocity_limits: yes please\n    max_velocity: 2\n',
     'has_velocity_limits must be true or false'),
    ('joint_limits:\n  j:\n    has_acceleration_limits: true\n    max_acceleration: -3\n',
     'max_acceleration = -3 must be a positive number'),
    ('joint_limits:\n  j:\n    has_jerk_limits: true\n', 'has_jerk_limits: true but no max_jerk'),
    ('limits:\n  j: {}\n', 'no top-level "joint_limits"'),
    ('joint_limits: {}\nscaling: 1\n', r"unknown top-level key\(s\) \['scaling'\]"),
    ('joint_limits: [1, 2]\n', 'must map joint names'),
    ('joint_limits: {j: [1]\n', 'not readable YAML'),
])
def test_bad_limits_files_are_refused_with_the_reason(tmp_path, text, match):
    with pytest.raises(ValueError, match=match):
        read_joint_limits_file(write(tmp_path, text))


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(ValueError, match='no such file'):
        read_joint_limits_file(str(tmp_path / 'none.yaml'))


def test_infinite_or_nan_file_values_are_refused(tmp_path):
    text = 'joint_limits:\n  j:\n    has_velocity_limits: true\n    max_velocity: .inf\n'
    with pytest.raises(ValueError, match='positive number'):
        read_joint_limits_file(write(tmp_path, text))


def test_position_limits_default_to_the_models_joint_ranges():
    # Issue 18: with kinematics "model", unset min/max_position are the URDF's ranges.
    path = vr.ur5_urdf()
    ranges = {j.get('name'): (float(j.find('limit').get('lower')),
                              float(j.find('limit').get('upper')))
              for j in ElementTree.parse(path).getroot().iter('joint')
              if j.get('type') == 'revolute'}
    config = PlannerConfig.from_values({
        'kinematics': 'model', 'model_file': path, 'tool_frame': 'tool0',
        'joint_names': list(vr.UR5_JOINTS), 'max_velocity': [0.0],
        'max_acceleration': [5.0] * 6, 'max_jerk': [0.0]})
    setup = build_robot_setup(config)
    assert setup.config.min_position == tuple(ranges[n][0] for n in vr.UR5_JOINTS)
    assert setup.config.max_position == tuple(ranges[n][1] for n in vr.UR5_JOINTS)
    # Explicit ones win, and must have one value per joint of the model.
    explicit = PlannerConfig.from_values({**{f: getattr(config, f) for f in (
        'kinematics', 'model_file', 'tool_frame', 'joint_names', 'max_velocity',
        'max_acceleration', 'max_jerk')}, 'min_position': [-1.0] * 6, 'max_position': [1.0] * 6})
    assert build_robot_setup(explicit).config.max_position == (1.0,) * 6
