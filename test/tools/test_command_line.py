"""The demos' main(): an exit code with the reason, never a traceback, at any stage."""

import os
import signal
import time

import pytest
from splines445_ros.tools import demo, robot_seam_demo, tool_path_demo
from splines445_ros.tools.command_line import run_main


@pytest.mark.parametrize('tool', [demo, tool_path_demo, robot_seam_demo],
                         ids=['demo', 'tool_path_demo', 'robot_seam_demo'])
def test_an_out_that_is_a_file_is_an_error_not_a_traceback(tool, tmp_path, capsys):
    taken = tmp_path / 'taken'
    taken.write_text('a file, not a folder')
    assert tool.main(['--out', str(taken)]) == 1
    assert 'File exists' in capsys.readouterr().err
    assert taken.read_text() == 'a file, not a folder'


def test_ctrl_c_at_a_late_stage_of_the_demo_exits_130(tmp_path, monkeypatch):
    """Not only while the paper's example runs (helper-64: a traceback from the report)."""
    monkeypatch.setattr(demo, 'run_paper_example', lambda recording: ([], {}))

    def interrupted(*args):
        raise KeyboardInterrupt
    monkeypatch.setattr(demo, 'write_report', interrupted)
    assert demo.main(['--out', str(tmp_path / 'out')]) == 130
    monkeypatch.setattr(robot_seam_demo, 'run_robot_seam_demo', interrupted)
    assert robot_seam_demo.main(['--out', str(tmp_path / 'out')]) == 130


def test_sigterm_exits_143_after_the_clean_up_and_the_handler_is_restored():
    cleaned = []

    def body():
        try:
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(10.0)    # the handler raises in here
            except Exception:   # noqa: B902 - as a node's callback keeps errors from the executor
                return 0
            return 0
        finally:
            cleaned.append('finally')

    before = signal.getsignal(signal.SIGTERM)
    assert run_main('tool', body) == 143
    assert cleaned == ['finally']
    assert signal.getsignal(signal.SIGTERM) is before
