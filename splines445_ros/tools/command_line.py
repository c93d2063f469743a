"""
The end of a command-line tool's ``main()``: an exit code, never a traceback for the usual ends.

Ctrl-C at any stage exits with 130 (the shell's code for SIGINT), as
rclpy's own executables do, and SIGTERM (``kill``, ``timeout``, ``docker
stop``, systemd) with 143, after the same clean-up: the ``finally`` blocks
and ``with`` exits run, so an MCAP recording is finished and readable, as
``ros2 bag record`` finishes its bag (SIGTERM killed the demo at once, and
its recording, all in one unwritten chunk, was an empty file: helper-72).
An ``OSError`` (an ``--out`` that is a file, a full disk, no permission)
prints the tool's name and the reason and exits with 1.
"""

import signal
import sys
import threading

# The shell's exit codes for a process ended by SIGINT and SIGTERM (128 + the signal).
INTERRUPTED = 130
TERMINATED = 143


class Terminated(BaseException):
    """
    Raised in the main thread by SIGTERM, so that every clean-up on the way out runs.

    A BaseException, as KeyboardInterrupt is: the in-process nodes' callbacks
    run in the main thread, and their ``except Exception`` (an error kept
    from the executor) would swallow it (helper-73).
    """


def _terminate(signum, frame):
    raise Terminated()


def run_main(name, body):
    """Return ``body()``'s exit code: 130 on Ctrl-C, 143 on SIGTERM, 1 on an OSError (said)."""
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if main_thread else None
    try:
        return body()
    except KeyboardInterrupt:
        return INTERRUPTED
    except Terminated:
        return TERMINATED
    except OSError as exc:
        print(f'{name}: {exc}', file=sys.stderr)
        return 1
    finally:
        if main_thread:
            # (None: a handler installed from C, which cannot be put back: the default.)
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)
