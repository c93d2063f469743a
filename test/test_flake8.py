"""ament_flake8 over the package sources and tests."""

import os

from ament_flake8.main import main_with_errors
import pytest

# Sources only: build/, install/ and .venv/ live inside the package directory too.
# From this file's folder, so that pytest run from anywhere lints them all.
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINTED = [os.path.join(ROOT, p)
          for p in ('splines445_ros', 'test', 'scripts', 'benchmarks', 'setup.py')]


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    rc, errors = main_with_errors(argv=LINTED)
    assert rc == 0, 'Found %d code style errors / warnings:\n' % len(errors) + '\n'.join(errors)
