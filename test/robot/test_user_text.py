"""Names in messages: the one format of a list of joints, frames or keys (issue 37)."""

import pytest
from splines445_ros.robot import joint_limits_file as jlf
from splines445_ros.robot import user_text
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.robot.user_text import NAMES_SHOWN, show_names
from splines445_ros.tools import vendor_robots as vr


def test_a_short_list_of_names_is_shown_as_python_shows_it():
    assert show_names(['shoulder', 'elbow']) == "['shoulder', 'elbow']"
    assert show_names(('a',)) == "['a']"
    assert show_names(iter(['a', 'b'])) == "['a', 'b']"
    assert show_names([]) == '[]'
    names = [f'joint{i}' for i in range(NAMES_SHOWN)]
    assert show_names(names) == repr(names)


def test_a_long_list_shows_its_first_names_and_the_count():
    names = [f'joint{i}' for i in range(NAMES_SHOWN + 5)]
    assert show_names(names) == (repr(names[:NAMES_SHOWN])[:-1]
                                 + f', ... ({NAMES_SHOWN + 5} in all)]')


def test_each_name_is_cut_short():
    text = show_names(['x' * 100_000, 'y'])
    assert len(text) < 2 * user_text.SHOWN_CHARS
    assert text.startswith("['xxx") and text.endswith("..., 'y']")
    many = show_names(['x' * 100_000] * 100_000)
    assert len(many) < (NAMES_SHOWN + 1) * (user_text.SHOWN_CHARS + 2) + 30
    assert many.endswith(', ... (100000 in all)]')


@pytest.mark.parametrize('text, expected', [
    ('joint_limits: {}\nmore: 1\n', "has unknown top-level key(s) ['more']; known: "),
    ('joint_limits:\n  j: {max_vel: 1, 3: 2}\n', "joint 'j' has unknown key(s) ['max_vel', '3']"),
])
def test_limits_file_keys_are_shown_in_that_format(tmp_path, text, expected):
    path = tmp_path / 'joint_limits.yaml'
    path.write_text(text)
    with pytest.raises(ValueError) as error:
        jlf.read_joint_limits_file(str(path))
    assert expected in str(error.value)


def test_model_messages_list_names_in_that_format():
    robot = load_robot_model(vr.ur5_urdf())
    with pytest.raises(ValueError, match=r"; it has: \['world', 'base_link', 'shoulder_link', "
                                         r".* 'tool0', 'base'\]$"):
        robot.frame('flange', 'tool_frame')
    with pytest.raises(ValueError, match=r"its actuated joints: \['shoulder_pan_joint', .* "
                                         r"'wrist_3_joint'\]$"):
        robot.joint('j7')
