"""
Segment durations of a spline with knots at the waypoints only.

``timing`` (chord lengths, eq. 11, and the paper's common scale factor),
``optimal`` (time-optimal durations by trust-region LPs on the exact peak
sensitivities of ``sensitivity``, solved by ``dense_lp``) and
``ratio_search`` (two-segment rest-to-rest requests, searched).

May import: numpy, scipy, the ``spline`` room and ``planning.validation``.
"""
