"""What the world's parts (``Fingers``, ``Hand``, ``ForceGuard``) read of the ``SimWorld`` they
belong to: its physics client and bodies, its configuration and clock, the event log, and the
people-in-the-cell actions (take a block away, put one down). A protocol, so the parts depend
on this narrow view and the world on them, never the other way round."""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from msgs_py import BlockPose
from nodes.sim.config import SimConfig
from nodes.sim.events import EventMonitor


class WorldBodies(Protocol):
    client: Any  # the world's pybullet BulletClient
    robot: int  # the arm-and-gripper body
    finger_joints: list[int]
    finger_links: set[int]
    block_bodies: dict[int, int]  # block id -> body
    body_to_block: dict[int, int]
    config: SimConfig
    monitor: EventMonitor | None
    noise_std: float  # the camera's read noise (grey levels), a fault may raise it

    @property
    def time_s(self) -> float: ...

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]: ...

    def block_position(self, block_id: int) -> np.ndarray: ...

    def remove_block(self, block_id: int) -> None: ...

    def add_block(self, block: BlockPose) -> None: ...
