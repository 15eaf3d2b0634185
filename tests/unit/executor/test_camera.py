"""The trigger of a look on the way: at the pose picked for the frame, and only once the
arm's measured posture leaves the blocks to judge in view."""

from __future__ import annotations

import numpy as np

from msgs_py import Pose2D
from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.executor.belief import Belief
from nodes.executor.camera import PASSING_M, Camera
from nodes.executor.inputs import Inbox
from nodes.executor.motion import ToolPose
from nodes.executor.observe import posture_check
from nodes.executor.states import Purpose
from nodes.executor.visibility import FRAME_DELAY_S, shows
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik
from tests.unit.executor.test_look_on_the_way import VIEW

PICKED = ToolPose(0.60, 0.10, 0.30, 0.0)


def on_the_way_camera(judge: frozenset[int] = frozenset({2})) -> Camera:
    camera = Camera()
    camera.begin(Purpose.AFTER_ACTION)
    camera.on_the_way, camera.judge, camera.trigger_near = True, judge, PICKED
    return camera


def approach(camera: Camera, t: float, shows_now: bool | None) -> bool:
    """One tick, the tool 5 mm off the picked pose."""
    tool = ToolPose(PICKED.x + 0.005, PICKED.y, PICKED.z, 0.0)
    return camera.due(t, tool, None if shows_now is None else (lambda: shows_now))


def test_at_the_picked_pose_the_frame_waits_for_a_posture_that_shows_the_blocks():
    camera = on_the_way_camera()
    far = ToolPose(PICKED.x - 0.2, PICKED.y, PICKED.z, 0.0)
    assert not camera.due(1.0, far, lambda: True)  # not there yet: the posture alone is not enough
    assert not approach(camera, 1.02, False) and not approach(camera, 1.04, False)
    assert camera.held_back == 2 and camera.trigger_ns is None
    assert approach(camera, 1.06, True)
    assert camera.trigger_ns == round(1.06 * 1e9) and camera.want_trigger
    assert not approach(camera, 1.08, True)  # once


def test_past_the_picked_pose_it_still_waits_for_the_posture():
    camera = on_the_way_camera()
    line = [ToolPose(PICKED.x + d, PICKED.y, PICKED.z, 0.0) for d in (-0.08, -0.03, 0.02, 0.07)]
    assert not any(camera.due(0.1 * k, p, lambda: False) for k, p in enumerate(line))
    assert camera.reached and camera.near_dist < PASSING_M
    assert camera.due(0.5, line[-1], lambda: True)


def test_without_a_posture_the_pose_decides_and_arrival_forces_it():
    camera = on_the_way_camera()
    assert approach(camera, 1.0, None)
    forced = on_the_way_camera()
    far = ToolPose(0.2, -0.5, 0.4, 0.0)
    assert forced.due(2.0, far, lambda: False, force=True)


def test_joint_rates_come_from_the_last_two_joint_states():
    inbox = Inbox()
    inbox.on_arm_joints([0.0] * 6, 10.00)
    assert inbox.arm_rates is None
    inbox.on_arm_joints([0.02, 0, 0, 0, 0, -0.01], 10.02)
    assert np.allclose(inbox.arm_rates, [1.0, 0, 0, 0, 0, -0.5])
    inbox.on_arm_joints([0.02, 0, 0, 0, 0, -0.01], None)  # no stamp: no rate
    assert inbox.arm_rates is None


def joints_at(x: float, y: float, z: float = 0.30) -> np.ndarray:
    q = solve_tcp_ik(pose_matrix((x, y, z), tool_down_quaternion(0.0)),
                     np.asarray(ur10e.WORKING_BRANCH_JOINTS, float)).q
    assert q is not None
    return q


def test_a_block_under_the_tool_or_where_the_arm_heads_within_a_frames_delay_is_covered():
    block = {2: Pose2D(0.60, 0.10, 0.0)}
    assert not shows(VIEW, joints_at(0.60, 0.10), None, block)
    away = joints_at(0.60, 0.40)
    assert shows(VIEW, away, None, block)
    # heading for the block fast enough to be over it when the frame is taken
    over = joints_at(0.60, 0.10)
    rates = (over - away) / FRAME_DELAY_S
    assert not shows(VIEW, away, rates, block)
    assert shows(VIEW, away, 0.0 * rates, block)


def test_the_posture_check_needs_a_camera_model_joints_and_blocks_to_judge():
    belief = Belief()
    belief.expected = {2: Pose2D(0.60, 0.10, 0.0)}
    inbox = Inbox()
    camera = on_the_way_camera()
    assert posture_check(VIEW, inbox, belief, camera) is None  # no joint states yet
    inbox.on_arm_joints(joints_at(0.60, 0.10), 1.0)
    assert posture_check(None, inbox, belief, camera) is None
    assert posture_check(VIEW, inbox, belief, on_the_way_camera(frozenset())) is None
    check = posture_check(VIEW, inbox, belief, camera)
    assert check is not None and not check()
    inbox.on_arm_joints(joints_at(0.60, 0.40), 1.02)
    inbox.arm_rates = None
    assert posture_check(VIEW, inbox, belief, camera)()
