"""Arm tracking, grasp-carry-place and two-finger push in real PyBullet physics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py import yaw_difference
from nodes.common.transforms import quaternion_to_matrix, rotation_angle, tool_down_quaternion

from . import scripted


def test_controller_tracks_a_held_setpoint_within_1_mm(world_factory):
    world = world_factory([])
    target = np.array([0.80, 0.20, 0.12])
    assert world.set_setpoint(target, tool_down_quaternion(0.7)).accepted
    world.step(round(4.0 / world.config.dt))  # long enough at the joint speed limits
    position, quat = world.tcp_pose()
    assert np.linalg.norm(position - target) <= 1e-3
    wanted = quaternion_to_matrix(tool_down_quaternion(0.7))
    assert math.degrees(rotation_angle(quaternion_to_matrix(quat), wanted)) <= 0.1
    # still there a second later (held, not drifting)
    world.step(240)
    assert np.linalg.norm(world.tcp_pose()[0] - target) <= 1e-3


def test_joint_motion_respects_the_velocity_limits(world_factory):
    from nodes.robot import ur10e

    world = world_factory([])
    world.set_setpoint([0.9, 0.3, 0.05], tool_down_quaternion(1.2))
    limit = np.asarray(ur10e.JOINT_VELOCITY_LIMIT)
    peak = np.zeros(6)
    for _ in range(240):
        world.step()
        _, v = world.arm_state()
        peak = np.maximum(peak, np.abs(v))
    assert np.all(peak <= limit * 1.05), (peak, limit)
    assert peak.max() > 0.3  # it did move


def test_grasp_carry_half_a_metre_and_place_within_2mm_1deg(world_factory):
    world = world_factory([(0, 0.60, -0.25, 0.3)])
    streamer = scripted.Streamer(world)
    scripted.pick(streamer, 0.60, -0.25, 0.3)
    held, _ = world.block_pose_3d(0)
    assert held[2] > 0.12  # lifted by friction alone ...
    assert world.client.getNumConstraints() == 1  # ... the finger coupling is the only one
    assert world.fingers.gap() > 0.049  # fingers stopped on the 50.8 mm block
    streamer.move_to([0.60, 0.25, scripted.SAFE_Z], speed=0.25)  # 0.5 m at 0.25 m/s
    scripted.place(streamer, 0.60, 0.25, 0.3)
    block = world.block_poses()[0]
    assert math.hypot(block.x - 0.60, block.y - 0.25) <= 0.002
    assert math.degrees(abs(yaw_difference(block.theta, 0.3, math.pi / 2))) <= 1.0
    assert not streamer.rejections
    assert world.monitor.blocks_lost == 0


def test_two_finger_push_keeps_the_line(world_factory):
    world = world_factory([(0, 0.60, 0.10, 0.25)])
    streamer = scripted.Streamer(world)
    direction = 0.25  # along the block's local x face normal
    scripted.push(streamer, 0.60, 0.10, direction, 0.15)
    block = world.block_poses()[0]
    d = np.array([math.cos(direction), math.sin(direction)])
    moved = np.array([block.x - 0.60, block.y - 0.10])
    lateral = abs(float(d[0] * moved[1] - d[1] * moved[0]))
    along = float(np.dot(d, moved))
    assert lateral <= 0.003
    assert along > 0.13  # moved most of the way (the fingers stop at the commanded end)
    assert math.degrees(abs(yaw_difference(block.theta, 0.25, math.pi / 2))) <= 2.0


def test_disturbance_moves_a_block_about_that_much(world_factory):
    world = world_factory([(3, 0.70, 0.0, 0.0)])
    world.hand.disturb(3, 0.03, -0.02)
    world.step(round(3.0 / world.config.dt))
    block = world.block_poses()[0]
    assert math.hypot(block.x - 0.73, block.y + 0.02) < 0.005
    assert not world.hand.disturbances


def test_event_monitor_counts_a_finger_landing_on_a_neighbour(world_factory):
    # block 1 stands 6 mm from block 0: a grasp of 0 across x puts a finger on top of 1
    world = world_factory([(0, 0.60, 0.0, 0.0), (1, 0.60 + 0.0508 + 0.006, 0.0, 0.0)])
    world.set_manipulated(0)
    streamer = scripted.Streamer(world)
    streamer.move_to([0.60, 0.0, scripted.SAFE_Z], yaw=0.0)
    streamer.gripper(0.0508 + 2 * scripted.CLEARANCE)
    streamer.move_to([0.60, 0.0, 0.03], speed=0.1)
    summary = world.monitor.summary()
    assert summary["unintended_contacts"] >= 1
    assert all(e["block"] == 1 for e in summary["events"] if e["type"] == "unintended_contact")


def test_block_pushed_out_of_the_workspace_is_lost(world_factory):
    world = world_factory([(2, 0.92, 0.0, 0.0)])
    world.hand.disturb(2, 0.09, 0.0)
    world.step(round(4.0 / world.config.dt))
    assert world.monitor.blocks_lost == 1
    assert world.monitor.events[-1]["reason"] == "out of the workspace"


def _tilt_deg(world, block: int) -> float:
    _, quat = world.block_pose_3d(block)
    up = np.array(world.client.getMatrixFromQuaternion(quat)).reshape(3, 3)[:, 2]
    return math.degrees(math.acos(min(1.0, abs(float(up[2])))))


def _finger_onto_neighbour(world_factory, **config):
    """Go down fast to grip block 0 across x while block 1 stands 6 mm off: one finger comes
    down on block 1's top edge (a block knocked there after the last frame)."""
    world = world_factory([(0, 0.60, 0.0, 0.0), (1, 0.60 + 0.0508 + 0.006, 0.0, 0.0)], **config)
    streamer = scripted.Streamer(world)
    streamer.move_to([0.60, 0.0, scripted.SAFE_Z], yaw=0.0)
    streamer.gripper(0.0508 + 2 * scripted.CLEARANCE)
    streamer.move_to([0.60, 0.0, 0.012], speed=0.37)
    return world, streamer


def test_a_finger_landing_on_a_block_stops_the_arm_before_the_block_tips(world_factory):
    world, _ = _finger_onto_neighbour(world_factory)
    assert "N on the robot" in world.robot_state.stop_reason and world.guard.protective_stops == 1
    assert world.tcp_pose()[0][2] > 0.045  # stopped on the block's top (50.8 mm)
    assert _tilt_deg(world, 1) < 3.0
    # without the force limit the arm goes on down to grasp height and drives the block out of
    # its way: tipped over, or shoved aside (streamed into the trajectory controller, which
    # starts every snippet from the measured joints, it mostly slides)
    world, _ = _finger_onto_neighbour(world_factory, tool_force_limit=0.0)
    assert world.guard.protective_stops == 0 and world.tcp_pose()[0][2] < 0.02
    moved = world.block_poses()[1]
    assert _tilt_deg(world, 1) > 45.0 or math.hypot(moved.x - (0.60 + 0.0508 + 0.006),
                                                      moved.y) > 0.005


def test_after_an_unlock_the_arm_backs_off_but_may_not_press_again(world_factory):
    world, streamer = _finger_onto_neighbour(world_factory, protective_stop_unlock_after_s=0.0)
    ok, _ = world.unlock_protective_stop()  # the arm node's sequence: unlock, stop, play
    assert ok
    for _ in range(round(2.0 / world.config.dt)):
        world.step()
        if world.core.state.state == "ready":
            break
    assert world.core.state.state == "ready" and world.robot_state.program_running
    assert not world.unlock_protective_stop()[0]  # not in a protective stop any more
    streamer.rejections.clear()
    streamer.position = world.tcp_pose()[0].copy()  # from where the arm stopped ...
    streamer.move_to([0.60, 0.0, 0.08], speed=0.1)  # ... up and off, in contact at first
    assert not streamer.rejections and not world.robot_state.stop_reason
    assert world.tcp_pose()[0][2] == pytest.approx(0.08, abs=1e-3)
    streamer.move_to([0.60, 0.0, 0.012], speed=0.37)  # down onto it again: stopped again
    assert world.robot_state.stop_reason and world.guard.protective_stops == 2
    assert _tilt_deg(world, 1) < 3.0
