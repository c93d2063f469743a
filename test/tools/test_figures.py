"""The demo's figures and table: produced, non-trivial, and matching the trajectories."""

import csv
import os

import numpy as np
import pytest
from splines445_ros.nodes.ros_conversions import duration_to_seconds
from splines445_ros.robot import paper_example as pe
from splines445_ros.robot.kinematics import PlanarArm
from splines445_ros.tools.demo import run_paper_example, write_report
from splines445_ros.tools.in_process import stamp_ns
from splines445_ros.tools.plot_trajectory import load_dump, main as plot_main, message_to_dict
import yaml

PNG = b'\x89PNG\r\n\x1a\n'


@pytest.fixture(scope='module')
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp('demo')
    results, _ = run_paper_example()
    metrics, paths = write_report(results, str(out))
    return results, metrics, paths


def check_png(path, low, high):
    assert os.path.exists(path)
    size = os.path.getsize(path)
    assert low <= size <= high, (path, size)
    with open(path, 'rb') as handle:
        assert handle.read(8) == PNG


def test_figures_exist_and_are_non_trivial(demo):
    _, _, paths = demo
    check_png(paths['joint_curves.png'], 100_000, 3_000_000)
    check_png(paths['tool_path.png'], 20_000, 1_000_000)
    check_png(paths['tracking.png'], 80_000, 3_000_000)
    with open(paths['table.md'], encoding='utf-8') as handle:
        lines = handle.read().strip().splitlines()
    assert len(lines) == 2 + 5 and all(line.startswith('|') for line in lines)
    assert all(line.count('|') == 17 for line in lines)  # 16 columns, none empty


def test_table_numbers_match_the_published_trajectories(demo):
    results, _, paths = demo
    with open(paths['table.csv'], encoding='utf-8') as handle:
        rows = list(csv.DictReader(handle))
    assert [(r['method'], r['timing']) for r in rows] == [
        ('434', 'uniform'), ('445', 'uniform'), ('445', 'optimal'), ('555', 'uniform'),
        ('555', 'optimal')]
    arm = PlanarArm()
    for row, result in zip(rows, results):
        msg = result['trajectory']
        times = np.array([duration_to_seconds(p.time_from_start) for p in msg.points])
        assert float(row['duration_s']) == pytest.approx(times[-1], abs=1e-8)
        for name, field in (('velocity', 'velocities'), ('acceleration', 'accelerations')):
            samples = np.abs(np.array([getattr(p, field) for p in msg.points]))
            for j in range(3):
                peak = float(row[f'peak_{name}_{j + 1}'])
                # The exact peak bounds every sample and is close to the sampled maximum.
                assert samples[:, j].max() <= peak * (1 + 1e-9)
                assert samples[:, j].max() >= peak * 0.97
                assert peak <= float(row[f'limit_{name}_{j + 1}']) * (1 + 1e-9)
        tool = arm.forward(np.array([s.position for s in result['joint_states']]))[:, :2]
        deviation = np.max(pe.distance_to_triangle(tool))
        assert float(row['max_tool_deviation']) >= deviation - 1e-12
        assert float(row['max_tool_deviation']) == pytest.approx(deviation, rel=0.05, abs=1e-3)
        # The dynamic arm stops within the friction dead band of its PD loop (at most
        # 0.25 mrad per joint with the defaults, 2 m of reach): 1 mm.
        assert (float(row['tool_end_x']), float(row['tool_end_y'])) == pytest.approx(
            (1.0, 0.0), abs=1e-3)
        check_tracking_columns(row, result)
    # The paper's qualitative claims, read from the table.
    r434, r445 = rows[0], rows[1]
    assert float(r434['max_jerk_jump']) > 10.0
    assert float(r445['max_jerk_jump']) < 1e-6
    assert float(r445['duration_s']) > float(r434['duration_s'])
    assert float(r445['max_tool_deviation']) > float(r434['max_tool_deviation'])
    assert float(rows[2]['duration_s']) < float(r445['duration_s'])
    # 555 is jerk-continuous too, and on this example faster than 445 (issue 10).
    r555, r555_optimal = rows[3], rows[4]
    assert float(r555['max_jerk_jump']) < 1e-6
    assert float(r555['duration_s']) < float(r445['duration_s'])
    assert float(r555_optimal['duration_s']) < float(r555['duration_s'])


def check_tracking_columns(row, result):
    """Check that the arm's figures bound its joint_states and respect the limits."""
    traj, start = result['plan'], result['start_ns']
    states = [s for s in result['states']
              if (stamp_ns(s) - start) * 1e-9 <= traj.duration]
    t = np.array([(stamp_ns(s) - start) * 1e-9 for s in states])
    error = np.abs(traj.evaluate(t) - np.array([s.position for s in states]))
    effort = np.abs(np.array([s.effort for s in states]))
    assert result['started_late_by'] == 0.0     # else it would start part-way: a jump
    assert row['saturated_steps'] == '0'
    for j in range(3):
        rms, peak = float(row[f'tracking_rms_error_{j + 1}']), float(
            row[f'tracking_max_error_{j + 1}'])
        assert 0.0 < rms <= peak
        # joint_states carry states the arm measured (stamped with the physics time)
        # against the same plan, sampled from 10 ms points (a 1e-6 rad allowance).
        assert error[:, j].max() <= peak * (1 + 1e-5) + 1e-6
        # The status carries 6 significant digits.
        assert effort[:, j].max() <= float(row[f'peak_effort_{j + 1}']) * (1 + 1e-5)
        assert float(row[f'peak_effort_{j + 1}']) <= float(row[f'torque_limit_{j + 1}'])
        assert float(row[f'settling_error_{j + 1}']) < 1e-3
    assert 0.0 < float(row['tool_max_error']) < 0.01


def test_plot_trajectory_reads_an_echo_dump(demo, tmp_path):
    results, _, _ = demo
    dump = tmp_path / 'trajectory.yaml'
    dump.write_text(yaml.safe_dump(message_to_dict(results[1]['trajectory'])) + '---\n')
    assert load_dump(str(dump))['joint_names'] == list(pe.JOINT_NAMES)
    out = tmp_path / 'trajectory.png'
    assert plot_main(['--file', str(dump), '--out', str(out)]) == 0
    check_png(str(out), 50_000, 3_000_000)
    empty = tmp_path / 'empty.yaml'
    empty.write_text('joint_names: []\npoints: []\n')
    assert plot_main(['--file', str(empty), '--out', str(tmp_path / 'x.png')]) == 1
    assert not (tmp_path / 'x.png').exists()
