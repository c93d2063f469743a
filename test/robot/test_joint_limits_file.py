"""Limits from the robot's description: URDF <limit velocity>, MoveIt joint_limits.yaml."""

import itertools
import re
import xml.etree.ElementTree as ElementTree

import numpy as np
import pytest
from splines445_ros.planning import plan
from splines445_ros.robot import joint_limits_file as jlf
from splines445_ros.robot.joint_limits_file import read_joint_limits_file, resolve_limits
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.service.model_planning import build_robot_setup
from splines445_ros.service.planner_config import PlannerConfig
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
    assert isinstance(limits, jlf.ResolvedLimits)  # not the planner's JointLimits
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
    # An integer too large for a float (an OverflowError once, which left the node).
    ('joint_limits:\n  j:\n    has_velocity_limits: true\n    max_velocity: ' + '9' * 4000
     + '\n', 'max_velocity = inf must be a positive number'),
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


# ------------------------------------------ hostile and careless files (issue 22)

LONG = 'x' * 100_000


def alias_bomb(levels=9, width=9):
    """Return a joint_limits.yaml whose has_velocity_limits has width**levels items."""
    value = '&a0 [' + ', '.join(['1'] * width) + ']'
    for level in range(1, levels):
        value = f'&a{level} [{value}' + f', *a{level - 1}' * (width - 1) + ']'
    return f'joint_limits:\n  j:\n    has_velocity_limits: {value}\n    max_velocity: 1.0\n'


def test_a_yaml_alias_bomb_is_refused_without_expanding_it(tmp_path):
    text = alias_bomb()
    assert len(text) < 2000
    with pytest.raises(ValueError) as error:
        read_joint_limits_file(write(tmp_path, text))
    message = str(error.value)
    assert 'aliases' in message and len(message) < 500, message[:1000]


def test_yaml_aliases_are_refused(tmp_path):
    text = ('joint_limits:\n'
            '  shoulder: &limits {has_velocity_limits: true, max_velocity: 1.0}\n'
            '  elbow: *limits\n')
    with pytest.raises(ValueError, match=r'anchors and aliases .* not accepted \(line 2, '):
        read_joint_limits_file(write(tmp_path, text))


@pytest.mark.parametrize('text, key, lines', [
    ('joint_limits:\n  j:\n    has_velocity_limits: true\n    max_velocity: 1.0\n'
     '    max_velocity: 2.0\n', 'max_velocity', (4, 5)),
    ('joint_limits:\n  j: {has_velocity_limits: true, max_velocity: 1.0}\n'
     '  j: {has_velocity_limits: true, max_velocity: 3.0}\n', 'j', (2, 3)),
    ('joint_limits: {j: {has_velocity_limits: true, max_velocity: 1, max_velocity: 2}}\n',
     'max_velocity', (1, 1)),
    ('joint_limits: {}\njoint_limits:\n  j: {has_velocity_limits: true, max_velocity: 1}\n',
     'joint_limits', (1, 2)),
], ids=['key', 'joint', 'one line', 'top level'])
def test_a_key_given_twice_is_refused_as_one_value_would_be_ignored(tmp_path, text, key, lines):
    # PyYAML keeps the last value silently; which one MoveIt keeps is not the point.
    with pytest.raises(ValueError, match=rf"the key '{key}' is given twice in one mapping "
                                         rf'\(lines {lines[0]} and {lines[1]}\)'):
        read_joint_limits_file(write(tmp_path, text))


@pytest.mark.parametrize('text, message', [
    ('joint_limits:\n  j: {<<: {has_velocity_limits: true}, max_velocity: 1.0}\n',
     r'merge keys \(<<\) are not accepted \(line 2\)'),
    ('joint_limits:\n  1: {has_velocity_limits: true, max_velocity: 1.0}\n'
     '  "1": {has_velocity_limits: true, max_velocity: 3.0}\n',
     r"joints 1 and '1' are both the joint '1'"),
    ('joint_limits:\n  true: {has_velocity_limits: true, max_velocity: 1.0}\n'
     '  "True": {has_velocity_limits: true, max_velocity: 3.0}\n',
     r"joints True and 'True' are both the joint 'True'"),
])
def test_keys_that_would_hide_one_another_are_refused(tmp_path, text, message):
    with pytest.raises(ValueError, match=message):
        read_joint_limits_file(write(tmp_path, text))


@pytest.mark.parametrize('text', [
    f'joint_limits:\n  ? {LONG}\n  : max_vel: 1\n',
    f'joint_limits:\n  j:\n    ? {LONG}\n    : 1\n',
    f'joint_limits:\n  j:\n    has_velocity_limits: {LONG}\n',
    'joint_limits:\n  j:\n    has_velocity_limits: true\n    max_velocity: ['
    + ', '.join(['1'] * 50_000) + ']\n',
    f'joint_limits:\n  j:\n    has_velocity_limits: true\n    max_velocity: {LONG}\n',
    f'joint_limits:\n  ? {LONG}\n  : 5\n',
    f'? {LONG}\n: 1\njoint_limits: {{}}\n',
], ids=['joint', 'key', 'has', 'list value', 'string value', 'entry', 'top-level key'])
def test_limits_file_messages_show_user_values_bounded(tmp_path, text):
    with pytest.raises(ValueError) as error:
        read_joint_limits_file(write(tmp_path, text))
    message = str(error.value)
    assert len(message) < 1000, message[:2000]
    assert 'joint_limits_file' in message


def test_resolve_limits_messages_show_joint_names_bounded():
    for call in (lambda: resolve_limits([LONG], {}),
                 lambda: resolve_limits([LONG], {LONG: 1e-300}, max_acceleration=[1.0]),
                 lambda: resolve_limits(['a'], {}, {LONG: {'velocity': 1.0}},
                                        max_acceleration=[1.0], known_joints=['a'])):
        with pytest.raises(ValueError, match='xxx') as error:
            call()
        assert len(str(error.value)) < 500, str(error.value)[:1000]


TYPO_YAML = """
joint_limits:
  shoulder_pan:
    has_velocity_limits: true
    max_velocity: 0.1
"""


def test_a_limits_entry_for_a_joint_the_model_lacks_is_refused(tmp_path, ur5_velocity):
    limits = read_joint_limits_file(write(tmp_path, TYPO_YAML))
    with pytest.raises(ValueError, match=r"joint 'shoulder_pan', but the robot model has no "
                                         r'joint of that name \(did you mean '
                                         r"'shoulder_pan_joint'\?\)"):
        resolve_limits(vr.UR5_JOINTS, ur5_velocity, limits, max_acceleration=[5.0] * 6,
                       known_joints=vr.UR5_JOINTS + ('finger_joint',))
    # Joints of the model that are not planned may have limits in the file.
    text = 'joint_limits:\n  finger_joint: {has_velocity_limits: true, max_velocity: 0.1}\n'
    resolve_limits(vr.UR5_JOINTS, ur5_velocity, read_joint_limits_file(write(tmp_path, text)),
                   max_acceleration=[5.0] * 6, known_joints=vr.UR5_JOINTS + ('finger_joint',))
    # Without known_joints (no model at hand) nothing is checked, as before.
    assert resolve_limits(['a'], {'a': 1.0}, {'b': {'velocity': 1.0}},
                          max_acceleration=[1.0]).velocity[0] == 1.0


CORNER_REQUESTS = [
    np.array([[0.0, 0.0], [0.8, -1.5], [2.9, -0.2], [1.0, 0.3]]),
    np.array([[0.0], [0.1], [0.05], [0.2], [0.3], [-0.1], [0.0], [0.12], [0.2], [0.25]]),
]


@pytest.mark.parametrize('method', ['434', '445', '555'])
@pytest.mark.parametrize('timing', ['uniform', 'optimal'])
def test_plans_at_the_corners_of_the_usable_limit_ranges_are_finite_and_within(method,
                                                                               timing):
    ranges = jlf.LIMIT_RANGES
    for velocity, acceleration, jerk in itertools.product(
            ranges['velocity'], ranges['acceleration'], ranges['jerk'] + (None,)):
        for points in CORNER_REQUESTS:
            n = points.shape[1]
            traj = plan(points, method, timing, max_velocity=[velocity] * n,
                        max_acceleration=[acceleration] * n,
                        max_jerk=None if jerk is None else [jerk] * n)
            assert np.all(np.isfinite(traj.coefficients)) and np.isfinite(traj.duration)
            assert traj.within_limits(1e-6), (velocity, acceleration, jerk)


def test_check_limit_value_says_the_range_that_works():
    low, high = jlf.LIMIT_RANGES['velocity']
    assert jlf.check_limit_value('velocity', low, 'here') == low
    assert jlf.check_limit_value('velocity', high, 'here') == high
    for value in (0.5 * low, 2.0 * high, 0.0, -1.0, float('inf'), float('nan')):
        with pytest.raises(ValueError, match=r'^here = \S+ is outside the usable range '
                                             r'\[1e-06, 10000\] \(rad/s or m/s\)'):
            jlf.check_limit_value('velocity', value, 'here')


def test_an_absurd_urdf_velocity_is_refused_naming_the_joint_and_range():
    with pytest.raises(ValueError, match=r"joint 'b': the URDF's <limit velocity> = 1e-300 is "
                                         r'outside the usable range \[1e-06, 10000\]'):
        resolve_limits(['a', 'b'], {'a': 1.0, 'b': 1e-300}, max_acceleration=[1.0, 1.0])
    with pytest.raises(ValueError, match=r"max_acceleration\[1\] \(joint 'b'\) = 1e\+300 is "
                                         r'outside the usable range \[1e-06, 1e\+06\]'):
        resolve_limits(['a', 'b'], {'a': 1.0, 'b': 1.0}, max_acceleration=[1.0, 1e300])
    # A value that does not win is not used, and not checked; 0 is "no URDF limit".
    limits = resolve_limits(['a', 'b'], {'a': 0.0, 'b': 1e-300}, max_velocity=[2.0, 3.0],
                            max_acceleration=[1.0, 1.0])
    assert list(limits.velocity) == [2.0, 3.0]
    with pytest.raises(ValueError, match="joint 'a' has no velocity limit"):
        resolve_limits(['a'], {'a': 0.0}, max_acceleration=[1.0])


@pytest.mark.parametrize('value', ['1e300', '1.0e+300', '1e-300', '2e9'])
def test_an_absurd_limits_file_value_is_refused_naming_the_joint_and_range(tmp_path, value):
    quantity = 'jerk' if value == '2e9' else 'velocity'
    text = (f'joint_limits:\n  elbow_joint:\n    has_{quantity}_limits: true\n'
            f'    max_{quantity}: {value}\n')
    number = re.escape(f'{float(value):g}')
    with pytest.raises(ValueError, match=rf"joint 'elbow_joint': max_{quantity} = {number} "
                                         r'is outside the usable range \['):
        read_joint_limits_file(write(tmp_path, text))


def test_yaml_1_2_numbers_are_numbers(tmp_path):
    # PyYAML reads 1e3 (YAML 1.2, yaml-cpp: a number) as a string; MoveIt reads a number.
    text = ('joint_limits:\n  j:\n    has_velocity_limits: true\n    max_velocity: 1e1\n'
            '    has_acceleration_limits: true\n    max_acceleration: 2.5E+1\n'
            '    has_jerk_limits: true\n    max_jerk: 1_000\n')
    assert read_joint_limits_file(write(tmp_path, text)) == {
        'j': {'velocity': 10.0, 'acceleration': 25.0, 'jerk': 1000.0}}


def test_moveit_scaling_factors_are_read_checked_and_said_not_applied(tmp_path, ur5_velocity):
    """
    The Setup Assistant of MoveIt writes 0.1 for both: accepted, they were silently ignored.

    Plans use the full limits (the factors are MoveIt's defaults for its own
    requests); the report on ``~/status`` says so, and a factor outside (0, 1]
    is refused like any bad value.
    """
    limits = resolve_limits(vr.UR5_JOINTS, ur5_velocity,
                            read_joint_limits_file(write(tmp_path, UR5_LIMITS_YAML)))
    assert limits.unapplied == {'default_velocity_scaling_factor': 0.1,
                                'default_acceleration_scaling_factor': 0.1}
    note = limits.report()['joint_limits_file_not_applied']
    assert note.startswith('default_velocity_scaling_factor = 0.1, '
                           'default_acceleration_scaling_factor = 0.1: MoveIt scales its own')
    bare = re.sub(r'default_\w+_scaling_factor: 0\.1\n', '', UR5_LIMITS_YAML)
    one = resolve_limits(vr.UR5_JOINTS, ur5_velocity, read_joint_limits_file(
        write(tmp_path, 'default_velocity_scaling_factor: 1\n' + bare, 'one.yaml')))
    np.testing.assert_array_equal(limits.velocity, one.velocity)
    np.testing.assert_array_equal(limits.acceleration, one.acceleration)
    assert one.unapplied == {} and 'joint_limits_file_not_applied' not in one.report()
    for bad in ('0', '1.5', '"fast"', 'true'):
        with pytest.raises(ValueError, match='default_velocity_scaling_factor .* must be a '
                                             r'number in \(0, 1\]'):
            read_joint_limits_file(write(tmp_path, f'default_velocity_scaling_factor: {bad}\n'
                                         + bare, 'bad.yaml'))
