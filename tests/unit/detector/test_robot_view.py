"""The robot's pose at a frame's stamp, from the drivers' joint states read by name."""

from __future__ import annotations

import numpy as np
import pytest

from nodes.detector.robot_view import RobotPoses
from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e

SHUFFLED = [ur10e.ARM_JOINTS[i] for i in (2, 0, 5, 1, 4, 3)]


def arm_state(poses: RobotPoses, stamp: float, value: float) -> None:
    q = np.full(6, value) + np.arange(6)
    poses.on_joint_state(SHUFFLED, [q[ur10e.ARM_JOINTS.index(n)] for n in SHUFFLED], stamp)


def test_joints_are_read_by_name_and_interpolated_at_the_frame_stamp():
    poses = RobotPoses()
    arm_state(poses, 10.00, 0.0)
    arm_state(poses, 10.02, 1.0)
    at = poses.at(10.005)
    assert at is not None
    assert np.allclose(at.q, 0.25 + np.arange(6))
    assert at.gap == pytest.approx(g85.knuckle_to_gap(0.0))  # no gripper: wide open


def test_the_gap_comes_from_the_knuckle_and_other_joints_are_ignored():
    poses = RobotPoses()
    arm_state(poses, 1.0, 0.0)
    poses.on_joint_state([g85.KNUCKLE_JOINT, "some_other_joint"], [g85.KNUCKLE_CLOSED, 3.0], 1.0)
    at = poses.at(1.0)
    assert at is not None and at.gap == pytest.approx(0.0)


def test_no_pose_without_joint_states_near_the_stamp():
    poses = RobotPoses(max_gap_s=0.1)
    assert poses.at(1.0) is None
    arm_state(poses, 1.0, 0.0)
    arm_state(poses, 2.0, 1.0)
    assert poses.at(1.5) is None  # a second without joint states around the frame
    assert poses.at(1.05) is not None and poses.at(2.08) is not None
    assert poses.at(2.2) is None


def test_a_joint_state_lacking_an_arm_joint_is_not_used():
    poses = RobotPoses()
    poses.on_joint_state(list(ur10e.ARM_JOINTS[:5]), [0.0] * 5, 1.0)
    assert poses.at(1.0) is None


def test_time_going_back_starts_afresh():
    poses = RobotPoses()
    arm_state(poses, 50.0, 3.0)
    arm_state(poses, 0.1, 0.0)
    at = poses.at(0.1)
    assert at is not None and np.allclose(at.q, np.arange(6))
    assert poses.at(50.0) is None
