"""
Polynomial segments of the 445, 434 and 555 splines as linear maps of their end conditions.

Every segment k runs from waypoint ``P_k`` to ``P_{k+1}`` in local time
``tau in [0, T]``.  Its coefficients (ascending powers, ``c0 .. c5``) are linear
in the *segment inputs*::

    u = [dP, v_s, a_s, v_e, a_e]      (dP = P_{k+1} - P_k)

plus ``c0 = P_k``.  A segment type is therefore a matrix ``B(T)`` of shape
``(6, 5)`` with ``c = B u`` (row 0 is zero: ``c0`` is added separately).  A
type ignores the inputs it does not use (their columns are zero).  Which
segments of a spline have which type is the method's definition
(:mod:`methods`).

Every entry is homogeneous in ``T``: ``B[i, input]`` is a constant times
``T**(e - i)`` with ``e`` = 0, 1, 2 for a position, velocity, acceleration
input (:data:`INPUT_ORDER`), so ``dB/dT = B * (e - i) / T`` exactly
(:func:`input_map_derivatives`; used for exact Jacobians in optimal timing).

The closed forms are the paper's:

* ``QUARTIC``: eqs. (3)-(9), meets ``P_k, v_k, a_k`` at 0 and ``P_{k+1}, v_{k+1}``
  at ``T`` (every 445 segment but the last, and the first 434 segment).
* ``QUINTIC``: eqs. (13)-(23), meets position, velocity and acceleration at both
  ends (the last 445 segment; the only segment when N = 2; every 555 segment).
* ``CUBIC``: Ho & Cook's intermediate segments, position and velocity at both ends.
* ``QUARTIC_REVERSED``: Ho & Cook's last segment, ``P_k, v_k`` at 0 and
  ``P_{k+1}, v_{k+1}, a_{k+1}`` at ``T`` (the time reversal of ``QUARTIC``).
"""

import numpy as np

QUARTIC = 0
QUINTIC = 1
CUBIC = 2
QUARTIC_REVERSED = 3

N_COEFFS = 6
N_INPUTS = 5
DP, V_START, A_START, V_END, A_END = range(N_INPUTS)
# Time order of every input (position 0, velocity 1, acceleration 2).
INPUT_ORDER = np.array([0, 1, 2, 1, 2])


def _quartic(T, B):
    """Eqs. (8)-(9): b3, b4 of a quartic that starts at (P, v, a) and ends at (P, v)."""
    B[:, 3, DP] = 4.0 / T**3
    B[:, 3, V_START] = -3.0 / T**2
    B[:, 3, A_START] = -1.0 / T
    B[:, 3, V_END] = -1.0 / T**2
    B[:, 4, DP] = -3.0 / T**4
    B[:, 4, V_START] = 2.0 / T**3
    B[:, 4, A_START] = 0.5 / T**2
    B[:, 4, V_END] = 1.0 / T**3


def _quintic(T, B):
    """Eqs. (20)-(22): c3, c4, c5 of a quintic with (P, v, a) given at both ends."""
    B[:, 3, DP] = 10.0 / T**3
    B[:, 3, V_START] = -6.0 / T**2
    B[:, 3, V_END] = -4.0 / T**2
    B[:, 3, A_START] = -1.5 / T
    B[:, 3, A_END] = 0.5 / T
    B[:, 4, DP] = -15.0 / T**4
    B[:, 4, V_START] = 8.0 / T**3
    B[:, 4, V_END] = 7.0 / T**3
    B[:, 4, A_START] = 1.5 / T**2
    B[:, 4, A_END] = -1.0 / T**2
    B[:, 5, DP] = 6.0 / T**5
    B[:, 5, V_START] = -3.0 / T**4
    B[:, 5, V_END] = -3.0 / T**4
    B[:, 5, A_START] = -0.5 / T**3
    B[:, 5, A_END] = 0.5 / T**3


def _cubic(T, B):
    """Ho & Cook cubic: position and velocity given at both ends (a_s, a_e unused)."""
    B[:, 2, A_START] = 0.0
    B[:, 2, DP] = 3.0 / T**2
    B[:, 2, V_START] = -2.0 / T
    B[:, 2, V_END] = -1.0 / T
    B[:, 3, DP] = -2.0 / T**3
    B[:, 3, V_START] = 1.0 / T**2
    B[:, 3, V_END] = 1.0 / T**2


def _quartic_reversed(T, B):
    """Ho & Cook last quartic: (P, v) at 0, (P, v, a) at T (a_s unused)."""
    B[:, 2, A_START] = 0.0
    B[:, 2, DP] = 6.0 / T**2
    B[:, 2, V_START] = -3.0 / T
    B[:, 2, V_END] = -3.0 / T
    B[:, 2, A_END] = 0.5
    B[:, 3, DP] = -8.0 / T**3
    B[:, 3, V_START] = 3.0 / T**2
    B[:, 3, V_END] = 5.0 / T**2
    B[:, 3, A_END] = -1.0 / T
    B[:, 4, DP] = 3.0 / T**4
    B[:, 4, V_START] = -1.0 / T**3
    B[:, 4, V_END] = -2.0 / T**3
    B[:, 4, A_END] = 0.5 / T**2


_FILLERS = {
    QUARTIC: _quartic,
    QUINTIC: _quintic,
    CUBIC: _cubic,
    QUARTIC_REVERSED: _quartic_reversed,
}


def _entries(fill):
    """
    Return the entries ``fill`` sets as (rows, inputs, constants, powers of T) arrays.

    Each entry is ``constant / T**power`` (power 0: the constant itself).
    Found by calling ``fill`` on the durations 2 and 3, whose ratios tell
    the power (every entry is ``constant * T**-power`` with power 0 .. 5).
    """
    B = np.full((2, N_COEFFS, N_INPUTS), np.nan)
    B[:, 1, V_START] = 1.0
    B[:, 2, A_START] = 0.5
    fill(np.array([2.0, 3.0]), B)
    rows, inputs = np.nonzero(~np.isnan(B[0]))
    ratio = B[0, rows, inputs] / np.where(B[1, rows, inputs] == 0.0, 1.0, B[1, rows, inputs])
    powers = np.rint(np.log(np.where(ratio == 0.0, 1.0, ratio)) / np.log(1.5)).astype(int)
    return rows, inputs, B[0, rows, inputs] * 2.0 ** powers, powers


# Every type's entries, for input_maps: one division by a table of the
# powers of T instead of an assignment per entry (the same quotients).
_ENTRIES = {kind: _entries(fill) for kind, fill in _FILLERS.items()}


def input_maps(types, durations):
    """
    Return ``B`` of shape (S, 6, 5): coefficients = ``B @ u`` for every segment.

    Row 0 (the constant term) is zero; every segment's linear (c1) and, where it
    starts with a given acceleration, quadratic (c2) terms are eqs. (4)-(5) and
    (15)-(16): ``c1 = v_s``, ``c2 = a_s / 2``.  ``types`` are the segments'
    types (S,), or one type (an int) of every segment.
    """
    T = np.ascontiguousarray(durations, dtype=float)
    S = T.size
    B = np.zeros((S, N_COEFFS, N_INPUTS))
    if S == 0:
        return B
    # powers[:, k] = T**k, computed as the closed forms write them (1, T, T**2, ...).
    powers = np.empty((S, N_COEFFS))
    powers[:, 0] = 1.0
    powers[:, 1] = T
    powers[:, 2] = T**2
    powers[:, 3] = T**3
    powers[:, 4] = T**4
    powers[:, 5] = T**5
    if isinstance(types, int):
        first = types
    else:
        types = np.asarray(types)
        first = types.flat[0]
    if isinstance(types, int) or np.all(types == first):
        rows, inputs, constants, exponents = _ENTRIES[int(first)]
        B[:, rows, inputs] = constants / powers[:, exponents]
        return B
    for kind, (rows, inputs, constants, exponents) in _ENTRIES.items():
        segments = np.flatnonzero(types == kind)
        if segments.size:
            B[segments[:, None], rows, inputs] = constants / powers[segments][:, exponents]
    return B


def input_map_derivatives(maps, durations):
    """Return ``dB/dT`` (S, 6, 5) of the (S, 6, 5) ``maps`` for their ``durations``."""
    T = np.asarray(durations, dtype=float)
    exponent = INPUT_ORDER[None, :] - np.arange(N_COEFFS)[:, None]
    return maps * exponent[None, :, :] / T[:, None, None]


def _falling_factors(derivative):
    """``i! / (i - d)!`` and the exponent ``i - d`` (0 below d) for i = 0 .. 5."""
    powers = np.arange(N_COEFFS)
    falling = np.ones(N_COEFFS)
    for j in range(derivative):
        falling = falling * np.maximum(powers - j, 0)
    return falling, np.maximum(powers - derivative, 0)


_FALLING = [_falling_factors(d) for d in range(N_COEFFS)]


def falling_factors(derivative):
    """
    Return ``(i! / (i - d)!, i - d)`` for i = 0 .. 5, d = ``derivative``.

    The d-th derivative of ``sum_i c_i tau**i`` is
    ``sum_i falling_i * c_i * tau**exponent_i`` (falling is 0 for i < d).
    """
    return _FALLING[derivative]


def sample_segments(coeffs, durations, count, derivatives=(0,)):
    """
    Return the ``derivatives`` of each segment at ``count`` even times, (S, count, n) each.

    ``coeffs`` (S, 6, n) are ascending in local time, ``durations`` (S,) the
    segments' durations; both ends of every segment are among the times.
    """
    tau = durations[:, None] * np.linspace(0.0, 1.0, count)[None, :]
    out = []
    for derivative in derivatives:
        falling, exponent = falling_factors(derivative)
        out.append(np.einsum('psk,pkn->psn', falling * tau[..., None] ** exponent, coeffs))
    return out


def derivative_weights(durations, derivative, at_end):
    """Weights ``w`` (S, 6) so that ``w @ c`` is the derivative at tau = 0 or tau = T."""
    T = np.asarray(durations, dtype=float)
    falling, exponent = falling_factors(derivative)
    if at_end:
        return falling[None, :] * T[:, None] ** exponent[None, :]
    weights = np.zeros((T.size, N_COEFFS))
    weights[:, derivative] = falling[derivative]
    return weights
