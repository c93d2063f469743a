"""The speed of a tool frame along a path: a first-order constraint."""

import numpy as np

from .canonical_forms import SpeedConstraint


class ToolSpeed(SpeedConstraint):
    """
    The linear (or angular) speed of a tool frame: ``|p'(s)| sdot <= v``.

    ``tangent(path)`` returns the tool's velocity per unit path speed,
    ``dp/ds`` (M + 1, 3), e.g. the frame's Jacobian times ``q'``.
    """

    def __init__(self, max_speed, tangent):
        """Take the speed limit (> 0) and the function giving ``dp/ds`` along a path."""
        self.max_speed = float(max_speed)
        self.tangent = tangent

    def squared_speed_limit(self, path):
        """Return ``(v / |dp/ds|)**2`` (inf where the tool does not move)."""
        rate = np.linalg.norm(self.tangent(path), axis=1)
        with np.errstate(divide='ignore', over='ignore'):
            return (self.max_speed / rate) ** 2
