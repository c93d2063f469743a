"""Joint acceleration limits along a path: a second-order constraint."""

import numpy as np

from .canonical_forms import AccelerationConstraint


class JointAcceleration(AccelerationConstraint):
    """``|q'_j u + q''_j x| <= a_j``: eqs. of :mod:`path_velocity`'s docstring."""

    def __init__(self, max_acceleration):
        """Take the acceleration limit per joint (n,)."""
        self.max_acceleration = np.asarray(max_acceleration, float)

    def rows(self, path):
        """Return ``(q', q'', -a, a)``."""
        bound = np.broadcast_to(self.max_acceleration, path.first.shape)
        return path.first, path.second, -bound, bound
