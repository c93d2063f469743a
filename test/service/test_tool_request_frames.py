"""The frames a kinematics "model" tool request may be in (no tf): tool_poses_from_message."""

from geometry_msgs.msg import Pose, PoseArray
import pytest
from splines445_ros.service.arm_sim_config import ArmSimConfig
from splines445_ros.service.arm_sim_model import resolve_model_config
from splines445_ros.service.model_planning import tool_poses_from_message
from splines445_ros.tools import vendor_robots as vr


def poses(frame_id):
    msg = PoseArray()
    msg.header.frame_id = frame_id
    msg.poses = [Pose(), Pose()]
    for k, pose in enumerate(msg.poses):
        pose.position.x, pose.orientation.w = 0.1 * k, 1.0
    return msg


@pytest.mark.parametrize('frame', ['', 'world', 'panda_link0'])
def test_the_world_by_either_name_or_none_is_taken_with_base_frame_empty(frame):
    rows = tool_poses_from_message(poses(frame), '', 'panda_link0')
    assert rows.shape == (2, 7) and rows[1, 0] == pytest.approx(0.1)


def test_another_frame_is_refused_naming_what_is_taken():
    with pytest.raises(ValueError, match=r"frame 'tool0', but base_frame is empty \(the world: "
                                         r"'world' or 'panda_link0'\)"):
        tool_poses_from_message(poses('tool0'), '', 'panda_link0')
    with pytest.raises(ValueError, match=r"frame 'panda_link0', but base_frame is empty \(the "
                                         r"world: 'world'\)"):
        tool_poses_from_message(poses('panda_link0'), '', None)
    # An explicit base_frame is the only one taken.
    with pytest.raises(ValueError, match="but base_frame is 'panda_link3'"):
        tool_poses_from_message(poses('world'), 'panda_link3', 'panda_link0')
    assert tool_poses_from_message(poses('panda_link3'), 'panda_link3', 'panda_link0').shape == (
        2, 7)


def test_the_arms_tool_pose_frame_defaults_to_the_models_root_link():
    """arm_sim_node's tool_pose: its frame_id empty = the URDF root (it said base_link)."""
    joints = [f'panda_joint{k}' for k in range(1, 8)]
    panda = ArmSimConfig.from_values({'model_file': vr.panda_urdf(), 'joint_names': joints,
                                      'initial_positions': [0.0] * 7})
    assert panda.frame_id == ''
    assert resolve_model_config(panda)[0].frame_id == 'panda_link0'
    named = ArmSimConfig.from_values({'model_file': vr.panda_urdf(), 'joint_names': joints,
                                      'initial_positions': [0.0] * 7, 'frame_id': 'table'})
    assert resolve_model_config(named)[0].frame_id == 'table'
