"""Arm controller: setpoint validation, hold-on-reject, rate limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.sim import robot_model as rm
from nodes.sim.config import HOME_JOINTS
from nodes.sim.controller import ArmController, clip_gripper_gap
from nodes.sim.kinematics import pose_error, tcp_pose

DT = 1.0 / 240.0


def run(ctrl: ArmController, seconds: float) -> list[np.ndarray]:
    return [ctrl.step(DT)[0] for _ in range(round(seconds / DT))]


def test_reaches_an_accepted_setpoint_within_joint_limits():
    ctrl = ArmController(HOME_JOINTS)
    target = pose_matrix([0.7, 0.1, 0.05], tool_down_quaternion(0.4))
    assert ctrl.set_setpoint(target[:3, 3], tool_down_quaternion(0.4)).accepted
    qs = np.array([HOME_JOINTS, *run(ctrl, 5.0)])
    steps = np.abs(np.diff(qs, axis=0))
    assert np.all(steps <= np.asarray(rm.JOINT_VELOCITY_LIMIT) * DT * (1 + 1e-9))
    accel = np.abs(np.diff(np.diff(qs, axis=0), axis=0)) / DT**2
    # (the last step onto the target may exceed the limit by a few per cent)
    assert np.all(accel <= np.asarray(rm.JOINT_ACCELERATION_LIMIT) * 1.05)
    dp, dr = pose_error(tcp_pose(qs[-1]), target)
    assert dp < 1e-6 and dr < 1e-6


@pytest.mark.parametrize(("position", "quat", "frame", "words"), [
    ([0.7, 0.0, 0.1], [0, 0, 0, 1], "base_link", "frame_id"),
    ([0.7, float("nan"), 0.1], [1, 0, 0, 0], "world", "non-finite"),
    ([0.7, 0.0, 0.1], [0, 0, 0, 0], "world", "norm"),
    ([0.7, 0.0, -0.01], [1, 0, 0, 0], "world", "safety plane"),
    ([2.0, 0.0, 0.1], [1, 0, 0, 0], "world", "reach"),
])
def test_bad_setpoints_are_rejected_and_the_arm_holds(position, quat, frame, words):
    ctrl = ArmController(HOME_JOINTS)
    ctrl.set_setpoint([0.7, 0.0, 0.2], tool_down_quaternion(0.0))
    run(ctrl, 0.3)  # moving now
    moving_at = ctrl.q_cmd.copy()
    result = ctrl.set_setpoint(position, quat, frame)
    assert not result.accepted and words in result.reason
    assert ctrl.rejected == 1 and words in ctrl.last_reason
    after = run(ctrl, 0.5)
    assert np.allclose(after[-1], moving_at)  # held still where it was


def test_speed_scale_slows_the_arm():
    fast, slow = ArmController(HOME_JOINTS), ArmController(HOME_JOINTS, speed_scale=0.25)
    for ctrl in (fast, slow):
        ctrl.set_setpoint([0.9, 0.3, 0.05], tool_down_quaternion(1.0))
    fast_q, slow_q = run(fast, 1.0)[-1], run(slow, 1.0)[-1]
    assert np.max(np.abs(slow_q - HOME_JOINTS)) < np.max(np.abs(fast_q - HOME_JOINTS))
    with pytest.raises(ValueError):
        ArmController(HOME_JOINTS, speed_scale=0.0)


def test_gripper_command_is_clipped_to_the_stroke():
    assert clip_gripper_gap(-0.01) == 0.0
    assert clip_gripper_gap(0.2) == rm.GRIPPER_STROKE
    assert clip_gripper_gap(0.05) == 0.05
    with pytest.raises(ValueError):
        clip_gripper_gap(math.nan)
