"""Turn ``colcon test-result`` output into one closing line: 'tests: N passed, N failed'."""

import re
import sys


def main(path):
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
    print(f'tests: {passed} passed, {failed} failed, {skipped} skipped')
    return 1 if failed or total == 0 else 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1]))
