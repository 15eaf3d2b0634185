"""Scripted motions on a ``SimArm``, the way the executor streams them (for the sim tests).

Setpoints are streamed on straight lines at a given TCP speed, one per physics step, the
gripper pointing down (``tool_down_quaternion(yaw)``). ``pick`` / ``place`` / ``push``
follow docs/contracts.md: open to ``s + 2 * clearance``, descend, close; for a push close to
``push_opening``, descend behind the block, push along the face normal, back off, lift.
"""

from __future__ import annotations

import math

import numpy as np

from nodes.bench.sim_arm import SimArm
from nodes.common.transforms import tool_down_quaternion
from nodes.sim import robot_model as rm

SAFE_Z = 0.15  #: m, transfer height of the TCP (fingertips well above 50.8 mm blocks)
GRASP_Z = 0.015  #: m, TCP height when grasping (fingertips 15 mm above the table)
PUSH_Z = 0.010  #: m, TCP height while pushing
CLEARANCE = 0.010  #: m, finger clearance on each side when opening for a grasp
PUSH_OPENING = 0.030  #: m, gap between the fingers for a two-finger push


class Streamer:
    """Streams straight-line TCP setpoints into a world, one per physics step."""

    def __init__(self, world: SimArm, yaw: float = 0.0) -> None:
        self.world = world
        self.yaw = yaw
        self.position = np.asarray(world.commanded_tcp()[:3, 3], dtype=float)
        self.rejections: list[str] = []

    def move_to(self, target, speed: float = 0.25, yaw: float | None = None,
                settle_s: float = 0.3) -> None:
        """Line from the last setpoint to ``target`` at ``speed`` (m/s), then wait."""
        target = np.asarray(target, dtype=float)
        if yaw is not None:
            self.yaw = yaw
        quat = tool_down_quaternion(self.yaw)
        dt = self.world.config.dt
        n = max(1, math.ceil(np.linalg.norm(target - self.position) / (speed * dt)))
        start = self.position.copy()
        for k in range(1, n + 1):
            p = start + (target - start) * (k / n)
            result = self.world.set_setpoint(p, quat)
            if not result.accepted:
                self.rejections.append(result.reason)
            self.world.step()
        self.position = target
        self.wait(settle_s)

    def wait(self, seconds: float) -> None:
        self.world.step(max(0, round(seconds / self.world.config.dt)))

    def gripper(self, gap: float, settle_s: float = 0.8) -> None:
        self.world.set_gripper(gap)
        self.wait(settle_s)


def pick(streamer: Streamer, x: float, y: float, yaw: float, speed: float = 0.25) -> None:
    s = rm.BLOCK_SIZE
    streamer.move_to([x, y, SAFE_Z], speed, yaw=yaw, settle_s=0.1)
    streamer.gripper(s + 2 * CLEARANCE, settle_s=0.5)
    streamer.move_to([x, y, GRASP_Z], speed * 0.5, settle_s=0.2)
    streamer.gripper(0.0)
    streamer.move_to([x, y, SAFE_Z], speed * 0.5, settle_s=0.2)


def place(streamer: Streamer, x: float, y: float, yaw: float, speed: float = 0.25) -> None:
    s = rm.BLOCK_SIZE
    streamer.move_to([x, y, SAFE_Z], speed, yaw=yaw, settle_s=0.2)
    streamer.move_to([x, y, GRASP_Z + 0.001], speed * 0.5, settle_s=0.3)
    streamer.gripper(s + 2 * CLEARANCE, settle_s=0.6)
    streamer.move_to([x, y, SAFE_Z], speed * 0.5, settle_s=0.2)


def push(streamer: Streamer, x: float, y: float, direction_yaw: float, distance: float,
         speed: float = 0.05, contact_depth: float = 0.01) -> None:
    """Push the block at (x, y) along ``direction_yaw`` by ``distance`` with both fingertips."""
    s = rm.BLOCK_SIZE
    d = np.array([math.cos(direction_yaw), math.sin(direction_yaw)])
    closing_yaw = direction_yaw + math.pi / 2  # fingers side by side across the push
    back = s / 2 + contact_depth + rm.FINGER_WIDTH / 2
    start = np.array([x, y]) - d * back
    end = start + d * (distance + contact_depth)
    streamer.move_to([*start, SAFE_Z], 0.25, yaw=closing_yaw, settle_s=0.1)
    streamer.gripper(PUSH_OPENING, settle_s=0.5)
    streamer.move_to([*start, PUSH_Z], 0.1, settle_s=0.2)
    streamer.move_to([*end, PUSH_Z], speed, settle_s=0.2)
    retreat = end - d * 0.02
    streamer.move_to([*retreat, PUSH_Z], 0.05, settle_s=0.1)
    streamer.move_to([*retreat, SAFE_Z], 0.1, settle_s=0.1)
