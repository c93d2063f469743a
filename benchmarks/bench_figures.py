"""
The figures every row of the issue 38 benches prints, each a plan's over TOPP-RA's on its case.

:data:`NAMES`: the duration over TOPP-RA's (on its chord spline through the
waypoints, ``own_path.chord_spline``, or the bench's rival); over TOPP-RA's along our own path
(:mod:`own_path`: what the speed profile gives away); TOPP-RA along our path
over TOPP-RA (what the path gains or loses); the shaking of a lightly damped
mode at 4 and 8 Hz, peak while moving and residual after the end
(:mod:`shaking`); the planning time over TOPP-RA's (the two timed in the
same rounds: ``wall_time.timed_against``).  :func:`summary` gives
median and worst (the largest: every figure is better smaller) over the
cases of one row.
"""

import numpy as np
from shaking import FREQUENCIES

NAMES = (('duration / TOPP-RA', '{:.3f}'),
         ('duration / TOPP-RA along our path', '{:.3f}'),
         ('TOPP-RA along our path / TOPP-RA', '{:.3f}'))
NAMES += tuple((f'shaking {f:g} Hz {kind}', '{:.2f}') for f in FREQUENCIES
               for kind in ('peak', 'residual'))
NAMES += (('planning / TOPP-RA', '{:.2f}'),)
# The 4 Hz shaking peak's place in a row of NAMES (printed beside a duration).
PEAK_4HZ = [name for name, _ in NAMES].index('shaking 4 Hz peak')


def figures(duration, own_duration, rival_duration, shaking, planning, rival_planning):
    """Return the :data:`NAMES` figures of one plan (list)."""
    return ([duration / rival_duration, duration / own_duration, own_duration / rival_duration]
            + list(shaking) + [planning / rival_planning])


def header(cases=True):
    """Return the column names, as the middle of a Markdown row."""
    tail = ': median / worst' if cases else ''
    return ' | '.join(name + tail for name, _ in NAMES)


def summary(rows):
    """Return 'median / worst' of each figure over ``rows`` (K, len(NAMES)), a row's middle."""
    rows = np.asarray(rows, float).reshape(-1, len(NAMES))
    return ' | '.join(f'{fmt.format(np.median(rows[:, k]))} / {fmt.format(np.max(rows[:, k]))}'
                      for k, (_, fmt) in enumerate(NAMES))


def single(row):
    """Return the figures of one plan, a Markdown row's middle."""
    return ' | '.join(fmt.format(value) for value, (_, fmt) in zip(row, NAMES))


def rule(columns):
    """Return a Markdown header rule of ``columns`` columns."""
    return '|' + '---|' * columns
