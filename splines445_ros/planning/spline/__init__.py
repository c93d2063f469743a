"""
The splines themselves: 445, 434 and 555 pieces, the banded system that joins them, their peaks.

``segments`` (each piece as a linear map of its end conditions, the paper's
eqs. 1-10), ``methods`` (445, 434, 555: which piece goes where),
``continuity_system`` (the banded system of the interior knots),
``peaks`` (exact peaks of |v|, |a|, |j| per piece), ``limits`` (the joint
limits and the peaks' ratios to them), ``trajectory`` (the
:class:`~.trajectory.Trajectory` every plan returns) and ``natural_cubic``
(the C2 path through the waypoints that the speed profiles follow).

May import: numpy, scipy and ``planning.validation``; no other room of
``planning`` (this is its bottom room).
"""
