"""ament_pep257 docstring checks over the package."""

import os

from ament_pep257.main import main
import pytest

# Sources only: build/, install/ and .venv/ live inside the package directory too.
LINTED = [p for p in ('splines445_ros', 'test', 'scripts', 'benchmarks', 'setup.py')
          if os.path.exists(p)]


@pytest.mark.linter
@pytest.mark.pep257
def test_pep257():
    rc = main(argv=LINTED)
    assert rc == 0, 'Found code style errors / warnings'
