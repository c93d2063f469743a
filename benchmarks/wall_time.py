"""Wall time of a call, best of several: what every bench's planning times are."""

import time


def best_of(func, repeats=3):
    """Return (the shortest wall time [s] of ``repeats`` calls of ``func``, the last result)."""
    best, result = float('inf'), None
    for _ in range(repeats):
        started = time.perf_counter()
        result = func()
        best = min(best, time.perf_counter() - started)
    return best, result
