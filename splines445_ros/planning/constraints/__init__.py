"""
The limits along a path as constraint objects, one class per limit.

``path_constraints`` (joint velocity, acceleration, jerk and torque; tool
speed and acceleration: each gives its rows on a gridded path ``q(s)``, and
the speed profiles never ask which kind they hold) and ``torque`` (the
request's torque limit and its 1 kHz check along a finished trajectory).

May import: numpy, scipy, the ``spline`` room and ``planning.validation``.
"""
