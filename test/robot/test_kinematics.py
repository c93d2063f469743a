"""The planar arm's kinematics and the paper's triangle example."""

from hypothesis import given, strategies as st
import numpy as np
import pytest
from splines445_ros.robot import paper_example
from splines445_ros.robot.kinematics import PlanarArm


@given(q=st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3))
def test_inverse_of_forward_gives_back_the_pose(q):
    arm = PlanarArm()
    pose = arm.forward(np.array(q))
    elbow = 1.0 if np.sin(q[1]) >= 0 else -1.0
    if abs(np.sin(q[1])) < 1e-3:
        return  # at the singularity both branches coincide numerically poorly
    back = arm.inverse(pose[None, :], elbow=elbow)[0]
    np.testing.assert_allclose(arm.forward(back), pose, atol=1e-9)
    assert np.cos(back[1]) == pytest.approx(np.cos(q[1]), abs=1e-9)


def test_triangle_waypoints_are_on_the_triangle_and_closed():
    xy = paper_example.triangle_points()
    assert xy.shape == (12, 2)
    np.testing.assert_allclose(xy[0], [1.0, 0.0])
    np.testing.assert_allclose(xy[-1], [1.0, 0.0])
    np.testing.assert_allclose(paper_example.distance_to_triangle(xy), 0.0, atol=1e-12)
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    # Evenly spaced along the path: chords equal except where a corner is cut.
    assert np.max(steps) == pytest.approx((2 + np.sqrt(2)) / 11)


def test_joint_waypoints_reach_the_triangle_with_zero_orientation_and_no_wraps():
    arm = PlanarArm()
    q = paper_example.joint_waypoints(arm)
    pose = arm.forward(q)
    np.testing.assert_allclose(pose[:, :2], paper_example.triangle_points(), atol=1e-12)
    np.testing.assert_allclose(pose[:, 2], 0.0, atol=1e-12)
    assert np.max(np.abs(np.diff(q, axis=0))) < np.pi


def test_unreachable_pose_and_bad_links_are_rejected():
    with pytest.raises(ValueError, match='out of reach'):
        PlanarArm().inverse([[3.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match='link length d2'):
        PlanarArm(1.0, 0.0)
    # Issue 18: these raised TypeError and IndexError.
    with pytest.raises(ValueError, match='link length d1 must be a number'):
        PlanarArm(None, 1.0)
    with pytest.raises(ValueError, match=r'poses must be \(K, 3\)'):
        PlanarArm().inverse([[1.0, 0.0]])
