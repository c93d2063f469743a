"""
How far a planned tool path leaves the straight lines between its tool waypoints.

:class:`PathMeasure` measures a trajectory against its edges and returns a
:class:`Deviation`; :func:`path_deviation` measures a finished
:class:`~.tool_paths.ToolPath` again.  Both the refinement of
:mod:`tool_paths` and the tool lines of :mod:`tool_lines` use it.

How the deviation between knots is bounded
------------------------------------------
The deviation is a smooth function of time on every segment.  It is sampled
on ``SEGMENT_GRID_POINTS`` points per segment (both knots included), and
every grid local maximum is refined by a vectorised golden-section search
over the bracket between its two grid neighbours (``GOLDEN_STEPS`` steps
shrink the bracket to 8e-3 of its width), so every maximum the grid brackets
is found to within about 1e-5 of its height (second order in the bracket).
Only grid maxima above a quarter of the tolerance are searched
(and the largest few, for an exact reported maximum): with 24 points per
segment the grid misses a smooth bump's height by well under 1 %, so a
bump below a quarter of the tolerance on the grid cannot exceed it.  A
maximum the grid does not bracket would have to sit between two grid points
and exceed the larger of them; since the distance to a segment is
1-Lipschitz in the tool position, it exceeds it by at most half the tool's
arc length between the two points (``grid_slack`` of :class:`Deviation`
reports half the largest chord between grid neighbours, a few millimetres on
the paper's triangle: that is the bound without the search, not the error of
the search).  On the paper's triangle a 1000-point grid per segment gives the
same maxima to 1e-9 m, and the tests check every result independently, by
forward kinematics of a much finer sampling.
"""

from dataclasses import dataclass

import numpy as np

from .golden_search import golden_maxima
from .tool_kinematics import has_transforms
from ..robot import rotations as rot

# Deviation samples per segment, both knots included (the docstring: why 24 suffice).
SEGMENT_GRID_POINTS = 24
# Golden-section steps on each bracket of two grid cells: 10 shrink it to
# 0.618**10 = 8e-3 of its width, and the maximum found is off by the square
# of that (second order; doc/tool_paths.md, "Where the constants come from").
GOLDEN_STEPS = 10
# Grid maxima searched: those above this fraction of the tolerance, and the
# largest few (so the reported maximum is exact even far below it).
REFINE_FRACTION = 0.25
ALWAYS_REFINED = 8
# Edges shorter than this [m] are pure rotations: parameterised by how far the
# tool has turned about the edge's axis, or by time where they turn less than
# MIN_TURN [rad] too (a stop in place).
MIN_EDGE_LENGTH = 1e-9
MIN_TURN = 1e-9


@dataclass(frozen=True)
class Deviation:
    """
    Largest deviation of the tool from its straight path, per trajectory segment.

    ``position`` [m] and ``orientation`` [rad] are arrays (S,), ``*_time`` the
    trajectory times [s] where they occur, ``grid_slack`` [m] half the largest
    tool chord between two grid points (see the module docstring).
    """

    position: np.ndarray
    orientation: np.ndarray
    position_time: np.ndarray
    orientation_time: np.ndarray
    grid_slack: float

    @property
    def max_position(self):
        """Return the largest position deviation [m] of the whole path."""
        return float(np.max(self.position))

    @property
    def max_orientation(self):
        """Return the largest orientation deviation [rad] of the whole path."""
        return float(np.max(self.orientation))


def _wrap(angle):
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


class PathMeasure:
    """
    Deviation of a planned trajectory's tool from the requested straight edges.

    ``traj``'s segment ``k`` lies on edge ``segment_edges[k]`` of ``edge_poses``;
    :meth:`deviation` measures it (the module docstring says how).
    """

    def __init__(self, traj, kinematics, edge_poses, segment_edges):
        self.traj = traj
        self.kinematics = kinematics
        self.segment_edges = segment_edges
        a, b = edge_poses[:-1], edge_poses[1:]
        self.spatial = edge_poses.shape[1] == 7
        dims = 3 if self.spatial else 2
        self.start = a[:, :dims]
        self.direction = b[:, :dims] - a[:, :dims]
        self.length2 = np.sum(self.direction**2, axis=1)
        if self.spatial:
            self.quat0 = a[:, 3:]
            self.quat1 = b[:, 3:]
            self._matrices = has_transforms(kinematics)
            # The slerp of edge e at s is R0 Rot(axis, s angle).
            turn = rot.multiply(rot.conjugate(self.quat0), self.quat1)
            turn = np.where(turn[:, :1] < 0.0, -turn, turn)
            sine = np.linalg.norm(turn[:, 1:], axis=1)
            self.angle = 2.0 * np.arctan2(sine, turn[:, 0])
            self.axis = turn[:, 1:] / np.where(sine > 1e-15, sine, 1.0)[:, None]
            if self._matrices:
                # Rodrigues' terms of the slerp.
                x, y, z = self.axis[:, 0], self.axis[:, 1], self.axis[:, 2]
                zero = np.zeros_like(x)
                self.skew = np.stack([np.stack([zero, -z, y], -1), np.stack([z, zero, -x], -1),
                                      np.stack([-y, x, zero], -1)], -2)
                self.skew2 = self.skew @ self.skew
                self.rot0 = rot.to_matrix(self.quat0)
        else:
            self.yaw0 = a[:, 2]
            self.dyaw = b[:, 2] - a[:, 2]
            self.angle = np.abs(self.dyaw)
        n_edges = len(a)
        first = np.searchsorted(segment_edges, np.arange(n_edges), side='left')
        last = np.searchsorted(segment_edges, np.arange(n_edges), side='right')
        # Segments run between the waypoints (knots of the tool path); a 555
        # optimal plan has inner knots between them too.
        self.edge_t0 = traj.waypoint_times[first]
        self.edge_t1 = traj.waypoint_times[last]

    def __call__(self, t, seg):
        """Position and orientation deviation (K,) at times ``t`` on segments ``seg``."""
        e = self.segment_edges[seg]
        if self.spatial:
            return self._spatial(t, e)
        pose = np.asarray(self.kinematics.forward(self.traj.evaluate(t)), dtype=float)
        p = pose[:, :2] - self.start[e]
        ab = self.direction[e]
        s_time = self._time_fraction(t, e)
        # On a pure rotation: how far the yaw has turned, unwrapped near the time's share.
        turned = s_time * self.dyaw[e]
        turned = turned + _wrap(pose[:, 2] - self.yaw0[e] - turned)
        s_turn = turned / np.where(self.angle[e] > 0.0, self.dyaw[e], 1.0)
        s = self._edge_parameter(p, s_time, s_turn, e)
        position = np.hypot(*(p - s[:, None] * ab).T)
        orientation = np.abs(_wrap(pose[:, 2] - self.yaw0[e] - s * self.dyaw[e]))
        return position, orientation, pose[:, :2]

    def _time_fraction(self, t, e):
        """Return the fraction of its edge's time at each time ``t`` (K,) on edges ``e``."""
        span = self.edge_t1[e] - self.edge_t0[e]
        return (t - self.edge_t0[e]) / np.where(span > 0.0, span, 1.0)

    def _edge_parameter(self, p, s_time, s_turn, e):
        """
        Where on its edge each tool point is, in [0, 1]: ``p`` (K, d) from the edge start.

        The projection on the edge.  On an edge too short to project on (a
        pure rotation), the share ``s_turn`` (K,) of the edge's rotation the
        tool has turned about the edge's axis, which follows the tool however
        the trajectory is timed along the edge; the fraction ``s_time`` of the
        edge's time where it does not turn either.
        """
        long_edge = self.length2[e] > MIN_EDGE_LENGTH**2
        s_line = np.sum(p * self.direction[e], axis=1) / np.where(long_edge, self.length2[e], 1.0)
        s_rest = np.where(self.angle[e] > MIN_TURN, s_turn, s_time)
        return np.clip(np.where(long_edge, s_line, s_rest), 0.0, 1.0)

    def _turn_share(self, orientation, e, s_time):
        """
        Return the share (K,) of its edge's rotation the tool has turned about the edge's axis.

        ``orientation`` (K, 3, 3) rotation matrices or (K, 4) quaternions of
        the tool: the rotation vector of ``R0^T R`` along the edge's axis,
        unwrapped near the time's share ``s_time`` of the edge's angle (a
        rotation vector stops at pi: a tool just past pi on an edge of
        nearly pi would read as turned back by 2 pi less), over the edge's
        angle (not used where that angle is below :data:`MIN_TURN`).
        """
        if orientation.ndim == 3:
            orientation = rot.from_matrix(orientation)
        relative = rot.multiply(rot.conjugate(self.quat0[e]), orientation)
        turned = np.sum(rot.rotation_vector(relative) * self.axis[e], axis=1)
        guess = s_time * self.angle[e]
        turned = guess + _wrap(turned - guess)
        return turned / np.where(self.angle[e] > MIN_TURN, self.angle[e], 1.0)

    def _spatial(self, t, e):
        joints = self.traj.evaluate(t)
        if self._matrices:
            position, mat = self.kinematics.forward_transform(joints)
        else:
            pose = np.asarray(self.kinematics.forward(joints), dtype=float)
            position = pose[:, :3]
        p = position - self.start[e]
        ab = self.direction[e]
        s_time = self._time_fraction(t, e)
        # The turn's share is read only on edges too short to project on: the others
        # (nearly every point of a refinement's many measures) skip its conversions.
        s_turn = s_time.copy()
        short = self.length2[e] <= MIN_EDGE_LENGTH**2
        if np.any(short):
            orientation = mat[short] if self._matrices else pose[short, 3:]
            s_turn[short] = self._turn_share(orientation, e[short], s_time[short])
        s = self._edge_parameter(p, s_time, s_turn, e)
        deviation = np.linalg.norm(p - s[:, None] * ab, axis=1)
        if not self._matrices:
            orientation = rot.angle_between(rot.slerp(self.quat0[e], self.quat1[e], s),
                                            pose[:, 3:])
            return deviation, orientation, position
        # D = (R0 Rot(s angle))^T R: its angle atan2(|vee(D - D^T)| / 2, (tr D - 1) / 2).
        a = s * self.angle[e]
        slerp_rel = (np.eye(3) + np.sin(a)[:, None, None] * self.skew[e]
                     + (1.0 - np.cos(a))[:, None, None] * self.skew2[e])
        wanted = self.rot0[e] @ slerp_rel
        d = np.einsum('kji,kjl->kil', wanted, mat)
        cosine = 0.5 * (d[:, 0, 0] + d[:, 1, 1] + d[:, 2, 2] - 1.0)
        sine = 0.5 * np.sqrt((d[:, 2, 1] - d[:, 1, 2]) ** 2 + (d[:, 0, 2] - d[:, 2, 0]) ** 2
                             + (d[:, 1, 0] - d[:, 0, 1]) ** 2)
        return deviation, np.arctan2(sine, cosine), position

    def deviation(self, tolerances=(0.0, 0.0), grid=SEGMENT_GRID_POINTS, steps=GOLDEN_STEPS):
        """
        Return the :class:`Deviation` per segment (grid, then golden-section search).

        Searched are the grid local maxima above ``REFINE_FRACTION`` of their
        tolerance (position, orientation; 0 = every one) and the
        ``ALWAYS_REFINED`` largest ones of each quantity; the others keep their
        grid value (a lower bound, far below the tolerance).
        """
        traj = self.traj
        starts = traj.waypoint_times[:-1]
        spans = np.diff(traj.waypoint_times)
        n_seg = spans.size
        # As many grid points per piece as a knots-only plan has per segment.
        grid *= -(-(traj.breakpoints.size - 1) // n_seg)
        u = np.linspace(0.0, 1.0, grid)
        times = starts[:, None] + spans[:, None] * u[None, :]
        seg = np.repeat(np.arange(n_seg), grid)
        pos, ori, xy = self(times.ravel(), seg)
        if self.spatial:
            xyz = xy.reshape(n_seg, grid, 3)
            slack = 0.5 * float(np.max(np.linalg.norm(np.diff(xyz, axis=1), axis=2)))
        else:
            xy = xy.reshape(n_seg, grid, 2)
            slack = 0.5 * float(np.max(np.hypot(*np.diff(xy, axis=1).transpose(2, 0, 1))))
        best = []
        for values in (pos.reshape(n_seg, grid), ori.reshape(n_seg, grid)):
            j = np.argmax(values, axis=1)
            best.append([values[np.arange(n_seg), j].copy(),
                         times[np.arange(n_seg), j].copy()])
        # Brackets around every interior grid local maximum, of either quantity.
        cand_seg, cand_lo, cand_hi, cand_kind = [], [], [], []
        for kind, values in enumerate((pos.reshape(n_seg, grid), ori.reshape(n_seg, grid))):
            mid = values[:, 1:-1]
            peak = (mid >= values[:, :-2]) & (mid >= values[:, 2:]) & (mid > 0.0)
            top = np.sort(mid[peak])[-ALWAYS_REFINED:]
            threshold = min(REFINE_FRACTION * tolerances[kind], top[0] if top.size else 0.0)
            s_idx, j_idx = np.nonzero(peak & (mid >= threshold))
            cand_seg.append(s_idx)
            cand_lo.append(times[s_idx, j_idx])
            cand_hi.append(times[s_idx, j_idx + 2])
            cand_kind.append(np.full(s_idx.size, kind))
        seg_c = np.concatenate(cand_seg)
        if seg_c.size:
            lo, hi = np.concatenate(cand_lo), np.concatenate(cand_hi)
            kind = np.concatenate(cand_kind)

            def value(t):
                p, o, _ = self(t, seg_c)
                return np.where(kind == 0, p, o)

            t_c, f_c = golden_maxima(value, lo, hi, steps)
            for k in (0, 1):
                mine = kind == k
                order = np.argsort(f_c[mine])  # larger values assigned last win
                s_k, f_k, t_k = seg_c[mine][order], f_c[mine][order], t_c[mine][order]
                better = f_k > best[k][0][s_k]
                best[k][0][s_k[better]] = f_k[better]
                best[k][1][s_k[better]] = t_k[better]
        return Deviation(best[0][0], best[1][0], best[0][1], best[1][1], slack)


def path_deviation(tool_path, kinematics, grid=SEGMENT_GRID_POINTS):
    """Measure a :class:`ToolPath` again, e.g. with a finer ``grid`` (a :class:`Deviation`)."""
    edge_poses = tool_path.poses[np.unique(tool_path.waypoint_knots)]
    return PathMeasure(tool_path.trajectory, kinematics, edge_poses,
                       tool_path.segment_edges).deviation(grid=grid)


def tolerance_excess(deviation, tolerances):
    """Per segment, the larger of position and orientation deviation over its tolerance."""
    return np.maximum(deviation.position / tolerances[0], deviation.orientation / tolerances[1])
