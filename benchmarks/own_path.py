"""
TOPP-RA along our own path (issue 38): how much the speed profile alone gives away.

Our plan's duration over TOPP-RA's on its chord spline (:func:`chord_spline`:
toppra's cubic through the waypoints against their normalised chord length)
mixes two things: the path (the curve through the waypoints in joint space)
and the speed along it.  :func:`arc_length_samples` takes the geometric path of one of our
trajectories and :func:`toppra_along` times that same curve with TOPP-RA
under the same limits; our duration over that one is what the speed profile
gives away, and that one over TOPP-RA's on its chord spline is what our path
gains or loses.

The path: our trajectory sampled every :data:`TIME_STEP` (and at least
:data:`TIME_SAMPLES_PER_SEGMENT` times per waypoint segment), its
cumulative joint-space arc length ``s`` (Euclidean norm of the joint
steps), then :data:`POINTS_PER_SEGMENT` points per segment (at least
:data:`MIN_POINTS`) equally spaced in ``s``, each our position at the time
our trajectory reaches that ``s`` (linear in time between the samples).
TOPP-RA gets toppra's cubic ``SplineInterpolator`` through those points
against ``s``: a unit-speed parameterisation, so the spline follows our
curve closely (a waypoint where we stop and turn is a kink of the curve;
the spline rounds it over one point spacing, and TOPP-RA slows down there
as we do).  Constraints as every bench builds them for its own rival (the
helpers here: joint velocity and acceleration; velocity and torque), toppra's
default grid and ``ParametrizeConstAccel``.
"""

import numpy as np

TIME_STEP = 1e-3                    # [s] our trajectory's samples for the arc length
TIME_SAMPLES_PER_SEGMENT = 200
POINTS_PER_SEGMENT = 40             # path points equally spaced in arc length
MIN_POINTS = 1001


def arc_length_samples(traj, points_per_segment=POINTS_PER_SEGMENT, min_points=MIN_POINTS):
    """
    Return (s (M,), q (M, n)): ``traj``'s path, points equally spaced in arc length ``s``.

    ``traj`` has ``duration``, ``evaluate(t)`` and ``waypoint_times``
    (a splines445 Trajectory, or the benches' wrapper of a toppra one).
    """
    segments = max(1, len(traj.waypoint_times) - 1)
    count = max(int(np.ceil(traj.duration / TIME_STEP)), TIME_SAMPLES_PER_SEGMENT * segments)
    t = np.linspace(0.0, traj.duration, count + 1)
    q = np.asarray(traj.evaluate(t), float)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    if s[-1] <= 0.0:
        raise ValueError('the trajectory does not move: no path to time')
    # Where we are at rest s stays put: keep the first sample of each such run.
    moving = np.concatenate([[True], np.diff(s) > 0.0])
    s, t = s[moving], t[moving]
    grid = np.linspace(0.0, s[-1], max(min_points, points_per_segment * segments + 1))
    return grid, np.asarray(traj.evaluate(np.interp(grid, s, t)), float)


def spline_path(s, q):
    """Return toppra's cubic spline through ``q`` (M, n) against ``s`` (M,)."""
    import toppra
    return toppra.SplineInterpolator(s, q)


def chord_parameter(points):
    """
    Return (s (M,), q (M, n)): ``points`` (N, n) against their chord-length parameter.

    ``s``: the cumulative joint-space chord lengths (Euclidean norm of the
    steps between consecutive waypoints) over their total, from 0 to 1,
    the parameter of TOPP-RA's chord spline (:func:`chord_spline`).  A
    waypoint that coincides with the one before it (a zero chord, or one
    too short to raise ``s`` in floating point) would make the knots
    non-increasing, which toppra's spline refuses: it is merged into that
    one (left out, M <= N; the path passes there once, as plan() merges
    such waypoints).  ValueError when all the waypoints coincide.
    """
    points = np.asarray(points, float)
    chords = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
    if not chords[-1] > 0.0:
        raise ValueError('the waypoints coincide: no path to time')
    s = chords / chords[-1]
    keep = np.concatenate([[True], np.diff(s) > 0.0])
    return s[keep], points[keep]


def chord_spline(points):
    """Return toppra's cubic spline through ``points`` (N, n) against :func:`chord_parameter`."""
    return spline_path(*chord_parameter(points))


def velocity_acceleration(vmax, amax):
    """Return toppra's joint velocity and acceleration constraints of the limits (n,)."""
    import toppra.constraint as tc
    return [tc.JointVelocityConstraint(np.column_stack([-vmax, vmax])),
            tc.JointAccelerationConstraint(np.column_stack([-amax, amax]))]


def velocity_torque(vmax, tau_max, torques, interpolation=False):
    """
    Return toppra's joint velocity and torque constraints (``torques(q, qd, qdd)``).

    No dry friction; Collocation (toppra's default), or Interpolation.
    """
    import toppra.constraint as tc
    scheme = (tc.DiscretizationType.Interpolation if interpolation
              else tc.DiscretizationType.Collocation)
    return [tc.JointVelocityConstraint(np.column_stack([-vmax, vmax])),
            tc.JointTorqueConstraint(torques, np.column_stack([-tau_max, tau_max]),
                                     np.zeros(len(vmax)), scheme)]


def toppra_on(path, constraints, gridpoints=None):
    """Return TOPP-RA's trajectory along ``path`` (RuntimeError when it finds none)."""
    import toppra.algorithm
    instance = toppra.algorithm.TOPPRA(constraints, path, gridpoints=gridpoints,
                                       parametrizer='ParametrizeConstAccel')
    trajectory = instance.compute_trajectory()
    if trajectory is None:
        raise RuntimeError('TOPP-RA found no parametrisation of the path')
    return trajectory


def toppra_along(traj, constraints):
    """Return TOPP-RA's trajectory along ``traj``'s own path (module docstring)."""
    return toppra_on(spline_path(*arc_length_samples(traj)), constraints)
