"""plot_trajectory's command line on untrusted dumps: a clear error, exit 1, no traceback."""

import json

import pytest
from splines445_ros.tools import plot_trajectory
from splines445_ros.tools.plot_trajectory import main as plot_main


def point(t, q):
    return {'positions': list(q), 'velocities': [0.0] * len(q),
            'time_from_start': {'sec': int(t), 'nanosec': int(round((t % 1) * 1e9))}}


GOOD = {'joint_names': ['a', 'b'],
        'points': [point(0.0, [0.0, 0.0]), point(0.5, [0.2, -0.1]), point(1.0, [0.3, 0.1])]}


def with_points(*points):
    return {'joint_names': ['a', 'b'], 'points': list(points)}


BAD = [
    ('a scalar', 3, 'must hold a JointTrajectory'),
    ('a list', [GOOD], 'must hold a JointTrajectory'),
    ('points not mappings', {'joint_names': ['a', 'b'], 'points': [1, 2]}, 'must be a mapping'),
    ('time not a mapping', with_points({'positions': [0, 0], 'time_from_start': 3}),
     'time_from_start must be a mapping'),
    ('sec null', with_points({'positions': [0, 0], 'time_from_start': {'sec': None}}),
     'sec must be a number'),
    ('a name not a string', {'joint_names': ['a', 2], 'points': GOOD['points']},
     'joint_names must be strings'),
    ('a NaN position', with_points(point(0.0, [0.0, float('nan')]), point(1.0, [0.0, 0.0])),
     'must be finite'),
    ('times going back', with_points(point(1.0, [0.0, 0.0]), point(0.5, [0.1, 0.0])),
     'must increase strictly'),
    ('a time repeated, positions only', with_points(
        {'positions': [0, 0], 'time_from_start': {'sec': 1}},
        {'positions': [1, 0], 'time_from_start': {'sec': 1}}), 'must increase strictly'),
    ('names as one string', {'joint_names': 'ab', 'points': GOOD['points']},
     'joint_names must be a list'),
    ('cut by ros2 topic echo', {'joint_names': ['a', 'b'], 'points': GOOD['points'] + ['...']},
     '--full-length'),
    ('a cut list of values', with_points(point(0.0, [0.0, '...'])), '--full-length'),
    ('too many joints', {'joint_names': [f'j{k}' for k in range(200)], 'points': [
        {'positions': [0.0] * 200}]}, 'at most 20 joints'),
]


@pytest.mark.parametrize('name, dump, reason', BAD, ids=[b[0] for b in BAD])
def test_a_bad_dump_is_refused_with_the_reason(tmp_path, capsys, name, dump, reason):
    path = tmp_path / 'dump.json'
    path.write_text(json.dumps(dump))
    out = tmp_path / 'x.png'
    assert plot_main(['--file', str(path), '--out', str(out)]) == 1
    assert reason in capsys.readouterr().err
    assert not out.exists()


def test_a_good_dump_plots_and_says_where(tmp_path, capsys):
    path = tmp_path / 'dump.json'
    path.write_text(json.dumps(GOOD))
    assert plot_main(['--file', str(path), '--out', str(tmp_path)]) == 0   # a folder
    assert (tmp_path / 'trajectory.png').stat().st_size > 10_000
    assert f'wrote {tmp_path / "trajectory.png"}' in capsys.readouterr().out


def test_bad_arguments_are_refused_before_anything_is_read(tmp_path, capsys, monkeypatch):
    path = tmp_path / 'dump.json'
    path.write_text(json.dumps(GOOD))
    assert plot_main(['--file', str(path), '--out', str(tmp_path / 'x.txt')]) == 1
    assert '.png' in capsys.readouterr().err
    assert plot_main(['--file', str(path), '--out', str(tmp_path / 'no' / 'x.png')]) == 1
    assert 'does not exist' in capsys.readouterr().err
    for argv in (['--timeout', 'inf'], ['--timeout', '0'], ['--outt', 'x.png']):
        with pytest.raises(SystemExit) as stop:
            plot_main(['--file', str(path), *argv])
        assert stop.value.code == 2
    # A file larger than the bound is not read.
    monkeypatch.setattr(plot_trajectory, 'MAX_DUMP_BYTES', 100)
    assert plot_main(['--file', str(path), '--out', str(tmp_path / 'y.png')]) == 1
    assert 'larger than' in capsys.readouterr().err


def test_ros_arguments_are_not_options_of_the_tool(tmp_path):
    path = tmp_path / 'dump.json'
    path.write_text(json.dumps(GOOD))
    out = tmp_path / 'z.png'
    assert plot_main(['--file', str(path), '--out', str(out), '--ros-args', '-r',
                      'joint_trajectory:=other']) == 0
    assert out.exists()
