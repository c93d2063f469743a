"""
ament_flake8 over the package sources and tests, in a process of its own.

flake8 checks files in worker processes it forks.  Run inside pytest after
the node tests, a forked worker inherits their rclpy objects, and their
garbage collection there crashed it (a segmentation fault, seen with
``pytest test/nodes/test_plan_interfaces.py test/test_flake8.py``).  A fresh
interpreter started for the lint holds none.
"""

import os
import subprocess
import sys

import pytest

# Sources only: build/, install/ and .venv/ live inside the package directory too.
# From this file's folder, so that pytest run from anywhere lints them all.
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINTED = [os.path.join(ROOT, p)
          for p in ('splines445_ros', 'test', 'scripts', 'benchmarks', 'setup.py')]
# The lint prints its errors, one a line, then this line with their count.
LINT = ('import sys\n'
        'from ament_flake8.main import main_with_errors\n'
        'rc, errors = main_with_errors(argv=sys.argv[1:])\n'
        'print("\\n".join(errors))\n'
        'print("errors:", len(errors))\n'
        'sys.exit(rc)\n')
# [s]: the whole tree takes about 20 s here; a hung worker fails the test.
TIMEOUT = 600


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    done = subprocess.run([sys.executable, '-c', LINT, *LINTED], capture_output=True,
                          text=True, timeout=TIMEOUT, cwd=ROOT)
    assert 'errors: ' in done.stdout, f'the lint did not run:\n{done.stdout}\n{done.stderr}'
    assert done.returncode == 0, f'code style errors / warnings:\n{done.stdout}{done.stderr}'
