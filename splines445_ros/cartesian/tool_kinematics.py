"""
The kinematics a tool request is planned with: :class:`ToolKinematics`, and its optional parts.

Any object with ``forward`` and ``inverse`` plans tool requests (see the
protocol's docstring).  A kinematics may offer more, and the tool paths use
it when it does; the functions here are the one place that asks:

* ``n_joints`` (:func:`declared_joint_count`): the joints, without an
  inverse kinematics call to find out;
* ``forget_walks()`` (:func:`start_walk`): a redundant arm's inverse
  kinematics walks from pose to pose, so the joints depend on the walk; the
  tool lines start each of theirs afresh;
* ``forward_transform(joints)`` (:func:`has_transforms`): positions and
  rotation matrices, exact angles between poses instead of quaternion
  arithmetic;
* ``tool``, a :class:`~splines445_ros.robot.frame_chain.FrameChain`
  (:func:`frame_chain`): tool speeds from the chain's Jacobian instead of
  central differences;
* an error of ``inverse`` with ``pose_index`` and ``reason``
  (:func:`refused_pose`): which pose it refused, and why.

:class:`~splines445_ros.robot.inverse_kinematics.ModelKinematics` has them
all; :class:`~splines445_ros.robot.kinematics.PlanarArm` only the two the
protocol asks for.
"""

import numbers
from typing import Protocol

from ..robot.frame_chain import FrameChain


class ToolKinematics(Protocol):
    """
    What every kinematics of a tool request has.

    Poses are planar, P = 3: (x, y, yaw), or spatial, P = 7: (x, y, z, qw,
    qx, qy, qz), a position and a unit quaternion (scalar first).
    """

    def forward(self, joints):
        """Return the tool poses (..., P) of joint positions (..., n), vectorised."""

    def inverse(self, poses):
        """
        Return joint positions (K, n) of tool poses (K, P), continuous along K.

        No 2 pi jumps between consecutive rows; ValueError for an unreachable
        pose (with ``pose_index`` and ``reason`` when it knows which).
        """


def declared_joint_count(kinematics):
    """Return the ``n_joints`` of ``kinematics`` when it declares an integer, else None."""
    count = getattr(kinematics, 'n_joints', None)
    if isinstance(count, numbers.Integral) and not isinstance(count, bool):
        return int(count)
    return None


def start_walk(kinematics):
    """Make the next ``inverse`` of ``kinematics`` start a walk afresh (``forget_walks``)."""
    forget = getattr(kinematics, 'forget_walks', None)
    if callable(forget):
        forget()


def has_transforms(kinematics):
    """Return True when ``kinematics`` gives ``forward_transform`` (positions, rotations)."""
    return callable(getattr(kinematics, 'forward_transform', None))


def frame_chain(kinematics):
    """Return the tool's :class:`FrameChain` of ``kinematics`` (its ``tool``), or None."""
    chain = getattr(kinematics, 'tool', None)
    return chain if isinstance(chain, FrameChain) else None


def refused_pose(exc):
    """Return (pose index or None, reason or None) of an ``inverse`` ValueError ``exc``."""
    return getattr(exc, 'pose_index', None), getattr(exc, 'reason', None)
