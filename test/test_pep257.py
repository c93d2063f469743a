"""ament_pep257 docstring checks over the package."""

import os

from ament_pep257.main import main
import pytest

# Sources only: build/, install/ and .venv/ live inside the package directory too.
# From this file's folder, so that pytest run from anywhere lints them all.
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINTED = [os.path.join(ROOT, p)
          for p in ('splines445_ros', 'test', 'scripts', 'benchmarks', 'setup.py')]


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257():
    rc = main(argv=LINTED)
    assert rc == 0, 'Found code style errors / warnings'
