"""
The end of a command-line tool's ``main()``: an exit code, never a traceback for the usual ends.

Ctrl-C at any stage exits with 130 (the shell's code for SIGINT), as
rclpy's own executables do; an ``OSError`` (an ``--out`` that is a file, a
full disk, no permission) prints the tool's name and the reason and exits
with 1.
"""

import sys


def run_main(name, body):
    """Return ``body()``'s exit code; 130 on Ctrl-C; 1, with the reason, on an OSError."""
    try:
        return body()
    except KeyboardInterrupt:
        return 130
    except OSError as exc:
        print(f'{name}: {exc}', file=sys.stderr)
        return 1
