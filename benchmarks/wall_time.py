"""
Wall time of a call, best of several: what every bench's planning times are.

A planning time over TOPP-RA's (or over any other call's) comes from
:func:`timed_against`: both calls on the same request, in turn, best of
each, so neither side is timed cold or on the machine's slower moments.
"""

import time


def best_of(func, repeats=3):
    """Return (the shortest wall time [s] of ``repeats`` calls of ``func``, the last result)."""
    return interleaved_best_of([func], repeats)[0]


def interleaved_best_of(funcs, repeats=3):
    """
    Return [(shortest wall time [s], last result)] of ``funcs``, called in turn ``repeats`` times.

    One call of each per round: on a shared machine whose speed drifts
    over seconds, each best comes from the same stretches of time, so
    their ratios do not hold one side's slow moment against the other's
    fast one.
    """
    best, results = [float('inf')] * len(funcs), [None] * len(funcs)
    for _ in range(repeats):
        for k, func in enumerate(funcs):
            started = time.perf_counter()
            results[k] = func()
            best[k] = min(best[k], time.perf_counter() - started)
    return list(zip(best, results))


def timed_against(reference, func, repeats=3):
    """
    Return ((``reference``'s best time [s], result), (``func``'s best time [s], result)).

    The two calls in turn, ``repeats`` rounds (:func:`interleaved_best_of`):
    the two times of a ratio ``func`` / ``reference`` (our plan over
    TOPP-RA's on the same request) come from the same rounds, and neither
    is a first, cold call.
    """
    first, second = interleaved_best_of((reference, func), repeats)
    return first, second
