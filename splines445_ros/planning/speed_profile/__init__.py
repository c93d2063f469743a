"""
Speed profiles ``s(t)`` along a fixed path that hold the ``constraints`` room's limits.

``path_velocity`` (the fastest profile under first- and second-order
constraints), ``averaged_timing`` (that profile averaged over windows, the
default's smoothing), ``jerk_profile`` (third order, by sequential LPs),
``smooth_profile`` (a C2 ``sdot**2`` that a spline can follow) and
``residual_vibration`` (the ringing of a lightly damped mode after a stop,
which ``vibration_frequency`` keeps down).

May import: numpy, scipy (highspy where installed), the ``constraints``
and ``spline`` rooms and ``planning.validation``.
"""
