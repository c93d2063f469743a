"""
Fresh random cases every run (issue 38): one seed from the OS, printed, repeatable.

A target holds only on sets that nothing was tuned on, so the benches no
longer fix their seeds: :func:`run_seed` draws one from the operating
system (:func:`secrets.randbits`) the first time a run asks, prints it at
the top of the output with the command that repeats the run, and gives the
same seed to every later call of the same process.  Set
``SPLINES445_BENCH_SEED=<seed>`` to repeat a run (the seed printed by it).

:func:`generator` gives each use of the seed its own independent stream
(numpy's ``SeedSequence`` of ``[seed, stream]``), so adding a use to a bench
does not change the cases of another.  :func:`case_count` lets
``SPLINES445_BENCH_CASES=<count>`` set how many random cases a bench draws
(fewer for a quick look on a busy machine; say so with the figures).
"""

import os
import secrets
import sys

import numpy as np

VARIABLE = 'SPLINES445_BENCH_SEED'
CASES_VARIABLE = 'SPLINES445_BENCH_CASES'
# The other variables that choose a run's cases (bench_arms reads the arms').
CHOOSING = (CASES_VARIABLE, 'SPLINES445_BENCH_ARMS')
SEED_BITS = 32
_chosen = []


def run_seed():
    """Return this run's seed: ``$SPLINES445_BENCH_SEED``, else a fresh one; printed once."""
    if _chosen:
        return _chosen[0]
    given = os.environ.get(VARIABLE, '').strip()
    if given:
        try:
            seed = int(given, 0)
        except ValueError:
            raise SystemExit(f'{VARIABLE}={given!r} is not an integer') from None
        if seed < 0:
            raise SystemExit(f'{VARIABLE}={given!r} is negative')
        origin = f'from {VARIABLE}'
    else:
        seed = secrets.randbits(SEED_BITS)
        origin = 'fresh from the OS'
    _chosen.append(seed)
    repository = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    script = (os.path.relpath(os.path.abspath(sys.argv[0]), repository)
              if sys.argv and sys.argv[0] else '')
    # The settings that choose the cases too, when set: the command repeats this run.
    chosen = ''.join(f'{name}={os.environ[name].strip()} ' for name in CHOOSING
                     if os.environ.get(name, '').strip())
    arguments = ''.join(f' {a}' for a in sys.argv[1:])
    print(f'Seed: {seed} ({origin}; repeat this run: {VARIABLE}={seed} {chosen}python '
          f'{script}{arguments})')
    sys.stdout.flush()
    return seed


def generator(stream=0):
    """Return a numpy Generator of this run's seed and ``stream`` (an int per use)."""
    return np.random.default_rng([run_seed(), stream])


def case_count(default):
    """Return the number of random cases: ``$SPLINES445_BENCH_CASES``, else ``default``."""
    given = os.environ.get(CASES_VARIABLE, '').strip()
    if not given:
        return default
    try:
        count = int(given)
    except ValueError:
        raise SystemExit(f'{CASES_VARIABLE}={given!r} is not an integer') from None
    if count < 1:
        raise SystemExit(f'{CASES_VARIABLE}={given!r}: at least one case')
    print(f'Cases: {count} ({CASES_VARIABLE}; the default is {default})')
    return count
