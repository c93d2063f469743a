"""The paper's Section III example: a triangle traced by the planar arm; no ROS imports."""

import numpy as np

from .kinematics import PlanarArm

TRIANGLE_CORNERS = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
N_WAYPOINTS = 12
BOUNDARY_VELOCITY = np.array([-0.1, 0.4, 0.0])
BOUNDARY_ACCELERATION = np.array([1.0, 3.0, 0.0])
MAX_VELOCITY = np.full(3, 2.0)
MAX_ACCELERATION = np.full(3, 10.0)
JOINT_NAMES = ('joint1', 'joint2', 'joint3')


def plan_kwargs():
    """Limits and boundary values of the example as keyword arguments of ``plan()``."""
    return {'max_velocity': MAX_VELOCITY, 'max_acceleration': MAX_ACCELERATION,
            'start_velocity': BOUNDARY_VELOCITY, 'start_acceleration': BOUNDARY_ACCELERATION,
            'end_velocity': BOUNDARY_VELOCITY, 'end_acceleration': BOUNDARY_ACCELERATION}


def triangle_points(n=N_WAYPOINTS):
    """
    ``n`` tool positions (n, 2) evenly spaced by arc length on the closed triangle.

    The path runs (1,0) -> (0,1) -> (1,1) -> (1,0); the first and last point are
    both (1, 0).
    """
    corners = np.vstack([TRIANGLE_CORNERS, TRIANGLE_CORNERS[:1]])
    edges = np.diff(corners, axis=0)
    lengths = np.hypot(edges[:, 0], edges[:, 1])
    cumulative = np.concatenate([[0.0], np.cumsum(lengths)])
    s = np.linspace(0.0, cumulative[-1], n)
    edge = np.clip(np.searchsorted(cumulative, s, side='right') - 1, 0, len(edges) - 1)
    frac = (s - cumulative[edge]) / lengths[edge]
    return corners[edge] + frac[:, None] * edges[edge]


def joint_waypoints(arm=None, n=N_WAYPOINTS):
    """Joint-space waypoints (n, 3) of the triangle with tool orientation 0 (IK of the paper)."""
    arm = arm or PlanarArm()
    xy = triangle_points(n)
    poses = np.column_stack([xy, np.zeros(len(xy))])
    return arm.inverse(poses)


def distance_to_triangle(points):
    """Distance (K,) of tool positions (K, 2) to the nearest of the triangle's edges."""
    p = np.atleast_2d(points)
    corners = np.vstack([TRIANGLE_CORNERS, TRIANGLE_CORNERS[:1]])
    best = np.full(len(p), np.inf)
    for a, b in zip(corners[:-1], corners[1:]):
        ab = b - a
        t = np.clip(((p - a) @ ab) / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - (a + t[:, None] * ab), axis=1))
    return best
