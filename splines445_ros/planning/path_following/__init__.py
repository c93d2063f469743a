"""
C4 555 splines with free inner knots that follow a speed profile along a path.

``inner_knots`` (555 optimal's default construction: its own path, then the
steps that place, fit and scale the inner knots), ``knot_pieces`` (where the
knots go and what each piece needs), ``path_timing`` (the same construction
along a given path: tool lines, torque), ``time_optimal`` (the spline
that follows ``speed_profile.smooth_profile``: plan()'s
``speed_profile='time_optimal'``), ``rest_ends`` (a knots-only plan
given a knot next to each rest end, turned along its chords),
``position_limit_knots`` (a plan past its position limits with its knots
moved back within them) and ``residual_knots`` (a vibration_frequency's
plan with its knots moved to cancel the mode's ringing after the stop).

May import: numpy, scipy, the ``speed_profile``, ``constraints``,
``durations`` and ``spline`` rooms, ``planning.plan_options`` (the request
they plan) and ``planning.validation``.
"""
