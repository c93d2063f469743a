"""Wall time of a call, best of several: what every bench's planning times are."""

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
