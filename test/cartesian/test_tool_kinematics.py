"""The kinematics protocol: forward and inverse are enough; the optional parts are found."""

import numpy as np
import pytest
from splines445_ros.cartesian.tool_kinematics import (declared_joint_count, frame_chain,
                                                      has_transforms, refused_pose, start_walk)
from splines445_ros.cartesian.tool_paths import plan_tool_path
from splines445_ros.robot.inverse_kinematics import ModelKinematics
from splines445_ros.robot.robot_model import load_robot_model
from splines445_ros.tools import vendor_robots as vr
from test_tool_paths_6d import MM, seam, UR5_LIMITS, UR5_SEAM
from urdf_reference import BatchedUrdfChain

TOOL_SPEED = 0.2    # [m/s]


class ForwardInverseOnly:
    """A kinematics with the two members the protocol asks for, and nothing else."""

    def __init__(self, kinematics):
        self._kinematics = kinematics

    def forward(self, joints):
        return self._kinematics.forward(joints)

    def inverse(self, poses):
        self._kinematics.forget_walks()     # every call a walk of its own
        return self._kinematics.inverse(poses)


@pytest.fixture(scope='module')
def ur5():
    robot = load_robot_model(vr.ur5_urdf())
    return ModelKinematics(robot, 'tool0', 'base_link', seed=vr.UR5_READY)


def test_the_optional_parts_are_found_where_they_are(ur5):
    bare = ForwardInverseOnly(ur5)
    assert declared_joint_count(ur5) == 6 and declared_joint_count(bare) is None
    assert has_transforms(ur5) and not has_transforms(bare)
    assert frame_chain(ur5) is ur5.tool and frame_chain(bare) is None
    start_walk(bare)    # nothing to forget: no error
    error = ValueError('out of reach')
    assert refused_pose(error) == (None, None)
    error.pose_index, error.reason = 3, 'is beyond the arm'
    assert refused_pose(error) == (3, 'is beyond the arm')


def test_forward_and_inverse_alone_plan_a_tool_line_within_its_speed(ur5):
    """The UR5 seam with only forward/inverse: central differences, yet the speed holds."""
    poses = seam(ur5, vr.UR5_READY, UR5_SEAM, 0.15)
    bare = plan_tool_path(poses, ForwardInverseOnly(ur5), MM, None, method='555',
                          timing='optimal', max_tool_speed=TOOL_SPEED, **UR5_LIMITS)
    full = plan_tool_path(poses, ur5, MM, None, method='555', timing='optimal',
                          max_tool_speed=TOOL_SPEED, **UR5_LIMITS)
    assert bare.construction == full.construction == 'tool lines'
    # An independent forward kinematics (the URDF's joints and origins) every
    # 0.5 ms: the tool's speed by central differences of its positions.
    fk = BatchedUrdfChain(vr.ur5_urdf(), 'base_link', 'tool0', list(vr.UR5_JOINTS))
    traj = bare.trajectory
    t = np.arange(0.0, traj.duration, 5e-4)
    position = fk(traj.evaluate(t))[0]
    speed = np.linalg.norm(np.diff(position, axis=0), axis=1) / np.diff(t)
    assert speed.max() <= TOOL_SPEED * (1 + 2e-3)
    assert bare.tool_speed <= TOOL_SPEED * (1 + 1e-9)
    # The same lines and profile: durations within a few per mille.
    assert bare.trajectory.duration == pytest.approx(full.trajectory.duration, rel=5e-3)
