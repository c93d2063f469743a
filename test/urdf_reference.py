"""
Forward kinematics of a URDF written for the tests, from the URDF specification.

Independent of the package: it reads ``<origin xyz rpy>`` and ``<axis>`` of
each joint with ElementTree and composes them with scipy's Rotation, so the
tests can check the MuJoCo-based model against it.
"""

import xml.etree.ElementTree as ET

import numpy as np
from scipy.spatial.transform import Rotation


class BatchedUrdfChain:
    """FK (K samples at once) from a URDF's <origin xyz rpy> and <axis>, written for tests."""

    def __init__(self, path, base, tool, joint_names):
        root = ET.parse(path).getroot()
        by_child = {j.find('child').get('link'): j for j in root.findall('joint')}
        chain, link = [], tool
        while link != base:
            chain.append(by_child[link])
            link = by_child[link].find('parent').get('link')
        self.steps = []
        for joint in reversed(chain):
            origin = joint.find('origin')
            xyz = np.array([float(v) for v in origin.get('xyz', '0 0 0').split()])
            rpy = [float(v) for v in origin.get('rpy', '0 0 0').split()]
            rotation = Rotation.from_euler('xyz', rpy).as_matrix()  # URDF: fixed-axis r, p, y
            index = None
            axis = None
            if joint.get('type') in ('revolute', 'continuous'):
                index = joint_names.index(joint.get('name'))
                axis = np.array([float(v) for v in joint.find('axis').get('xyz').split()])
            self.steps.append((rotation, xyz, index, axis))

    def __call__(self, q):
        q = np.atleast_2d(q)
        k = len(q)
        pos = np.zeros((k, 3))
        mat = np.tile(np.eye(3), (k, 1, 1))
        for rotation, xyz, index, axis in self.steps:
            pos = pos + np.einsum('kij,j->ki', mat, xyz)
            mat = np.einsum('kij,jl->kil', mat, rotation)
            if index is not None:
                turn = Rotation.from_rotvec(q[:, index, None] * axis[None, :]).as_matrix()
                mat = np.einsum('kij,kjl->kil', mat, turn)
        return pos, mat


def distance_to_polyline(points, corners):
    """Return the distance (K,) of points (K, 3) to the polyline through corners (M, 3)."""
    best = np.full(len(points), np.inf)
    for a, b in zip(corners[:-1], corners[1:]):
        ab = b - a
        s = np.clip((points - a) @ ab / (ab @ ab), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - a - s[:, None] * ab, axis=1))
    return best
