"""Files for tests that check a project tree: written under a temporary root (test helper)."""

import os


def write_file(root, relpath, text):
    """Write ``text`` to ``root``/``relpath`` (``/``-separated), making its folders."""
    path = os.path.join(root, *relpath.split('/'))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, 'w', encoding='utf-8') as handle:
        handle.write(text)
