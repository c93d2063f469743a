"""
Tool lines like an industrial linear move: the timing follows the tool's own path (issue 24).

:func:`plan_tool_lines` is the construction :func:`tool_paths.plan_tool_path`
uses for method 555 with optimal timing, rest to rest:

1. Path.  The straight lines (and the slerps, or yaw interpolations) between
   the tool waypoints, with a path coordinate ``s``: per edge, its length
   plus :data:`ANGLE_LENGTH` times its rotation angle, so a pure rotation
   has a length too.  It is sampled every :data:`SAMPLE_SPACING` of ``s``,
   more densely towards every waypoint (:data:`CORNER_SAMPLES` samples at
   halving distances: the joint path turns sharply there), and the inverse
   kinematics of the samples is the joint path (the kinematics' walk, on the
   seed's branch).
2. Timing.  :func:`planning.path_following.path_timing.plan_along_path` times that joint
   path under the joint limits and, when given, the tool speeds: on an edge
   of length ``L``, rotation ``theta`` and path length ``l``, the tool moves
   ``L / l`` metres and turns ``theta / l`` radians per unit of ``s``, so
   ``max_tool_speed`` is the first-order constraint ``sdot <= v l / L``
   (:class:`planning.constraints.ToolSpeed`).  The C4 555 spline passes
   its knots (on the path) at the profile's times, every waypoint exactly.
3. Taylor's test.  The deviation of the timed spline's tool from the lines
   is measured per piece (:class:`path_deviation.PathMeasure`, exact maxima);
   every piece beyond a tolerance gets a knot at its time midpoint, and step
   2 is repeated with those knots (at most :data:`MAX_ROUNDS` times).
4. Tool speed.  The spline follows the profile closely but not exactly: its
   tool speeds are measured every :data:`CHECK_PERIOD` (``|J(q) qdot|`` from
   the spline's joint positions and velocities, :class:`ToolRates`; every
   local maximum refined by golden-section search; the trial splines of
   step 2 are sampled the same way, :data:`TOOL_SPEED_PIECE_SAMPLES` per piece) and
   the spline is slowed down uniformly by the largest ratio to
   its limit when one exceeds it (a uniform slow-down divides every speed by
   its factor and keeps the v/a/j limits).
5. The third-order profile (before step 4's check, and after it).  With plan()'s
   ``speed_profile`` "time_optimal" the spline is timed again along its own
   path (:func:`planning.path_following.time_optimal.retime_path`, the tool speeds rows of
   the profile) and kept when shorter with its tool within the tolerances
   and its joints within their position limits.
   The default tries the same when its spline, checked by step 4, keeps
   the tool below :data:`AT_SPEED` of every tool speed limit (a piece's
   jerk or acceleration slows the whole spline down and ``_unbound``'s
   splitting did not help, or step 4 slowed it down for the torque or the
   tool acceleration) although the joints' v/a
   profile along the path, rounded by a jerk ramp, reaches it
   (:func:`_speed_reachable`), the plan lasts at most
   :data:`RETIME_BELOW_SPEED_SECONDS` and nothing smooths it (no
   ``vibration_frequency``), unless :data:`RETIME_BELOW_SPEED` is False; and
   likewise when step 4 slowed the whole spline down for the tool
   acceleration (where lines meet: the profile slows the tool there alone).
   The new spline, checked by step 4 too, is kept when it is shorter than
   the checked plan, within the tolerances (and the position limits) and
   takes the tool to that share of a limit; the plan then says so
   (``optimizer['speed_profile_reason']``, :data:`BELOW_SPEED`).

Between two samples of step 4 the speed cannot rise above its refined local
maxima: a maximum is found where the samples bracket it; one that lies
between two samples without being bracketed would need the speed to rise
and fall again within one period, i.e. a tool acceleration of order
``v / CHECK_PERIOD``, far beyond what the joint limits allow.
"""

from dataclasses import dataclass, replace
import math

import numpy as np

from .golden_search import CHECK_MAXIMA, CHECK_STEPS, golden_maxima, sampled_maxima
from .path_deviation import tolerance_excess
from .refinement_time import SKIPPED
from .tool_acceleration import (acceleration_factor, peak_tool_acceleration, PieceAccelerations,
                                ToolCurve)
from .tool_kinematics import frame_chain, has_transforms, refused_pose, start_walk
from ..planning.constraints import ToolAcceleration, ToolSpeed
from ..planning.constraints.torque import (CHECK_PERIOD, check_times, checked_slow_down,
                                           uniform_slow_down)
from ..planning.path_following.path_timing import (JointPathSamples, midpoint_fractions,
                                                   plan_along_path, rescaled)
from ..planning.path_following.time_optimal import NO_TIME_OPTIMAL_SPLINE, retime_path
from ..planning.planner import within_position_limits
from ..planning.speed_profile.averaged_timing import AveragedTiming
from ..planning.speed_profile.path_velocity import path_position, traversal_times
from ..robot import rotations as rot

# Path length [m] that one radian of tool rotation counts for in s.
ANGLE_LENGTH = 0.1
# Largest spacing of the path samples [m of s] along an edge.
SAMPLE_SPACING = 0.01
# Extra samples towards each waypoint, at SAMPLE_SPACING / 2, / 4, ...
CORNER_SAMPLES = 5
# Corner blends (CornerBlends): the share of the position tolerance a blend
# may use (the spline's own deviation has the rest), the share of each edge
# it may take, and the turns blended [rad] (a turn back on itself is not).
BLEND_SHARE = 0.5
BLEND_EDGE_SHARE = 0.45
MIN_BLEND_TURN = 1e-6
MAX_BLEND_TURN = math.radians(60.0)
# Rounds of knot insertion (step 3).
MAX_ROUNDS = 10
# The central-difference half step [s] of the tool speed (checked every CHECK_PERIOD).
_DIFFERENCE_STEP = 1e-5
# Samples per spline piece of the tool speed seen by the timing's iteration
# (the 1 kHz check holds the limit).  bench_tool_lines' seams and 40 random
# line sets got the same shares and durations (within 0.1 %) from 8 as from
# 12, in two thirds of the tool-rate evaluations.
TOOL_SPEED_PIECE_SAMPLES = 8
# The profile aims at this share of a tool speed limit: the spline follows it
# within a few tenths of a percent on the lines, so the last step's uniform
# slow-down stays below the 1 % that "at the programmed speed" allows.
SPEED_MARGIN = 0.998
# Most knots per edge (inner knots plus its waypoint) of the first spline, and
# the shortest piece [s]: knots every 30 ms at most follow a speed ramp.
EDGE_START_KNOTS = 64
MIN_PIECE = 0.03
# Rounds of splitting the pieces that slow a tool-speed line down (_unbound).
SPEED_ROUNDS = 4
# Iterations of the timing after a round of _unbound (warm-started).
UNBOUND_ITERATIONS = 15
# A tool at this share of its speed limit or more runs at its programmed
# speed: speed_share counts it, and _unbound splits pieces until the top
# speed reaches it (doc/tool_paths.md, "Where the constants come from").
AT_SPEED = 0.99
# The profile aims at this share of a tool acceleration limit: the piece
# factors and the final check hold the limit itself.
ACCELERATION_MARGIN = 0.99
# Step 5: a default plan whose own timing leaves the tool below AT_SPEED of its
# speed limits everywhere, where the joints' rounded v/a profile reaches it, is timed
# again by the third-order profile (False: never).  On 22 such line sets (UR5
# and Panda, 0.2-0.5 m/s, j = 10-30 a; the tool at 0.91-0.99 v) the tool then
# reached 0.99-1.00 v, in 0.86-0.99 of the time (median 0.956), shaking a 4 Hz
# mode more: peak 1.23 times, residual 1.38 times (medians).
RETIME_BELOW_SPEED = True
# ... on plans of at most this duration [s]: the profile's LPs grow with it
# (seams of 3-13 s took 85-190 ms more; a 43 s plan of 60 lines 1 s more).
RETIME_BELOW_SPEED_SECONDS = 20.0
# Trajectory.optimizer['speed_profile_reason'] of such a plan.
BELOW_SPEED = ("the lines' own timing left the tool below 99 % of its speed limit: timed "
               'again by the third-order profile')
# ... of a plan step 4 slowed down uniformly for a tool acceleration limit alone:
# the whole plan slowed for its corners took 2.08 times the profile's time on a
# UR5 circle at 0.3 m/s^2 (helper-92).
SLOWED_FOR_ACCELERATION = ('step 4 slowed the whole plan down for max_tool_acceleration: '
                           'timed again by the third-order profile')


class LineUnreachable(ValueError):
    """The inverse kinematics of line ``edge`` (from waypoint ``edge``) failed at ``pose``."""

    def __init__(self, edge, pose, reason):
        """Record the edge, the pose and the kinematics' reason."""
        self.edge, self.pose, self.reason = edge, pose, reason
        super().__init__(f'line {edge} leaves the reach of the arm: {reason}')


class LineOutOfTolerance(ValueError):
    """Line ``edge`` (from waypoint ``edge``) stays out of the tolerances: ``reason`` says how."""

    def __init__(self, edge, reason):
        """Record the edge and the reason."""
        self.edge, self.reason = edge, reason
        super().__init__(f'line {edge}: {reason}')


@dataclass(frozen=True)
class ToolLines:
    """What :func:`plan_tool_lines` found: the trajectory and its figures."""

    trajectory: object
    joints: np.ndarray
    inserted: int
    initial_duration: float
    initial_deviation: object
    deviation: object
    rounds: int
    samples: int
    tool_speed: float
    tool_angular_speed: float
    speed_share: float
    tool_acceleration: float = None


def edge_geometry(poses):
    """Return per edge (E,) the position length [m], the rotation angle [rad] and its s-length."""
    if poses.shape[1] == 3:
        length = np.hypot(*np.diff(poses[:, :2], axis=0).T)
        angle = np.abs(np.diff(poses[:, 2]))
    else:
        length = np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1)
        angle = rot.angle_between(poses[:-1, 3:], poses[1:, 3:])
    return length, angle, length + ANGLE_LENGTH * angle


def sample_edges(poses):
    """
    Return (s, edge fraction, edge) of every path sample (K,), and the waypoints' sample indices.

    Every edge is sampled at most :data:`SAMPLE_SPACING` apart in ``s`` and
    :data:`CORNER_SAMPLES` more times towards each of its ends.
    """
    _, _, ell = edge_geometry(poses)
    s0 = np.concatenate([[0.0], np.cumsum(ell)])
    parts, edges = [], []
    for e, length in enumerate(ell):
        count = max(1, int(math.ceil(length / SAMPLE_SPACING)))
        sigma = np.arange(count) / count
        near = SAMPLE_SPACING / length * 0.5 ** np.arange(1, CORNER_SAMPLES + 1)
        near = near[near < 0.5 / count]
        sigma = np.unique(np.concatenate([sigma, near, 1.0 - near]))
        parts.append(sigma)
        edges.append(np.full(sigma.size, e))
    sigma = np.concatenate(parts + [[1.0]])
    edge = np.concatenate(edges + [[len(ell) - 1]])
    s = s0[edge] + sigma * ell[edge]
    waypoints = np.concatenate([np.flatnonzero(sigma == 0.0), [s.size - 1]])
    return s, sigma, edge, waypoints


def interpolate_poses(poses, sigma, edge, blends=None):
    """
    Return the tool poses (K, P) at fractions ``sigma`` of edges ``edge``: lines and slerps.

    ``blends`` (:func:`corner_blends`) moves the positions near the blended
    corners off the lines (module docstring); the orientations stay on the slerps.
    """
    a, b = poses[edge], poses[edge + 1]
    out = a + sigma[:, None] * (b - a)
    if poses.shape[1] == 7:
        out[:, 3:] = rot.slerp(a[:, 3:], b[:, 3:], sigma)
    if blends is not None:
        dims = 2 if poses.shape[1] == 3 else 3
        out[:, :dims] += blends.offsets(sigma, edge)
    return out


class CornerBlends:
    """
    Smooth corners through the waypoints, within a share of the position tolerance.

    At a corner where the tool turns by ``theta`` between two edges that
    do not rotate the tool, the path leaves the first line ``r`` before the
    corner on its outer side, passes the corner exactly along the bisector
    of the two directions and rejoins the second line ``r`` after it: the
    offset from each line at distance ``u`` from the corner is
    ``tan(theta / 2) u (1 - u / r)**2`` (its slope at the corner turns each
    line's direction onto the bisector, the offset and its slope vanish at
    ``u = r``), at most ``4 / 27 tan(theta / 2) r``, which sets
    ``r`` from :data:`BLEND_SHARE` of the tolerance.  So the joint path has
    no kink there, and the tool need not stop.
    """

    def __init__(self, poses, tolerance):
        """Find the corners of ``poses`` (N, P) to blend within ``tolerance`` [m]."""
        dims = 2 if poses.shape[1] == 3 else 3
        self.dims = dims
        length, angle, _ = edge_geometry(poses)
        safe = np.where(length > 0.0, length, 1.0)
        direction = np.diff(poses[:, :dims], axis=0) / safe[:, None]
        n_edges = length.size
        self.radius = np.zeros(n_edges + 1)
        self.slope = np.zeros(n_edges + 1)
        self.inside_in = np.zeros((n_edges + 1, dims))
        self.inside_out = np.zeros((n_edges + 1, dims))
        self.length = length
        if not math.isfinite(tolerance):
            return
        for k in range(1, n_edges):
            d1, d2 = direction[k - 1], direction[k]
            cosine = float(np.clip(d1 @ d2, -1.0, 1.0))
            theta = math.acos(cosine)
            if not (MIN_BLEND_TURN < theta < MAX_BLEND_TURN) or angle[k - 1] > 1e-12 or \
                    angle[k] > 1e-12 or min(length[k - 1], length[k]) <= 0.0:
                continue
            slope = math.tan(0.5 * theta)
            radius = BLEND_SHARE * tolerance / (4.0 / 27.0 * slope)
            self.radius[k] = min(radius, BLEND_EDGE_SHARE * length[k - 1],
                                 BLEND_EDGE_SHARE * length[k])
            self.slope[k] = slope
            sine = math.sin(theta)
            self.inside_in[k] = (d2 - cosine * d1) / sine
            self.inside_out[k] = (cosine * d2 - d1) / sine

    def stretch(self, sigma, edge):
        """Return |dp/du| (K,) at ``sigma`` of ``edge``: sqrt(1 + offset slope**2) in a blend."""
        out = np.ones(sigma.size)
        for u, corner in (((1.0 - sigma) * self.length[edge], edge + 1),
                          (sigma * self.length[edge], edge)):
            r = self.radius[corner]
            near = (r > 0.0) & (u < r)
            if np.any(near):
                x = u[near] / r[near]
                slope = self.slope[corner][near] * (1.0 - x) * (1.0 - 3.0 * x)
                out[near] = np.hypot(1.0, slope)
        return out

    def offsets(self, sigma, edge):
        """Return how far (K, dims) the samples at ``sigma`` of ``edge`` leave the lines."""
        out = np.zeros((sigma.size, self.dims))
        to_end = (1.0 - sigma) * self.length[edge]
        from_start = sigma * self.length[edge]
        for u, corner, inside in ((to_end, edge + 1, self.inside_in),
                                  (from_start, edge, self.inside_out)):
            r = self.radius[corner]
            near = (r > 0.0) & (u < r)
            if not np.any(near):
                continue
            rr = r[near]
            size = self.slope[corner][near] * u[near] * (1.0 - u[near] / rr) ** 2
            out[near] -= size[:, None] * inside[corner][near]
        return out


class _EdgeRates:
    """The tool's speed per unit path speed along the path: the ToolSpeed tangents."""

    def __init__(self, poses, edge_s, blends=None):
        length, angle, ell = edge_geometry(poses)
        self.edge_s = edge_s
        self.ell = ell
        self.linear = length / ell
        self.angular = angle / ell
        self.blends = blends

    def _at(self, s, rate, blended=False):
        out = None
        # At a waypoint both edges meet: the larger rate holds.
        for side in ('right', 'left'):
            e = np.clip(np.searchsorted(self.edge_s, s, side=side) - 1, 0, rate.size - 1)
            value = rate[e]
            if blended and self.blends is not None:
                sigma = np.clip((s - self.edge_s[e]) / self.ell[e], 0.0, 1.0)
                value = value * self.blends.stretch(sigma, e)
            out = value if out is None else np.maximum(out, value)
        return out[:, None]

    def linear_tangent(self, path):
        """Return |dp/ds| (M + 1, 1) at the grid points (longer in the corner blends)."""
        return self._at(path.s, self.linear, blended=True)

    def angular_tangent(self, path):
        """Return |dtheta/ds| (M + 1, 1) at the grid points."""
        return self._at(path.s, self.angular)


def tool_speeds(traj, kinematics, period=CHECK_PERIOD, differences=False):
    """
    Return the largest tool (linear [m/s], angular [rad/s]) speed of ``traj``, and the samples.

    The speeds through the tool Jacobian (or with ``differences`` by central
    differences of the forward kinematics) at every ``period``, the largest
    local maxima refined by golden-section search (module docstring).
    """
    t = check_times(traj.duration, period, 'the tool speed')
    if not differences:
        kinematics = ToolRates(kinematics)
    sampled = _speeds(traj, kinematics, t, differences)
    lo, hi, kind = [], [], []
    for k, values in enumerate(sampled):
        below, above = sampled_maxima(values, CHECK_MAXIMA)
        lo.append(t[below])
        hi.append(t[above])
        kind.append(np.full(below.size, k))
    lo, hi, kind = np.concatenate(lo), np.concatenate(hi), np.concatenate(kind)

    def value(times):
        linear, angular = _speeds(traj, kinematics, times, differences)
        return np.where(kind == 0, linear, angular)

    _, best = golden_maxima(value, lo, hi, CHECK_STEPS)
    return (max(float(np.max(sampled[0])), float(np.max(best[kind == 0], initial=0.0))),
            max(float(np.max(sampled[1])), float(np.max(best[kind == 1], initial=0.0))),
            sampled[0])


def _speeds(traj, kinematics, times, differences=False):
    """
    Return the tool's linear and angular speed at ``times``.

    Through the tool Jacobian (``kinematics`` a :class:`ToolRates`) from
    the spline's joint positions and velocities, or with ``differences`` by
    central differences of the forward kinematics (an independent check, as
    the benchmark's).
    """
    if not differences:
        return kinematics(traj.evaluate(times), traj.evaluate(times, 1))
    h = _DIFFERENCE_STEP
    late, early = np.minimum(times + h, traj.duration), np.maximum(times - h, 0.0)
    span = late - early
    return _difference(kinematics, traj.evaluate(early), traj.evaluate(late), span)


def _difference(kinematics, before, after, span):
    """Return the tool's (linear, angular) speed between joints ``before`` and ``after``."""
    if has_transforms(kinematics):
        p0, m0 = kinematics.forward_transform(before)
        p1, m1 = kinematics.forward_transform(after)
        d = np.einsum('...ji,...jk->...ik', m0, m1)
        cosine = 0.5 * (d[..., 0, 0] + d[..., 1, 1] + d[..., 2, 2] - 1.0)
        sine = 0.5 * np.sqrt((d[..., 2, 1] - d[..., 1, 2]) ** 2
                             + (d[..., 0, 2] - d[..., 2, 0]) ** 2
                             + (d[..., 1, 0] - d[..., 0, 1]) ** 2)
        return (np.linalg.norm(p1 - p0, axis=-1) / span, np.arctan2(sine, cosine) / span)
    a = np.asarray(kinematics.forward(after))
    b = np.asarray(kinematics.forward(before))
    if a.shape[-1] == 3:
        return (np.hypot(a[..., 0] - b[..., 0], a[..., 1] - b[..., 1]) / span,
                np.abs(a[..., 2] - b[..., 2]) / span)
    angle = rot.angle_between(b[..., 3:].reshape(-1, 4), a[..., 3:].reshape(-1, 4))
    return (np.linalg.norm(a[..., :3] - b[..., :3], axis=-1) / span,
            angle.reshape(a.shape[:-1]) / span)


class ToolRates:
    """
    The tool's linear and angular speed at joints ``q`` moving at ``qdot``: ``|J(q) qdot|``.

    For a :class:`frame_chain.FrameChain` tool (:class:`ModelKinematics`)
    its one pass along the chain (:meth:`frame_chain.FrameChain.speeds`):
    about a third of the cost of the two forward kinematics and the relative
    rotation of central differences (4000 configurations of the UR5 and the
    Panda: 1.7-2.1 ms against 5.4-6.1 ms), and no difference error.  Other
    kinematics (the planar arm) fall back to central differences of their
    forward kinematics.
    """

    def __init__(self, kinematics):
        """Keep the chain of ``kinematics`` (None: central differences)."""
        self.kinematics = kinematics
        self.chain = frame_chain(kinematics)

    def __call__(self, q, qdot):
        """Return the linear [m/s] and angular [rad/s] speed (...,) at ``q``, ``qdot`` (..., n)."""
        if self.chain is not None:
            return self.chain.speeds(q, qdot)
        h = _DIFFERENCE_STEP
        q, qdot = np.asarray(q, float), np.asarray(qdot, float)
        return _difference(self.kinematics, q - h * qdot, q + h * qdot, 2.0 * h)


def plan_tool_lines(edge_poses, kinematics, limits, measure, tolerances, max_tool_speed=0.0,
                    max_tool_angular_speed=0.0, max_tool_acceleration=0.0, windows=(),
                    max_inserted=None, torque=None, time_optimal=False,
                    vibration_frequency=0.0, position_limits=(None, None), clock=None):
    """
    Return the :class:`ToolLines` of the tool path through ``edge_poses`` (module docstring).

    ``edge_poses`` (N, P) are the distinct tool waypoints, ``limits`` the
    :class:`planning.JointLimits`, ``measure(traj, segment_edges)`` the
    :class:`path_deviation.Deviation` of a trajectory whose segments lie on the
    given edges, ``tolerances`` (position, orientation), inf for unchecked.
    Speeds 0 mean no limit; so does ``max_tool_acceleration`` 0, the
    limit [m/s^2] of the tool frame origin's linear acceleration
    (:mod:`tool_acceleration`: a constraint of the profile, a factor of
    every piece, and a 1 kHz check at the end).  ``torque`` (a
    :class:`planning.constraints.torque.TorqueLimit`) adds the joint torque: one more
    constraint of the timing, one more factor of every piece, and a 1 kHz
    check at the end (the spline is slowed down uniformly when it needs
    it).  ``time_optimal`` (plan()'s ``speed_profile``): the spline found is
    then timed again along its own path by the third-order profile
    (:func:`planning.path_following.time_optimal.retime_path`, every limit above a row or a
    factor of it), and kept when its tool stays within the tolerances
    (step 5); ``vibration_frequency`` [Hz] (0: none): that profile also
    cancels the ringing of a mode at it after the stop
    (:mod:`planning.speed_profile.residual_vibration`).  ``position_limits`` (low, high),
    (n,) arrays or both None: step 5's spline is kept only within them
    (the caller checks the plan returned).  ``clock``, a
    :class:`refinement_time.RefinementClock` (None: no limit), is read
    before every round of knot insertion.  ValueError
    when the inverse kinematics fails, no spline meets the limits, or the
    tolerances are not reached; :class:`refinement_time.RefinementTimeout`
    when the clock's time is up first.
    """
    s, sigma, edge, waypoint_index = sample_edges(edge_poses)
    # One continuous walk through every sample (a redundant arm's joints
    # depend on the walk: none may come from an earlier one).
    start_walk(kinematics)
    blends = CornerBlends(edge_poses, tolerances[0])
    samples = interpolate_poses(edge_poses, sigma, edge, blends)
    try:
        with np.errstate(over='ignore', invalid='ignore'):
            joints = np.asarray(kinematics.inverse(samples), float)
    except ValueError as exc:
        k, reason = refused_pose(exc)
        if k is None:
            # A kinematics that does not say which pose: the first it refuses alone.
            k, reason = _first_refused(kinematics, samples)
            if k is None:
                raise
        raise LineUnreachable(int(edge[k]), samples[k], reason or str(exc)) from None
    if joints.shape[0] != s.size or not np.all(np.isfinite(joints)):
        raise ValueError('inverse kinematics of the path samples failed')
    rates = _EdgeRates(edge_poses, s[waypoint_index], blends)
    constraints = []
    if max_tool_speed:
        constraints.append(ToolSpeed(max_tool_speed * SPEED_MARGIN, rates.linear_tangent))
    if max_tool_angular_speed:
        constraints.append(ToolSpeed(max_tool_angular_speed * SPEED_MARGIN, rates.angular_tangent))
    check = _PieceSpeeds(kinematics, max_tool_speed, max_tool_angular_speed)
    speeds = bool(constraints)
    factors = [check] if speeds else []
    if max_tool_acceleration:
        constraints.append(ToolAcceleration(max_tool_acceleration * ACCELERATION_MARGIN,
                                            ToolCurve(kinematics)))
        factors.append(PieceAccelerations(kinematics, max_tool_acceleration))
    if torque is not None:
        constraints.append(torque.constraint())
        factors.append(torque.piece_factors)
    path = JointPathSamples(s, joints, waypoint_index, limits, constraints, windows,
                            _joined(factors), EDGE_START_KNOTS, MIN_PIECE, round_corners=speeds)
    timing = plan_along_path(path, limits)
    initial = None
    inserted, rounds = 0, 0
    budget = math.inf if max_inserted is None else max_inserted
    for rounds in range(1, MAX_ROUNDS + 1):
        traj = timing.trajectory
        piece_edges = np.repeat(np.arange(len(timing.fractions)),
                                [f.size for f in timing.fractions])
        deviation = measure(_Pieces(traj), piece_edges)
        if initial is None:
            initial = (deviation, traj.duration)
        excess = tolerance_excess(deviation, tolerances)
        bad = np.flatnonzero(excess > 1.0)
        if bad.size == 0:
            break
        if clock is not None:
            clock.check(lambda: f'{inserted} knots inserted along the tool lines, and the tool '
                                f'is still {float(np.max(excess)):.3g} times its tolerance')
        if inserted + bad.size > budget:
            raise LineOutOfTolerance(
                int(piece_edges[bad[np.argmax(excess[bad])]]),
                f'the tool path needs more than max_inserted = {max_inserted} knots to stay '
                f'within the tolerances ({float(np.max(excess)):.3g} times them there)')
        fractions = midpoint_fractions(timing.fractions, bad)
        inserted += int(sum(f.size for f in fractions) - sum(f.size for f in timing.fractions))
        timing = plan_along_path(path, limits, fractions, timing.local)
    else:
        raise LineOutOfTolerance(
            int(piece_edges[np.argmax(excess)]),
            f'the tool path is still {float(np.max(excess)):.3g} times its tolerance after '
            f'{MAX_ROUNDS} rounds of knot insertion')
    skipped = []        # the optional steps skipped once the clock's time is up

    def late():
        if clock is not None and clock.expired():
            skipped.append(True)
            return True
        return False

    if speeds and not late():
        timing, more, measured = _unbound(timing, path, limits, check, measure, tolerances)
        inserted += more
        if measured is not None:
            deviation, piece_edges = measured
    traj = timing.trajectory
    speed_limits = (max_tool_speed, max_tool_angular_speed)
    # Step 5: the third-order profile when asked for ...
    if time_optimal and not late():
        traj, measured = _retimed(traj, path, limits, kinematics, constraints, vibration_frequency,
                                  speed_limits, measure, tolerances, position_limits)
        if measured is not None:
            deviation, piece_edges = measured
    final = _checked(traj, kinematics, speed_limits, max_tool_acceleration, torque)
    # ... or when the lines' own timing, checked, leaves the tool below its speed, or
    # step 4 slowed all of it down for the tool acceleration (at its corners).
    eligible = (RETIME_BELOW_SPEED and not time_optimal and not windows
                and not vibration_frequency and final.traj.duration <= RETIME_BELOW_SPEED_SECONDS)
    accelerating = eligible and final.accelerated
    below = eligible and speeds and final.top < AT_SPEED
    if (accelerating or below) and not late() and (
            accelerating or _speed_reachable(path, constraints, limits)):
        retimed, measured = _retimed(traj, path, limits, kinematics, constraints, 0.0,
                                     speed_limits, measure, tolerances, position_limits,
                                     final.traj.duration)
        if measured is not None:
            again = _checked(retimed, kinematics, speed_limits, max_tool_acceleration, torque)
            if ((again.top >= AT_SPEED or accelerating)
                    and again.traj.duration < final.traj.duration):
                again.traj.optimizer['speed_profile_reason'] = (BELOW_SPEED if below
                                                                else SLOWED_FOR_ACCELERATION)
                final, (deviation, piece_edges) = again, measured
    if skipped:
        final.traj.optimizer['refinement_time'] = SKIPPED
    share = 0.0
    if max_tool_speed:
        # By length: every sample weighs the distance the tool covers there.
        share = float(np.sum(final.sampled[final.sampled >= AT_SPEED * max_tool_speed])
                      / np.sum(final.sampled))
    return ToolLines(final.traj, joints[waypoint_index], inserted, initial[1], initial[0],
                     _per_edge(deviation, piece_edges, len(edge_poses) - 1, final.slow),
                     rounds, int(s.size), final.linear, final.angular, share,
                     final.acceleration)


@dataclass(frozen=True)
class _Checked:
    """Step 4's trajectory and figures: the tool speeds [m/s, rad/s] and acceleration reached."""

    traj: object
    slow: float
    linear: float
    angular: float
    sampled: np.ndarray
    acceleration: float
    top: float
    # Step 4 slowed it down for the tool acceleration (its factor the largest of the tool's).
    accelerated: bool = False


def _checked(traj, kinematics, speed_limits, max_tool_acceleration, torque):
    """
    Return the :class:`_Checked` of ``traj``: step 4, slowed down uniformly where it needs it.

    ``top`` is the largest ratio of a tool speed to its limit (0 without a
    limit), after the slow-down.
    """
    max_tool_speed, max_tool_angular_speed = speed_limits
    linear, angular, sampled = tool_speeds(traj, kinematics)
    acceleration = peak_tool_acceleration(traj, kinematics) if max_tool_acceleration else None
    speed_factor = max(linear / max_tool_speed if max_tool_speed else 0.0,
                       angular / max_tool_angular_speed if max_tool_angular_speed else 0.0)
    acceleration_need = acceleration_factor(acceleration, max_tool_acceleration)
    factor = max(speed_factor, acceleration_need)
    torque_check = checked = None
    slow = uniform_slow_down(factor)
    if torque is not None:
        # Slowed down, the torque is bounded with the gravity's and the
        # dynamic part's excesses between samples apart (TorqueCheck).
        torque_check = torque.check(traj)
        checked = torque_check.needs()
        slow = torque_check.slow_down_with(factor, checked[0])
    if slow > 1.0:
        # Rest to rest, the spline through the same knots on pieces f times
        # longer is this one slowed down by f: every tool speed divided by
        # f, so no second check (it cost 14 ms on the Panda seam); nor of
        # the torque, g + d / f**2 at the same path points (its samples are
        # those of a period f times CHECK_PERIOD), unless the inverse
        # dynamics does not scale so (checked_slow_down: slowed more).
        if torque_check is None:
            traj = rescaled(traj, slow)
        else:
            traj, slow, checked = checked_slow_down(torque, torque_check, traj, slow, rescaled)
        linear, angular, sampled = (value / slow for value in (linear, angular, sampled))
        if acceleration is not None:
            acceleration /= slow * slow
    if checked is not None:
        traj.torque_factor, traj.torque_ratios = checked
    top = max(linear / max_tool_speed if max_tool_speed else 0.0,
              angular / max_tool_angular_speed if max_tool_angular_speed else 0.0)
    return _Checked(traj, max(slow, 1.0), linear, angular, sampled, acceleration, top,
                    slow > 1.0 and acceleration_need > 1.0 and acceleration_need >= speed_factor)


def _within(traj, position_limits):
    """Whether ``traj`` stays within ``position_limits`` (low, high; both None: no limits)."""
    try:
        within_position_limits(traj, *position_limits)
    except ValueError:
        return False
    return True


def _speed_reachable(path, constraints, limits):
    """
    Whether the joints' v/a profile, rounded by a jerk ramp, takes the tool to :data:`AT_SPEED`.

    The fastest profile along ``path`` under its own constraints (the
    joints' velocity and acceleration, the tool speeds at
    :data:`SPEED_MARGIN`, any more), its path position averaged over a
    window of one jerk ramp (the longest ``a_j / j_j``): a joint
    speeding up alone at its acceleration limit does exactly that under
    its jerk limit (the S-curve of the trapezoid), so a speed the profile
    holds for less than a ramp is out of reach; elsewhere an estimate (the
    joints' ramps overlap, and the profile's ends already ramp from rest at
    the jerk, so short first and last edges lean out of reach).  Where the
    averaged tool speed stays below :data:`AT_SPEED` of every tool speed
    limit, step 5 is not tried: a limit meant as a cap far above what the
    arm does, or one the jerk keeps the tool from.  On 160 random line sets
    (UR5, Panda, 0.05-0.9 m/s) this left out 11 of the 18 tries that would
    not have been kept, and none of the 13 kept; on 550 more (helper-25)
    none of the retimes it leaves out would have been kept.
    """
    x = path.limits.profile(np.ones(path.s.size))
    times = traversal_times(x, path.steps)
    finite = np.isfinite(limits.jerk)
    ramp = float(np.max(limits.acceleration[finite] / limits.jerk[finite], initial=0.0))
    # A ramp under the 1 kHz check's period rounds nothing it would see.
    if ramp >= CHECK_PERIOD and np.all(np.isfinite(times)):
        # The average over [t - ramp, t] (AveragedTiming) moves at (s(t) - s(t - ramp)) / ramp;
        # its pieces meet at the grid's times and one ramp later.
        t = np.concatenate([times, times + ramp])
        end = times[-1]
        speed = (path_position(times, x, path.s, np.minimum(t, end))
                 - path_position(times, x, path.s, np.clip(t - ramp, 0.0, end))) / ramp
        at = AveragedTiming(times, x, path.s, (ramp,)).position_at(t)
    else:
        speed, at = np.sqrt(np.maximum(x, 0.0)), path.s
    for constraint in constraints:
        if isinstance(constraint, ToolSpeed):
            cap = np.sqrt(constraint.squared_speed_limit(path.gridded))
            with np.errstate(divide='ignore', invalid='ignore'):
                share = SPEED_MARGIN * speed / np.interp(at, path.s, cap)
            if np.any(share >= AT_SPEED):
                return True
    return False


def _retimed(traj, path, limits, kinematics, constraints, vibration_frequency, speeds, measure,
             tolerances, position_limits, below=None):
    """
    Return (``traj`` timed by the third-order profile, its (deviation, piece edges)).

    Step 5 with ``time_optimal``: the tool speed limits become rows of the
    profile along the spline's own path (``|J(q) q'| sdot``, with
    :class:`ToolRates`, at :data:`SPEED_MARGIN` like the timing's), the
    tool acceleration and the torque keep their constraint objects, and
    the path's piece factors are step 4's.  The new spline is kept when it
    is shorter, its tool within the tolerances and its joints within
    ``position_limits`` (it can overshoot the lines' ends by ~1e-7 rad,
    where the lines' own timing touches a limit); otherwise (``traj``,
    None), and unless ``traj`` was simply the shorter, the trajectory says
    why (``speed_profile_skipped``).  ``below``: the profile was not asked
    for but is tried because ``traj``'s tool stays below its speed, and the
    new spline is kept when shorter than ``below`` [s] (``traj`` slowed down
    by step 4); ``traj`` kept then says nothing (the caller checks the new
    spline's speed after its own step 4).
    """
    rates = ToolRates(kinematics)
    # The lines' ToolSpeed tangents belong to the lines' path coordinate: the
    # same limits as rows along the spline's own path.
    retime_constraints = [c for c in constraints if not isinstance(c, ToolSpeed)]
    for which, speed in enumerate(speeds):
        if speed:
            retime_constraints.append(ToolSpeed(speed * SPEED_MARGIN, _rate_of(rates, which)))
    retimed = retime_path(traj, limits, retime_constraints, path.piece_factors,
                          vibration_frequency)
    longest = traj.duration if below is None else below
    if retimed is not None and not retimed.duration < longest:
        return traj, None       # the lines' own timing is the shorter: no failure
    skipped = NO_TIME_OPTIMAL_SPLINE
    if retimed is not None:
        edges = np.searchsorted(retimed.waypoint_times, retimed.breakpoints[:-1],
                                side='right') - 1
        deviation = measure(_Pieces(retimed), edges)
        excess = tolerance_excess(deviation, tolerances)
        if not np.all(excess <= 1.0):
            skipped = 'the time-optimal spline leaves the tool tolerances'
        elif not _within(retimed, position_limits):
            skipped = 'the time-optimal spline leaves the position limits'
        else:
            return retimed, (deviation, edges)
    if below is None:
        traj.optimizer = dict(traj.optimizer or {}, speed_profile_skipped=skipped)
    return traj, None


def _rate_of(rates, which):
    """Return tangent(path): the tool's linear (0) or angular (1) speed per unit path speed."""
    def tangent(path):
        return np.asarray(rates(path.positions, path.first)[which], float)[:, None]
    return tangent


def _per_edge(deviation, piece_edges, n_edges, time_scale):
    """
    Return the deviation per edge from the one per piece (``piece_edges``: each piece's edge).

    The last measure was of the kept spline piece by piece; a slow-down by
    ``time_scale`` moves along the same curve, so the figures stay and only
    their times scale.  Measuring again per edge (as before) cost a third
    of the measuring time.
    """
    out = {}
    for name in ('position', 'orientation'):
        values = getattr(deviation, name)
        times = getattr(deviation, name + '_time')
        best = np.full(n_edges, -np.inf)
        when = np.zeros(n_edges)
        for p in np.argsort(values, kind='stable'):  # the largest of each edge last
            best[piece_edges[p]] = values[p]
            when[piece_edges[p]] = times[p] * time_scale
        out[name], out[name + '_time'] = best, when
    return replace(deviation, **out)


def _joined(factors):
    """Return one piece-factor function of several ((P, k) each, side by side), or None."""
    if not factors:
        return None
    if len(factors) == 1:
        return factors[0]

    def joined(coeffs, pieces):
        return np.concatenate([f(coeffs, pieces) for f in factors], axis=1)
    return joined


def _unbound(timing, path, limits, check, measure, tolerances):
    """
    Return (timing, knots added, measured): the pieces that slow a tool line down split in two.

    The third value is (deviation, piece edges) of the timing returned when
    it is not ``timing`` itself, else None.

    A rest-to-rest spline is slowed down as a whole by its largest factor,
    so a piece near a stop that needs 1 % more time (its jerk) takes 1 % off
    the tool speed along every line.  While the tool's top speed on the
    pieces stays below :data:`AT_SPEED` of its limits (where
    :attr:`ToolLines.speed_share` would count none of the path), the pieces
    whose joint factor binds get a knot at their time midpoint (a spline
    with more knots there follows the stop more closely), at most
    :data:`SPEED_ROUNDS` times; a round is kept when the spline gets
    shorter and stays within the tolerances.
    """
    added, measured = 0, None
    for _ in range(SPEED_ROUNDS):
        traj = timing.trajectory
        pieces = np.diff(traj.breakpoints)
        if np.max(check(traj.coefficients, pieces)) >= AT_SPEED:
            break
        joint = np.max(traj.limit_ratios() ** (1.0 / np.arange(1, 4)), axis=(1, 2))
        binding = np.flatnonzero(joint >= 1.0 - 1e-3)
        fractions = midpoint_fractions(timing.fractions, binding)
        try:
            found = plan_along_path(path, limits, fractions, timing.local, UNBOUND_ITERATIONS)
        except ValueError:
            break
        if not found.trajectory.duration < traj.duration:
            break
        piece_edges = np.repeat(np.arange(len(found.fractions)),
                                [f.size for f in found.fractions])
        deviation = measure(_Pieces(found.trajectory), piece_edges)
        if np.any(deviation.position > tolerances[0]) or \
                np.any(deviation.orientation > tolerances[1]):
            break
        added += int(sum(f.size for f in found.fractions) - sum(f.size for f in timing.fractions))
        timing, measured = found, (deviation, piece_edges)
    return timing, added, measured


def _first_refused(kinematics, samples):
    """Return (index, reason) of the first sample the kinematics refuses alone, or (None, None)."""
    for k, pose in enumerate(samples):
        try:
            with np.errstate(over='ignore', invalid='ignore'):
                kinematics.inverse(pose[None, :])
        except ValueError as exc:
            return k, f'is unreachable ({exc})'
    return None, None


class _PieceSpeeds:
    """
    Tool speed over its limit per spline piece, from :data:`TOOL_SPEED_PIECE_SAMPLES` samples each.

    The samples include both ends of every piece; a piece's end is its
    successor's start (the spline is C4), so it is computed once.
    """

    def __init__(self, kinematics, linear, angular):
        self.rates = ToolRates(kinematics)
        self.limits = [(k, v) for k, v in enumerate((linear, angular)) if v]

    def __call__(self, coeffs, pieces):
        """Return (P, k): the largest sampled speed of each piece over each speed limit."""
        tau = pieces[:, None] * np.linspace(0.0, 1.0, TOOL_SPEED_PIECE_SAMPLES)[None, :-1]
        powers = tau[..., None] ** np.arange(6)
        q = np.einsum('psk,pkn->psn', powers, coeffs).reshape(-1, coeffs.shape[2])
        qd = np.einsum('psk,pkn->psn', powers[..., :5] * np.arange(1, 6), coeffs[:, 1:]
                       ).reshape(-1, coeffs.shape[2])
        end = pieces[-1] ** np.arange(6)
        q = np.vstack([q, end @ coeffs[-1]])
        qd = np.vstack([qd, (end[:5] * np.arange(1, 6)) @ coeffs[-1, 1:]])
        speeds = self.rates(q, qd)
        out = []
        for k, v in self.limits:
            sampled = speeds[k][:-1].reshape(pieces.size, TOOL_SPEED_PIECE_SAMPLES - 1)
            ends = speeds[k][TOOL_SPEED_PIECE_SAMPLES - 1::TOOL_SPEED_PIECE_SAMPLES - 1]
            out.append(np.maximum(np.max(sampled, axis=1), ends) / v)
        return np.stack(out, axis=1)


class _Pieces:
    """A trajectory seen piece by piece: its knots as the segments to measure."""

    def __init__(self, traj):
        self.evaluate = traj.evaluate
        self.breakpoints = traj.breakpoints
        self.waypoint_times = traj.breakpoints
