"""
The linear acceleration of the tool frame's origin, for ``max_tool_acceleration`` (issue 38).

The tool lines (:mod:`tool_lines`) hold a tool acceleration limit ``A`` in
three places, as they hold a tool speed:

1. Profile.  Along the joint path ``q(s)`` the tool's position ``p(q(s))``
   has the path derivatives ``p'`` and ``p''`` (:class:`ToolCurve`), and
   the tool's acceleration at path speed ``sdot`` and path acceleration
   ``sddot`` is ``p' sddot + p'' sdot**2``: second order in TOPP-RA's sense,
   the rows of :class:`planning.constraints.ToolAcceleration`.
2. Spline pieces.  The construction's C4 spline is sampled per piece
   (:class:`PieceAccelerations`) and a piece whose tool acceleration
   exceeds ``A`` gets the time factor ``sqrt(peak / A)``: a piece ``f``
   times slower has ``1 / f**2`` of its accelerations.
3. Check.  The final trajectory's tool acceleration is sampled every
   :data:`planning.constraints.torque.CHECK_PERIOD` and its largest local maxima are
   refined by golden-section search (:func:`peak_tool_acceleration`); a
   rest-to-rest spline over ``A`` is slowed down uniformly by
   ``sqrt(peak / A)``.

Everything comes from the forward kinematics alone, by central
differences: ``p(q(t + h)) - 2 p(q(t)) + p(q(t - h))`` over ``h**2`` in
time, and the same in ``s`` along the path.  Only the origin's linear
acceleration is limited, not the angular acceleration of the tool.
"""

import math

import numpy as np

from .golden_search import refined_peak
from .tool_kinematics import has_transforms
from ..planning.constraints.torque import CHECK_PERIOD, check_times

# The step [m of s] of p' and p'' along the joint path (ToolCurve): far below
# the path samples' finest spacing (0.3 mm near a corner), far above round-off.
CURVE_STEP = 1e-4
# The time step [s] of the second differences in time: round-off ~1e-8 m/s^2,
# the O(h**2) term below 1e-5 m/s^2 at a tool snap of 1e4 m/s^4.
TIME_STEP = 1e-4
# Samples per spline piece of the construction's piece factors (the 1 kHz
# check holds the limit; as the tool speed's TOOL_SPEED_PIECE_SAMPLES).
PIECE_SAMPLES = 8


def tool_positions(kinematics, joints):
    """Return the tool frame origin's positions (..., d) at ``joints`` (..., n): d = 2 or 3."""
    if has_transforms(kinematics):
        return np.asarray(kinematics.forward_transform(joints)[0], float)
    poses = np.asarray(kinematics.forward(joints), float)
    return poses[..., :2] if poses.shape[-1] == 3 else poses[..., :3]


class ToolCurve:
    """
    ``p'(s)`` and ``p''(s)`` of the tool position along a gridded joint path: ``derivatives``.

    The joint path at ``s +- delta`` is its Taylor polynomial
    ``q +- delta q' + delta**2 / 2 q''`` (the odd term cancels in both
    central differences, so both are second-order accurate in ``delta``).
    """

    def __init__(self, kinematics, step=CURVE_STEP):
        """Keep the kinematics and the step ``delta`` of the differences."""
        self.kinematics = kinematics
        self.step = step

    def __call__(self, path):
        """Return ``(p', p'')``, each (M + 1, d), at the grid points of ``path``."""
        h = self.step
        q, first, second = path.positions, path.first, path.second
        bend = 0.5 * h * h * second
        ahead = tool_positions(self.kinematics, q + h * first + bend)
        here = tool_positions(self.kinematics, q)
        behind = tool_positions(self.kinematics, q - h * first + bend)
        return (ahead - behind) / (2.0 * h), (ahead - 2.0 * here + behind) / (h * h)


def _second_difference(kinematics, before, here, after, h):
    """Return ``|p(after) - 2 p(here) + p(before)| / h**2`` (...,): the tool's acceleration."""
    stacked = tool_positions(kinematics, np.stack([before, here, after]))
    return np.linalg.norm(stacked[0] - 2.0 * stacked[1] + stacked[2], axis=-1) / (h * h)


def tool_accelerations(traj, kinematics, times, h=TIME_STEP):
    """Return the tool's acceleration [m/s^2] (K,) of ``traj`` at ``times`` (K,)."""
    times = np.asarray(times, float)
    return _second_difference(kinematics, traj.evaluate(times - h), traj.evaluate(times),
                              traj.evaluate(times + h), h)


def peak_tool_acceleration(traj, kinematics, period=CHECK_PERIOD):
    """
    Return the largest tool acceleration [m/s^2] of ``traj``: sampled, local maxima refined.

    Sampled every ``period``; the largest local maxima are refined in their
    brackets by golden-section search (:func:`golden_search.refined_peak`,
    :data:`~.golden_search.CHECK_MAXIMA` of them).  A polynomial spline's
    acceleration rises and falls between two samples only with a tool jerk of order
    ``A / period``: far beyond what the joint limits allow.
    """
    t = check_times(traj.duration, period, 'the tool acceleration')
    return refined_peak(lambda x: tool_accelerations(traj, kinematics, x), t,
                        tool_accelerations(traj, kinematics, t))


class PieceAccelerations:
    """
    Per spline piece, the time factor its tool acceleration needs: ``sqrt(peak / A)``.

    The peak of each piece is the largest of :data:`PIECE_SAMPLES` samples
    (both ends included), each by the second difference in time of a
    piece's polynomial.  A piece's end is its successor's start (the spline
    is C4): computed once, as the next piece's first sample.
    """

    def __init__(self, kinematics, max_acceleration):
        """Keep the kinematics and the limit ``A`` [m/s^2] (> 0)."""
        self.kinematics = kinematics
        self.max_acceleration = float(max_acceleration)

    def __call__(self, coeffs, pieces):
        """Return (P, 1): each piece's ``sqrt(peak / A)`` (coefficients (P, 6, n), ascending)."""
        h = TIME_STEP
        tau = pieces[:, None] * np.linspace(0.0, 1.0, PIECE_SAMPLES)[None, :-1]
        degree = np.arange(coeffs.shape[1])
        joints = [np.einsum('psk,pkn->psn', (tau + d)[..., None] ** degree, coeffs)
                  for d in (-h, 0.0, h)]
        sampled = _second_difference(self.kinematics, *joints, h)
        last = [((pieces[-1] + d) ** degree) @ coeffs[-1] for d in (-h, 0.0, h)]
        ends = np.append(sampled[1:, 0], _second_difference(self.kinematics, *last, h))
        peak = np.maximum(np.max(sampled, axis=1), ends)
        return np.sqrt(peak / self.max_acceleration)[:, None]


def acceleration_factor(peak, max_acceleration):
    """Return the uniform slow-down ``sqrt(peak / A)`` a peak asks (0 without a limit)."""
    return math.sqrt(peak / max_acceleration) if max_acceleration else 0.0
