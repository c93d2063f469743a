"""
The README and the doc pages: every relative link and image resolves, parameters are listed.

Links are read from the Markdown (outside code blocks and code spans):
``[text](target)``, ``![alt](target)`` and ``<img src="target">``.  A
relative target must name an existing file (or folder), and a ``#anchor``
in a link to a Markdown file must be one of its headings, made into an
anchor as GitHub does (lower case, punctuation dropped, spaces to hyphens,
``-1``, ``-2`` for repeats).  ``test_the_checker_finds_broken_links`` runs
the checker on pages written in the test, with one broken link of each kind,
so the link test is known to be able to fail.
"""

from dataclasses import fields
import os
import re

from file_tree import write_file
import pytest
from splines445_ros.service.arm_sim_config import ArmSimConfig
from splines445_ros.service.planner_config import PlannerConfig

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LINK = re.compile(r'!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+"[^"]*")?\s*\)')
IMG = re.compile(r'<img\s[^>]*src="([^"]+)"', re.IGNORECASE)
FENCE = re.compile(r'^(```|~~~)')
EXTERNAL = re.compile(r'^[a-z][a-z0-9+.-]*:', re.IGNORECASE)  # http:, https:, mailto:, ...


def pages(root):
    """README.md and every Markdown file below doc/, as paths."""
    found = [os.path.join(root, 'README.md')]
    for folder, _, files in os.walk(os.path.join(root, 'doc')):
        found += [os.path.join(folder, name) for name in sorted(files) if name.endswith('.md')]
    return found


def prose_lines(path, keep_code=False):
    """Yield (line number, text) outside fenced code blocks, code spans removed unless kept."""
    fenced = False
    with open(path, encoding='utf-8') as handle:
        for number, line in enumerate(handle, 1):
            if FENCE.match(line.strip()):
                fenced = not fenced
                continue
            if not fenced:
                yield number, line if keep_code else re.sub(r'`[^`]*`', '', line)


def anchors(path):
    """Yield the anchors GitHub makes of the headings of a Markdown file."""
    seen = {}
    # A heading's code spans keep their text in GitHub's anchor (their
    # backticks go with the other punctuation).
    for _, line in prose_lines(path, keep_code=True):
        match = re.match(r'^#{1,6}\s+(.*?)\s*#*\s*$', line)
        if not match:
            continue
        slug = re.sub(r'[^\w\- ]', '', match.group(1).strip().lower()).replace(' ', '-')
        count = seen.get(slug, 0)
        seen[slug] = count + 1
        yield slug if count == 0 else f'{slug}-{count}'


def prose(path):
    """Return the page without its code (blank lines kept, so line numbers hold)."""
    lines = dict(prose_lines(path))
    with open(path, encoding='utf-8') as handle:
        total = sum(1 for _ in handle)
    return ''.join(lines.get(number, '\n') for number in range(1, total + 1))


def broken_links(root):
    """Every relative link or image of the pages below ``root`` that does not resolve."""
    broken = []
    for page in pages(root):
        text = prose(page)
        # Whole pages, not lines: a link's text may wrap onto the next line.
        for match in list(LINK.finditer(text)) + list(IMG.finditer(text)):
            target = match.group(1)
            if EXTERNAL.match(target):
                continue
            number = text.count('\n', 0, match.start(1)) + 1
            where = f'{os.path.relpath(page, root)}:{number}: {target}'
            path, _, anchor = target.partition('#')
            resolved = (os.path.normpath(os.path.join(os.path.dirname(page), path))
                        if path else page)
            if not os.path.exists(resolved):
                broken.append(f'{where} (no such file)')
            elif anchor and resolved.endswith('.md') and anchor not in set(anchors(resolved)):
                broken.append(f'{where} (no such heading)')
    return broken


def test_every_relative_link_and_image_of_the_docs_exists():
    assert os.path.exists(os.path.join(ROOT, 'doc', 'nodes.md'))
    assert broken_links(ROOT) == []


def test_the_checker_finds_broken_links(tmp_path):
    root = str(tmp_path)
    write_file(root, 'doc/figure.png', '')
    write_file(root, 'doc/page.md', '# A page\n\n## Connecting to ros2_control\n\n## A page\n'
               'Back to [the README](../README.md) and [here](#a-page-1).\n'
               'Broken: [missing](other.md) and [bad anchor](#nowhere), [a wrapped\n'
               'link](#wrapped).\n'
               '## Moves on arms: `bench_arm.py` (issue 38)\n'
               '[kept code](#moves-on-arms-bench_armpy-issue-38) [dropped code]'
               '(#moves-on-arms--issue-38)\n')
    write_file(root, 'README.md', '# Title\n\n![figure](doc/figure.png)\n'
               '[ok](doc/page.md#connecting-to-ros2_control) [web](https://example.com/x.md)\n'
               '![no image](doc/missing.png) <img src="doc/gone.png">\n'
               '[no heading](doc/page.md#not-there)\n'
               '`[in code](nothing.md)`\n```\n[in a block](nothing.md)\n```\n')
    found = broken_links(root)
    expected = ['README.md:5: doc/missing.png (no such file)',
                'README.md:5: doc/gone.png (no such file)',
                'README.md:6: doc/page.md#not-there (no such heading)',
                os.path.join('doc', 'page.md') + ':7: other.md (no such file)',
                os.path.join('doc', 'page.md') + ':7: #nowhere (no such heading)',
                os.path.join('doc', 'page.md') + ':8: #wrapped (no such heading)',
                os.path.join('doc', 'page.md') + ':10: #moves-on-arms--issue-38 (no such heading)']
    assert sorted(found) == sorted(expected)


def test_the_readme_keeps_the_two_commands():
    with open(os.path.join(ROOT, 'README.md'), encoding='utf-8') as handle:
        text = handle.read()
    assert 'make demo' in text and 'make test' in text  # .ci/run and users rely on them


@pytest.mark.parametrize('config', [PlannerConfig, ArmSimConfig])
def test_every_parameter_has_a_row_in_doc_nodes(config):
    with open(os.path.join(ROOT, 'doc', 'nodes.md'), encoding='utf-8') as handle:
        rows = set(re.findall(r'^\| `(\w+)` \|', handle.read(), re.MULTILINE))
    missing = [f.name for f in fields(config) if f.name not in rows]
    assert missing == []
