"""Joint jerk limits along a path: a third-order constraint."""

import numpy as np

from .canonical_forms import JerkConstraint


class JointJerk(JerkConstraint):
    """
    ``|d/dt (q' u + q'' x)| = |sdot (q''' x + 3 q'' u + q' du/ds)| <= j_j`` per joint.

    Joints without a jerk limit (inf) are left out; the path needs ``third``.
    """

    def __init__(self, max_jerk):
        """Take the jerk limit per joint (n,), inf for none."""
        self.max_jerk = np.asarray(max_jerk, float)

    def terms(self, path):
        """Return ``(q''', 3 q'', q', j)`` of the joints with a jerk limit."""
        limited = np.isfinite(self.max_jerk)
        bound = np.broadcast_to(self.max_jerk[limited], (path.s.size, int(limited.sum())))
        return (path.third[:, limited], 3.0 * path.second[:, limited], path.first[:, limited],
                bound)
