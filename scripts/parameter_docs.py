#!/usr/bin/env python3
"""
Write the parameter tables of doc/nodes.md from the nodes' config dataclasses.

Each table sits between ``<!-- parameters: NODE -->`` and ``<!-- end
parameters -->``; its rows are the fields of the node's config (see
``splines445_ros/service/parameter_table.py``).  Run it after adding or
changing a parameter: ``python3 scripts/parameter_docs.py`` rewrites the
page, ``--check`` only says whether it is up to date (exit status 1 when
not).  ``test/service/test_parameter_table.py`` fails while they differ.
"""

import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)  # the source tree, as the tests import it

from splines445_ros.service.arm_sim_config import ArmSimConfig  # noqa: E402
from splines445_ros.service.parameter_table import rewrite_tables  # noqa: E402
from splines445_ros.service.planner_config import PlannerConfig  # noqa: E402

PAGE = os.path.join(ROOT, 'doc', 'nodes.md')
TABLES = {'planner_node': PlannerConfig, 'arm_sim_node': ArmSimConfig}


def main(argv=None):
    """Rewrite (or, with --check, compare) the tables of doc/nodes.md; return the exit code."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--check', action='store_true',
                        help='do not write; exit 1 when the page differs from the code')
    args = parser.parse_args(argv)
    with open(PAGE, encoding='utf-8') as handle:
        text = handle.read()
    rewritten = rewrite_tables(text, TABLES)
    if rewritten == text:
        print(f'{os.path.relpath(PAGE, ROOT)}: the parameter tables are up to date')
        return 0
    if args.check:
        print(f'{os.path.relpath(PAGE, ROOT)}: the parameter tables differ from the code; '
              'run scripts/parameter_docs.py')
        return 1
    with open(PAGE, 'w', encoding='utf-8') as handle:
        handle.write(rewritten)
    print(f'{os.path.relpath(PAGE, ROOT)}: parameter tables rewritten')
    return 0


if __name__ == '__main__':
    sys.exit(main())
