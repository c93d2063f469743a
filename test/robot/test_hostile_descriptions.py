"""
Hostile and careless robot descriptions and limits files (issue 22).

Each test is a regression test of one way a description or a
``joint_limits.yaml`` could stop or mislead the planner: a YAML alias bomb,
user values printed without bound, a description too large for MuJoCo to
compile in reasonable time, a typo in a joint name, a joint range upside
down, limits the planner cannot work with, and files that are not regular
files.
"""

import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from splines445_ros.robot import joint_limits_file as jlf
from splines445_ros.robot import robot_model as rm
from splines445_ros.sim.mujoco_model import load_arm_model, planar_arm_mjcf, PlanarArmModel
from splines445_ros.tools import vendor_robots as vr

PLANAR_JOINTS = ('joint1', 'joint2', 'joint3')


def write(tmp_path, text, name='joint_limits.yaml'):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.fixture(scope='module')
def ur5():
    return rm.load_robot_model(vr.ur5_urdf())


def ur5_velocity(robot):
    return {j.name: j.velocity for j in robot.joints}


# ------------------------------------------------- 2. size of a robot description

def caps(text):
    return text.format(links=rm.MAX_LINKS, joints=rm.MAX_JOINTS, depth=rm.MAX_DEPTH)


def ur5_with_extra_links(count, chain=False, joints_only=False):
    """Return the UR5's URDF plus ``count`` fixed links on tool0 (side by side or chained)."""
    root = ET.parse(vr.ur5_urdf()).getroot()
    parent = 'tool0'
    for i in range(count):
        name = f'extra_{i}'
        if not joints_only:
            ET.SubElement(root, 'link', name=name)
        joint = ET.SubElement(root, 'joint', name=f'extra_joint_{i}', type='fixed')
        ET.SubElement(joint, 'parent', link=parent)
        ET.SubElement(joint, 'child', link=name)
        ET.SubElement(joint, 'origin', xyz='0 0 0.001')
        if chain:
            parent = name
    return ET.tostring(root, encoding='unicode')


@pytest.mark.parametrize('count, chain, joints_only, match', [
    (60_000, False, False, '60011 links, more than the {links} accepted'),
    (1500, False, False, '1511 links, more than the {links} accepted'),
    (1500, False, True, '1510 joints, more than the {joints} accepted'),
    (300, True, False, "link 'extra_299' is 309 links deep \\(from the root link\\), more "
                       'than the {depth} accepted'),
])
def test_an_oversized_urdf_is_refused_before_mujoco(tmp_path, count, chain, joints_only,
                                                    match):
    match = caps(match)
    text = ur5_with_extra_links(count, chain, joints_only)
    with pytest.raises(ValueError, match=match):
        rm.load_robot_model(urdf_string=text)
    path = write(tmp_path, text, 'big.urdf')
    with pytest.raises(ValueError, match=match):
        rm.load_robot_model(path)
    # The simulator's loader reads URDF files the same way.
    with pytest.raises(ValueError, match=match):
        load_arm_model(vr.UR5_JOINTS, [100.0] * 6, 0.0, model_file=path)


def test_the_caps_leave_room_for_real_robots(ur5):
    # A humanoid has about 100 links; a description at the caps still loads.  The UR5 has
    # 11 links, tool0 is 9 links from the root (world).
    text = ur5_with_extra_links(rm.MAX_LINKS - 11)
    assert rm.load_robot_model(urdf_string=text).joint_names == ur5.joint_names
    text = ur5_with_extra_links(rm.MAX_DEPTH - 9, chain=True)
    assert rm.load_robot_model(urdf_string=text).joint_names == ur5.joint_names


def mjcf(body_xml):
    return f'<mujoco><worldbody>{body_xml}</worldbody></mujoco>'


BODY = '<body><geom size="0.1"/></body>'


@pytest.mark.parametrize('text, match', [
    (mjcf(BODY * 1500), '1500 bodies, more than the {links} accepted'),
    (mjcf('<replicate count="40" offset="0 0 1"><replicate count="40" offset="1 0 0">'
          f'{BODY}</replicate></replicate>'), r'1600 bodies'),
    (mjcf('<body>' + '<joint/>' * 1500 + '<geom size="0.1"/></body>'),
     '1500 joints, more than the {joints} accepted'),
    (mjcf('<body><joint/><geom size="0.1"/>' * 300 + '</body>' * 300),
     'a body is 201 bodies deep, more than the {depth} accepted'),
])
def test_an_oversized_mjcf_is_refused_before_mujoco(tmp_path, text, match):
    match = caps(match)
    path = write(tmp_path, text, 'big.xml')
    with pytest.raises(ValueError, match=match):
        rm.load_robot_model(path)
    with pytest.raises(ValueError, match=match):
        load_arm_model(('j',), [1.0], 0.0, model_file=path)


# ------------------------------------------------- 3. limits for an unknown joint

def test_a_limits_entry_for_a_joint_the_model_lacks_is_refused(tmp_path, ur5):
    text = 'joint_limits:\n  shoulder_pan: {has_velocity_limits: true, max_velocity: 0.1}\n'
    with pytest.raises(ValueError, match=r"joint 'shoulder_pan', but the robot model has no "
                                         r'joint of that name \(did you mean '
                                         r"'shoulder_pan_joint'\?\)"):
        jlf.resolve_limits(vr.UR5_JOINTS, ur5_velocity(ur5),
                           jlf.read_joint_limits_file(write(tmp_path, text)),
                           max_acceleration=[5.0] * 6, known_joints=ur5.all_joint_names)
    # Fixed joints of the URDF (MuJoCo has no joint for them) are joints of the model too.
    assert 'ee_fixed_joint' in ur5.all_joint_names


def test_limits_of_joints_of_the_model_that_are_not_planned_are_accepted(tmp_path):
    panda = rm.load_robot_model(vr.panda_urdf())
    text = ('joint_limits:\n'
            '  panda_finger_joint1: {has_velocity_limits: true, max_velocity: 0.1}\n'
            '  panda_finger_joint2: {has_velocity_limits: true, max_velocity: 0.1}\n'
            '  panda_joint1: {has_velocity_limits: true, max_velocity: 1.5}\n')
    assert 'panda_finger_joint2' in panda.all_joint_names  # a mimic joint
    limits = jlf.resolve_limits(vr.PANDA_ARM_JOINTS, ur5_velocity(panda),
                                jlf.read_joint_limits_file(write(tmp_path, text)),
                                max_acceleration=[5.0] * 7,
                                known_joints=panda.all_joint_names)
    assert limits.velocity[0] == 1.5


# ------------------------------------------------------ 4. joint ranges in a URDF

def ur5_with_limit(joint, **attributes):
    root = ET.parse(vr.ur5_urdf()).getroot()
    limit = next(j for j in root.findall('joint') if j.get('name') == joint).find('limit')
    for key, value in attributes.items():
        limit.set(key, value)
    return ET.tostring(root, encoding='unicode')


@pytest.mark.parametrize('lower, upper, match', [
    ('1.0', '-1.0', r'lower="1.0" is above upper="-1.0"'),
    ('nan', '1.0', r'lower="nan" is not a finite number'),
    ('-inf', '1.0', r'lower="-inf" is not a finite number'),
    ('-1.0', 'inf', r'upper="inf" is not a finite number'),
])
def test_a_urdf_joint_range_upside_down_or_not_finite_is_refused(lower, upper, match):
    text = ur5_with_limit('elbow_joint', lower=lower, upper=upper)
    with pytest.raises(ValueError, match=r"joint 'elbow_joint': <limit> " + match):
        rm.load_robot_model(urdf_string=text)


def test_a_urdf_range_of_one_position_holds_the_joint(ur5, tmp_path, monkeypatch):
    # MuJoCo drops a range with lower == upper (the joint would be unlimited),
    # and writes its warning to MUJOCO_LOG.TXT in the working directory: not
    # into the checkout.
    monkeypatch.chdir(tmp_path)
    robot = rm.load_robot_model(urdf_string=ur5_with_limit('elbow_joint', lower='0.5',
                                                           upper='0.5'))
    elbow = robot.joint('elbow_joint')
    assert (elbow.lower, elbow.upper) == (0.5, 0.5)
    assert any("'elbow_joint' at 0.5" in note for note in robot.notes)
    assert robot.joint('wrist_1_joint') == ur5.joint('wrist_1_joint')


def test_a_continuous_joint_keeps_no_range():
    # lower/upper of a continuous joint mean nothing (URDF spec): not checked, unlimited.
    root = ET.parse(vr.ur5_urdf()).getroot()
    joint = next(j for j in root.findall('joint') if j.get('name') == 'wrist_3_joint')
    joint.set('type', 'continuous')
    joint.find('limit').set('lower', '1')
    joint.find('limit').set('upper', '-1')
    robot = rm.load_robot_model(urdf_string=ET.tostring(root, encoding='unicode'))
    assert robot.joint('wrist_3_joint').lower == -np.inf


# ----------------------------------------------------- 6. usable range of limits

def test_an_absurd_urdf_velocity_is_refused_naming_the_joint_and_range():
    robot = rm.load_robot_model(urdf_string=ur5_with_limit('elbow_joint', velocity='1e-300'))
    assert robot.joint('elbow_joint').velocity == 1e-300  # read as written
    with pytest.raises(ValueError, match=r"joint 'elbow_joint'.*URDF.*1e-300.*outside the "
                                         r'usable range \[1e-06, 10000\]'):
        jlf.resolve_limits(vr.UR5_JOINTS, ur5_velocity(robot), max_acceleration=[5.0] * 6)
    # A value that does not win is not used, and not checked.
    limits = jlf.resolve_limits(vr.UR5_JOINTS, ur5_velocity(robot),
                                max_velocity=[0, 0, 1.0, 0, 0, 0], max_acceleration=[5.0] * 6)
    assert limits.velocity[2] == 1.0
    # velocity="0" stays "no URDF limit".
    robot = rm.load_robot_model(urdf_string=ur5_with_limit('elbow_joint', velocity='0'))
    with pytest.raises(ValueError, match="joint 'elbow_joint' has no velocity limit"):
        jlf.resolve_limits(vr.UR5_JOINTS, ur5_velocity(robot), max_acceleration=[5.0] * 6)


# --------------------------------------------------- 8a. files that are not files

def not_a_file(tmp_path, kind):
    if kind == 'directory':
        return str(tmp_path)
    if kind == 'device':
        return '/dev/zero'
    path = str(tmp_path / 'pipe')
    os.mkfifo(path)
    return path


@pytest.mark.parametrize('kind', ['directory', 'device', 'fifo'])
def test_a_path_that_is_not_a_regular_file_is_named_as_such(tmp_path, kind):
    path = not_a_file(tmp_path, kind)
    match = 'is a directory' if kind == 'directory' else 'is not a regular file'
    with pytest.raises(ValueError, match=f'model_file .* {match}'):
        rm.load_robot_model(path)
    with pytest.raises(ValueError, match=f'joint_limits_file .* {match}'):
        jlf.read_joint_limits_file(path)
    with pytest.raises(ValueError, match=f'model_file .* {match}'):
        load_arm_model(PLANAR_JOINTS, [1.0] * 3, 0.0, model_file=path)
    with pytest.raises(ValueError, match=f'model_file .* {match}'):
        rm.check_description_file(path)


@pytest.mark.parametrize('kind', ['missing', 'directory', 'device', 'fifo', 'large', 'small'])
def test_the_cheap_check_and_the_read_refuse_a_file_with_one_message(tmp_path, kind,
                                                                     monkeypatch):
    monkeypatch.setattr(rm, 'MAX_DESCRIPTION_CHARS', 100)
    if kind == 'missing':
        path = str(tmp_path / 'absent.urdf')
    elif kind in ('large', 'small'):
        path = write(tmp_path, '<robot/>' + ' ' * (200 if kind == 'large' else 0), 'r.urdf')
    else:
        path = not_a_file(tmp_path, kind)
    refused = []
    for call in (rm.check_description_file, rm.read_description_file):
        try:
            call(path)
        except ValueError as error:
            refused.append(str(error))
    if kind == 'small':
        assert refused == [] and rm.read_description_file(path) == '<robot/>'
        return
    assert len(refused) == 2 and refused[0] == refused[1], refused
    expected = {'missing': ': no such file', 'directory': ' is a directory, not a file',
                'large': ' has 208 bytes, more than the 100 bytes accepted'}.get(
                    kind, ' is not a regular file (a device, pipe or socket)')
    assert refused[0] == f'model_file {path!r}{expected}'


def test_a_file_larger_than_its_cap_is_refused_unread(tmp_path, monkeypatch):
    monkeypatch.setattr(jlf, 'MAX_FILE_BYTES', 100)
    path = write(tmp_path, 'joint_limits: {}\n' + '#' * 200 + '\n')
    with pytest.raises(ValueError, match='more than the 100 bytes accepted'):
        jlf.read_joint_limits_file(path)
    monkeypatch.setattr(rm, 'MAX_DESCRIPTION_CHARS', 100)
    path = write(tmp_path, '<robot name="r">' + ' ' * 200 + '</robot>', 'r.urdf')
    with pytest.raises(ValueError, match='more than the 100 bytes accepted'):
        rm.load_robot_model(path)


def test_a_limits_file_for_hundreds_of_joints_is_read_and_a_larger_one_refused(tmp_path):
    # It is parsed in the parameter callback: the cap bounds how long that
    # blocks (a 1 MB file took 3-9 s).  MoveIt's format for 300 joints fits.
    def limits_file(joints):
        lines = ['joint_limits:']
        for k in range(joints):
            lines += [f'  joint_{k}:', '    has_velocity_limits: true',
                      '    max_velocity: 2.0', '    has_acceleration_limits: true',
                      '    max_acceleration: 5.0', '    has_jerk_limits: false']
        return write(tmp_path, '\n'.join(lines) + '\n', f'limits_{joints}.yaml')

    limits = jlf.read_joint_limits_file(limits_file(300))
    assert len(limits) == 300 and limits['joint_299'] == {'velocity': 2.0, 'acceleration': 5.0}
    with pytest.raises(ValueError, match='bytes, more than the 65536 bytes accepted'):
        jlf.read_joint_limits_file(limits_file(600))


def test_model_messages_show_user_names_bounded(ur5, tmp_path):
    long = 'x' * 100_000
    path = write(tmp_path, planar_arm_mjcf(PlanarArmModel(), PLANAR_JOINTS), 'arm.xml')
    calls = [lambda: ur5.joint(long), lambda: ur5.select((long, long)),
             lambda: ur5.frame(long, 'tool_frame'),
             lambda: rm.load_robot_model(str(tmp_path / long[:200])),
             lambda: load_arm_model((long,) * 3, [1.0] * 3, 0.0, model_file=path),
             lambda: load_arm_model(PLANAR_JOINTS, [1.0] * 3, 0.0, model_file=path,
                                    tool_frame=long)]
    for call in calls:
        with pytest.raises(ValueError, match='xxx') as error:
            call()
        assert len(str(error.value)) < 2000, str(error.value)[:3000]


# -------------------------------------- 8b. files an MJCF names (MuJoCo opens them itself)

ARM_BODY = '<body><joint name="j" type="hinge"/><geom size="0.1" mass="1"/></body>'


@pytest.mark.parametrize('kind', ['fifo', 'device', 'directory'])
def test_an_mjcf_including_a_file_that_is_not_a_regular_file_is_refused_unopened(
        tmp_path, kind):
    """A named pipe in an <include> blocked MuJoCo, and the node with it, for good."""
    target = not_a_file(tmp_path, kind)
    path = write(tmp_path, f'<mujoco><include file="{target}"/><worldbody>{ARM_BODY}'
                 '</worldbody></mujoco>', 'arm.xml')
    match = 'is a directory' if kind == 'directory' else 'is not a regular file'
    with pytest.raises(ValueError, match=f'<include file=.*{match}'):
        rm.load_robot_model(path)
    with pytest.raises(ValueError, match=f'<include file=.*{match}'):
        load_arm_model(('j',), [1.0], 0.0, model_file=path)


def test_bodies_in_included_files_count_towards_the_cap(tmp_path):
    """The cap held for one file only: 5001 bodies loaded through an <include>."""
    write(tmp_path, '<mujoco><worldbody>' + BODY * 700 + '</worldbody></mujoco>', 'a.xml')
    write(tmp_path, '<mujoco><include file="a.xml"/><worldbody>' + BODY * 400
          + '</worldbody></mujoco>', 'b.xml')
    path = write(tmp_path, '<mujoco><include file="b.xml"/></mujoco>', 'main.xml')
    with pytest.raises(ValueError, match=caps('1100 bodies with its included files, more '
                                              'than the {links} accepted')):
        rm.load_robot_model(path)


def test_an_include_cycle_is_refused(tmp_path):
    write(tmp_path, '<mujoco><include file="b.xml"/></mujoco>', 'a.xml')
    write(tmp_path, '<mujoco><include file="a.xml"/></mujoco>', 'b.xml')
    with pytest.raises(ValueError, match='includes a file twice'):
        rm.load_robot_model(str(tmp_path / 'a.xml'))


@pytest.mark.parametrize('kind', ['fifo', 'device', 'large'])
def test_an_mjcf_asset_that_is_not_a_small_regular_file_is_refused_unopened(
        tmp_path, kind, monkeypatch):
    """A 1.5 GB sparse mesh was read whole (5.5 s, 1.6 GB); a pipe blocked."""
    monkeypatch.setattr(rm, 'MAX_ASSET_BYTES', 1000)
    if kind == 'large':
        target = write(tmp_path, 'solid x\n' + ' ' * 2000 + '\nendsolid x\n', 'big.stl')
    else:
        target = not_a_file(tmp_path, kind)
    path = write(tmp_path, f'<mujoco><asset><mesh name="m" file="{target}"/></asset>'
                 f'<worldbody>{ARM_BODY}</worldbody></mujoco>', 'arm.xml')
    match = 'more than the 1000 bytes' if kind == 'large' else 'is not a regular file'
    with pytest.raises(ValueError, match=f'<mesh file=.*{match}'):
        rm.load_robot_model(path)


def test_an_mjcf_with_a_small_included_file_still_loads(tmp_path):
    write(tmp_path, f'<mujoco><worldbody>{ARM_BODY}</worldbody></mujoco>', 'arm_body.xml')
    path = write(tmp_path, '<mujoco><include file="arm_body.xml"/></mujoco>', 'arm.xml')
    robot = rm.load_robot_model(path)
    assert [j.name for j in robot.joints] == ['j']


# ------------------------------------------------- XML that MuJoCo reads and ElementTree does not

@pytest.mark.parametrize('name, text', [
    # '--' inside a comment: MuJoCo's parser takes it, ElementTree does not, and the
    # checks above (the caps, the included files) once gave up silently on it.
    ('big.xml', '<!-- a -- b -->' + mjcf(BODY * 1500)),
    ('dashes.urdf', None),
])
def test_a_description_that_is_not_well_formed_xml_is_refused(tmp_path, name, text):
    if text is None:    # a UR5 with a separator comment: once loaded as MJCF, limits lost
        with open(vr.ur5_urdf(), encoding='utf-8') as handle:
            text = handle.read().replace('<robot ', '<!-- ---- -->\n<robot ', 1)
    path = write(tmp_path, text, name)
    with pytest.raises(ValueError, match='is not well-formed XML'):
        rm.load_robot_model(path)
    with pytest.raises(ValueError, match='is not well-formed XML'):
        load_arm_model(('j',), [1.0], 0.0, model_file=path)


def test_a_urdf_nested_deeper_than_python_writes_back_is_refused():
    """2000 nested elements in a link: a RecursionError once, which left arm_sim_node."""
    with open(vr.ur5_urdf(), encoding='utf-8') as handle:
        text = handle.read()
    deep = '<a>' * 2000 + '</a>' * 2000
    text = text.replace('<link name="base_link">', '<link name="base_link">' + deep, 1)
    with pytest.raises(ValueError, match='nest too deep to read'):
        rm.load_robot_model(urdf_string=text)


@pytest.mark.parametrize('path, attribute, value, match', [
    ("joint[@name='elbow_joint']/origin", 'xyz', '0 nan 0', r"joint 'elbow_joint': <origin xyz="),
    ("joint[@name='elbow_joint']/axis", 'xyz', '0 inf 0', r"joint 'elbow_joint': <axis xyz="),
    ("link[@name='forearm_link']/inertial/mass", 'value', '1e308',
     r"link 'forearm_link': <mass value="),
    ("link[@name='forearm_link']/inertial/inertia", 'ixx', 'nan',
     r"link 'forearm_link': <inertia ixx="),
])
def test_a_urdf_number_that_is_not_finite_or_absurd_is_refused_at_load(path, attribute, value,
                                                                       match):
    """They loaded with an OK status, and every request then failed obscurely."""
    root = ET.parse(vr.ur5_urdf()).getroot()
    element = root.find(path)
    assert element is not None, path
    element.set(attribute, value)
    with pytest.raises(ValueError, match=match + '.*must be finite numbers'):
        rm.load_robot_model(urdf_string=ET.tostring(root, encoding='unicode'))
