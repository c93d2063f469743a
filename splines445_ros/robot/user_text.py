"""
Text from users: files read with a size bound, values shown in messages with a length bound.

A leaf module of ``robot`` (standard library only).  :func:`read_text_file`
opens the path first and then looks at what it opened, so a directory, a
device such as ``/dev/zero`` or a named pipe is named as such (never read,
never waited on), and a regular file is read up to its cap and no further.
:func:`show` is ``repr`` cut to :data:`SHOWN_CHARS` characters, at a cost
independent of the value's size (``reprlib``), and :func:`show_names` a list
of names cut to :data:`NAMES_SHOWN` of them: an error message never grows
with what the user gave.
"""

import os
import reprlib
import stat

SHOWN_CHARS = 80
PATH_CHARS = 300  # a file path is shown longer: its end matters
NAMES_SHOWN = 20  # names of a list in a message: all the joints of two arms with grippers

_REPR = reprlib.Repr()
_REPR.maxlevel = 2
_REPR.maxlist = _REPR.maxtuple = _REPR.maxset = _REPR.maxfrozenset = 4
_REPR.maxdict = 3
_REPR.maxstring = _REPR.maxother = _REPR.maxlong = SHOWN_CHARS


def clip(text, limit=SHOWN_CHARS):
    """Return ``str(text)`` cut to at most ``limit`` characters (ending in ``...`` when cut)."""
    text = str(text)
    return text if len(text) <= limit else text[:limit - 3] + '...'


def show(value, limit=SHOWN_CHARS):
    """Return ``repr(value)`` cut to at most ``limit`` characters, cheaply for any value."""
    if isinstance(value, str):
        text = repr(value[:limit])
    else:
        try:
            text = _REPR.repr(value)
        except Exception:  # a value whose repr fails is still named
            text = f'<{type(value).__name__}>'
    return clip(text, limit)


def format_vector(values):
    """Per-joint numbers as a compact comma-separated string (for status values)."""
    return ', '.join(f'{float(v):.6g}' for v in values)


def show_names(names):
    """
    Return a list of names for a message, like ``repr(list)``, bounded.

    The one format of every list of names (joints, frames, keys) in the
    package's messages: ``['a', 'b']``, each name as :func:`show` gives it;
    beyond :data:`NAMES_SHOWN` names the first of them and the count,
    ``['a', 'b', ... (25 in all)]``.
    """
    names = list(names)
    more = f', ... ({len(names)} in all)' if len(names) > NAMES_SHOWN else ''
    return '[' + ', '.join(show(n) for n in names[:NAMES_SHOWN]) + more + ']'


def show_path(path):
    """Return a file path for messages: its repr, at most :data:`PATH_CHARS` characters."""
    return show(path, PATH_CHARS)


def check_text_file(path, where, max_bytes):
    """
    Raise ValueError unless ``path`` is a regular file of at most ``max_bytes`` bytes.

    The one check of a file a user names, with its messages (``where``
    names the file in them): a missing path, a path that cannot be looked
    at, a directory, anything that is not a regular file (a device, a named
    pipe, a socket), a file of more than ``max_bytes`` bytes.  The cheap
    check before a slow load: the path is looked at (``stat``), not opened
    or read; :func:`read_text_file` makes the same check of what it opens.
    """
    try:
        status = os.stat(path)
    except (OSError, ValueError, TypeError) as exc:
        raise _path_error(exc, where) from None
    _check_status(status, where, max_bytes)


def _path_error(exc, where):
    """Return the ValueError for a path that ``os.stat`` or ``os.open`` refused with ``exc``."""
    if isinstance(exc, FileNotFoundError):
        return ValueError(f'{where}: no such file')
    if isinstance(exc, IsADirectoryError):
        return ValueError(f'{where} is a directory, not a file')
    reason = exc.strerror if isinstance(exc, OSError) else clip(exc)
    return ValueError(f'{where}: cannot open it ({reason})')


def _check_status(status, where, max_bytes):
    """Raise ValueError unless ``status`` (os.stat_result) is a regular file of ``max_bytes``."""
    if stat.S_ISDIR(status.st_mode):
        raise ValueError(f'{where} is a directory, not a file')
    if not stat.S_ISREG(status.st_mode):
        raise ValueError(f'{where} is not a regular file (a device, pipe or socket)')
    if status.st_size > max_bytes:
        raise ValueError(f'{where} has {status.st_size} bytes, more than the {max_bytes} '
                         'bytes accepted')


def read_text_file(path, where, max_bytes):
    """
    Return the UTF-8 text of the regular file ``path`` (ValueError with the reason).

    ``where`` names the file in messages.  Refused as by
    :func:`check_text_file`, with its messages (at most ``max_bytes + 1``
    bytes are ever read), and text that is not UTF-8.
    """
    try:
        # O_NONBLOCK: opening a named pipe must not wait for a writer.
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, 'O_CLOEXEC', 0))
    except (OSError, ValueError, TypeError) as exc:
        raise _path_error(exc, where) from None
    try:
        _check_status(os.fstat(fd), where, max_bytes)
        chunks, left = [], max_bytes + 1
        while left > 0:
            chunk = os.read(fd, min(left, 1 << 20))
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
        data = b''.join(chunks)
    except OSError as exc:
        raise ValueError(f'{where}: cannot read it ({exc.strerror})') from None
    finally:
        os.close(fd)
    if len(data) > max_bytes:  # it grew since fstat
        raise ValueError(f'{where} has more than the {max_bytes} bytes accepted')
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as exc:
        raise ValueError(f'{where} is not UTF-8 text ({exc.reason} at byte {exc.start})') \
            from None
