"""Joint velocity limits along a path: a first-order constraint."""

import numpy as np

from .canonical_forms import SpeedConstraint


class JointVelocity(SpeedConstraint):
    """``|q'_j(s)| sdot <= v_j``: ``x <= (v_j / |q'_j|)**2``."""

    def __init__(self, max_velocity):
        """Take the velocity limit per joint (n,)."""
        self.max_velocity = np.asarray(max_velocity, float)

    def squared_speed_limit(self, path):
        """Return ``min_j (v_j / |q'_j|)**2`` (inf where no joint moves)."""
        speed = np.abs(path.first)
        with np.errstate(divide='ignore', over='ignore'):
            return np.min((self.max_velocity[None, :] / speed) ** 2, axis=1)
