"""
Turn ``colcon test-result`` output into one closing line: 'tests: N passed, N failed'.

``--skips-fail``: a skipped test counts as a failure too.  The Makefile
passes it when it set up ``.venv`` itself, where every test's packages are
pinned: a skip there means the environment lost one (``importorskip``
turned a missing MuJoCo into three skipped modules and a green run).
"""

import re
import sys


def main(path, skips_fail=False):
    """Print the summary of the colcon test-result output in ``path``; 1 on failures."""
    with open(path, encoding='utf-8') as handle:
        text = handle.read()
    match = re.search(r'Summary: (\d+) tests?, (\d+) errors?, (\d+) failures?, (\d+) skipped',
                      text)
    if not match:
        print('tests: 0 passed, 1 failed (no colcon test-result summary found)')
        return 1
    total, errors, failures, skipped = (int(g) for g in match.groups())
    failed = errors + failures
    passed = total - failed - skipped
    if skips_fail and skipped:
        print(f'{skipped} skipped, which fails the run: every test runs in .venv, so the '
              'environment misses a package (make env installs requirements.txt again)')
    print(f'tests: {passed} passed, {failed} failed, {skipped} skipped')
    return 1 if failed or total == 0 or (skips_fail and skipped) else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1], '--skips-fail' in sys.argv[2:]))
