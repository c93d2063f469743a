"""A joint path ``q(s)`` on a grid, with its derivatives: what every constraint reads."""

from dataclasses import dataclass
from typing import Optional

import numpy as np


@dataclass(frozen=True)
class GriddedPath:
    """
    A joint path ``q(s)`` on a grid: what every constraint reads.

    ``s`` (M + 1,) grid, ``steps`` (M,) its spacing, ``positions``,
    ``first``, ``second`` (M + 1, n): ``q``, ``q'`` and ``q''`` at the grid
    points; ``third``, ``q'''``, only where a third-order constraint needs it
    (else None).
    """

    s: np.ndarray
    positions: np.ndarray
    first: np.ndarray
    second: np.ndarray
    third: Optional[np.ndarray] = None

    @property
    def steps(self):
        """Grid spacing (M,)."""
        return np.diff(self.s)

    @classmethod
    def of_ppoly(cls, ppoly, s, third=False):
        """Sample a piecewise polynomial path (scipy ``PPoly``) and its derivatives at ``s``."""
        return cls(s, ppoly(s), ppoly(s, 1), ppoly(s, 2), ppoly(s, 3) if third else None)
