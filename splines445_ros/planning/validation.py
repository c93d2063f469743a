"""Checks of user input: every problem is a ValueError that names it and its index."""

import numpy as np


def _first_bad(mask):
    index = np.argwhere(mask)[0]
    return ', '.join(str(i) for i in index)


def real_array(name, value):
    """
    Return ``value`` as a float array; ValueError if it is not numeric, complex or boolean.

    numpy would drop an imaginary part with only a ComplexWarning, and take
    True for 1.
    """
    try:
        raw = np.asarray(value)
        if value is None or (raw.dtype == object and any(v is None for v in raw.reshape(-1))):
            # As float None is NaN: "is nan" named no None (helper-89).
            raise ValueError(f'{name} must be numbers, got None' + (
                '' if value is None else ' among them'))
        if np.iscomplexobj(raw) or (raw.dtype == object and any(
                isinstance(v, complex) for v in raw.reshape(-1))):
            raise ValueError(f'{name} must be real numbers, got complex values')
        if raw.dtype == bool or (raw.dtype == object and any(
                isinstance(v, (bool, np.bool_)) for v in raw.reshape(-1))):
            # As the scalar options refuse them: True would be planned as 1 (helper-69).
            raise ValueError(f'{name} must be real numbers, got booleans')
        return np.array(raw, dtype=float)
    except (TypeError, ValueError) as exc:
        if (('complex' in str(exc) or 'booleans' in str(exc) or 'None' in str(exc))
                and str(exc).startswith(name)):
            raise
        raise ValueError(f'{name} must be numeric: {exc}') from None


def finite_array(name, value, shape=None, ndim=None):
    """Return ``value`` as a float array, checking shape and that it is finite."""
    arr = real_array(name, value)
    if ndim is not None and arr.ndim != ndim:
        raise ValueError(f'{name} must have {ndim} dimension(s), got shape {arr.shape}')
    if shape is not None and arr.shape != tuple(shape):
        raise ValueError(f'{name} must have shape {tuple(shape)}, got {arr.shape}')
    bad = ~np.isfinite(arr)
    if np.any(bad):
        where = _first_bad(bad)
        raise ValueError(f'{name}[{where}] is {arr[tuple(np.argwhere(bad)[0])]}: '
                         'values must be finite')
    return arr


def waypoint_array(waypoints):
    """Return waypoints as an (N, n) array with N >= 2 and n >= 1, all finite."""
    arr = finite_array('waypoints', waypoints)
    if arr.ndim != 2:
        raise ValueError(f'waypoints must be a 2-D array (N waypoints, n joints), '
                         f'got shape {arr.shape}')
    if arr.shape[0] < 2:
        raise ValueError(f'need at least 2 waypoints, got {arr.shape[0]}')
    if arr.shape[1] < 1:
        raise ValueError('waypoints must have at least one joint column')
    return arr


def positive_array(name, value, n, allow_inf=False):
    """Return an (n,) array of positive limits; ``allow_inf`` admits +inf (no limit)."""
    arr = real_array(name, value)
    if arr.shape != (n,):
        raise ValueError(f'{name} must have one value per joint, shape ({n},), got {arr.shape}')
    bad = np.isnan(arr) | (arr <= 0.0) | (np.isinf(arr) & (not allow_inf))
    if np.any(bad):
        i = int(np.argwhere(bad)[0][0])
        kind = 'positive' + ('' if allow_inf else ' and finite')
        raise ValueError(f'{name}[{i}] = {arr[i]}: limits must be {kind}')
    return arr


def boundary_vector(name, value, n):
    """Return an (n,) finite boundary velocity/acceleration, zeros when None."""
    if value is None:
        return np.zeros(n)
    return finite_array(name, value, shape=(n,))


def duration_array(durations, n_segments):
    """Return (N-1,) finite positive segment durations."""
    if durations is None:
        raise ValueError('timing="fixed" needs durations (one per segment)')
    arr = finite_array('durations', durations, ndim=1)
    if arr.shape != (n_segments,):
        raise ValueError(f'durations must have one value per segment, shape ({n_segments},), '
                         f'got {arr.shape}')
    bad = arr <= 0.0
    if np.any(bad):
        i = int(np.argwhere(bad)[0][0])
        raise ValueError(f'durations[{i}] = {arr[i]}: durations must be positive')
    return arr


def non_negative(name, value):
    """Return ``value`` as a finite float >= 0."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f'{name} must be a number, got {value!r}')
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f'{name} must be a number, got {value!r}') from None
    if not (np.isfinite(number) and number >= 0.0):
        raise ValueError(f'{name} = {number}: must be >= 0 and finite')
    return number


def position_limit_vector(name, value, n, default):
    """
    Return (n,) position limits, ``default`` (+-inf) where None (ValueError).

    NaN is refused, and so is the infinity opposite to ``default`` (a lower
    limit of +inf): no position would be within it.
    """
    if value is None:
        return np.full(n, default)
    arr = real_array(name, value)
    if arr.shape != (n,):
        raise ValueError(f'{name} must have one value per joint, shape ({n},), got {arr.shape}')
    bad = np.isnan(arr)
    if np.any(bad):
        raise ValueError(f'{name}[{int(np.flatnonzero(bad)[0])}] is nan')
    # Infinite on the side it bounds (a lower limit of +inf, an upper one of -inf):
    # no position is within it, and every request would be refused.
    bad = arr == -default
    if np.any(bad):
        j = int(np.flatnonzero(bad)[0])
        raise ValueError(f'{name}[{j}] = {arr[j]:g} leaves no position: use {default:g} for a '
                         'joint without a limit')
    return arr
