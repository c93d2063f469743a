"""
Spline methods, one small definition each: 445, 434 and 555.

A method is everything the rest of the planning core needs to know about a
spline family:

* the segment type (:mod:`segments`) of the first, the intermediate and the
  last segment (a single segment is always the quintic of eqs. 13-23);
* the derivatives made continuous at interior knots (the equations of the
  banded system, :mod:`continuity_system`);
* the knot-state components that are unknowns of that system (velocity, or
  velocity and acceleration);
* how many segments a duration change reaches, upstream and downstream,
  counted until its effect has decayed below about 1e-4 of that on its own
  segment (None: it does not decay); optimal timing's Jacobian is banded to
  that reach, plus a rank-one tail where it does not decay
  (:mod:`sensitivity`), which is accurate enough for its linear model.

Adding a method is adding one :class:`Method` to :data:`METHOD_DEFINITIONS`.
"""

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from .segments import CUBIC, QUARTIC, QUARTIC_REVERSED, QUINTIC

# Knot state components: velocity and acceleration.
VEL, ACC = 0, 1


@dataclass(frozen=True)
class Method:
    """One spline method; see the module docstring."""

    name: str
    summary: str
    first: int
    middle: int
    last: int
    continuous: Tuple[int, ...]
    unknowns: Tuple[int, ...]
    reach: Tuple[int, Optional[int]]

    def segment_types(self, n_segments):
        """Return the segment type of every one of ``n_segments`` segments (int array)."""
        types = np.full(n_segments, self.middle, dtype=int)
        if n_segments == 1:
            types[0] = QUINTIC
        else:
            types[0] = self.first
            types[-1] = self.last
        return types

    @property
    def smoothness(self):
        """Return the highest derivative continuous at interior knots (2 = C2)."""
        return max(self.continuous)


METHOD_DEFINITIONS = {
    # Petrinec & Kovacic: quartics and a final quintic, eqs. (3)-(33).  The
    # influence of a duration decays by about 0.1 per knot upstream and not at
    # all downstream (roots 5 - sqrt(24) and -1 of the knot recursion), where
    # the rank-one tail takes over once the decaying mode is gone.  With
    # unequal durations that mode contracts more slowly than 0.1 per knot: a
    # band of 5 left Jacobian errors of 1 % on random durations in a 1:5 range
    # (40 knots), a band of 8 leaves 4e-6 at no measurable cost.
    '445': Method('445', 'quartics and a final quintic; C3 (jerk continuous)',
                  QUARTIC, QUARTIC, QUINTIC, (2, 3), (VEL, ACC), (8, None)),
    # Ho & Cook: quartic, cubics, quartic; interior knot velocities unknown.
    # Influence decays by 2 - sqrt(3) = 0.27 per knot both ways: 0.27^8 = 3e-5.
    '434': Method('434', 'quartic, cubics, quartic; C2 (jerk jumps at knots)',
                  QUARTIC, CUBIC, QUARTIC_REVERSED, (2,), (VEL,), (8, 8)),
    # C4 quintic spline in Hermite form: every segment the quintic of eqs.
    # (13)-(23), interior knot velocities and accelerations unknown, jerk and
    # snap continuous.  Odd degree: the knot recursion has the quintic spline's
    # Euler-Frobenius roots -0.43 and -0.043 (and their reciprocals), so the
    # influence decays by about 0.43 per knot both ways: 0.43^12 = 4e-5.
    '555': Method('555', 'quintics; C4 (jerk and snap continuous)',
                  QUINTIC, QUINTIC, QUINTIC, (3, 4), (VEL, ACC), (12, 12)),
}

METHODS = tuple(METHOD_DEFINITIONS)


def get_method(method):
    """
    Return the :class:`Method` named ``method``; a Method is returned as is.

    Integers are accepted (``555`` for ``'555'``), as ROS parameters typed on
    the command line arrive.  Raises ValueError for an unknown name.
    """
    if isinstance(method, Method):
        return method
    name = method
    if isinstance(method, (int, np.integer)) and not isinstance(method, bool):
        name = str(int(method))
    if isinstance(name, str) and name in METHOD_DEFINITIONS:
        return METHOD_DEFINITIONS[name]
    raise ValueError(f'unknown method {method!r}: expected one of {METHODS}')
