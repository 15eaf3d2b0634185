"""A block the arm has just set down or pushed: the arm's word for where it is (for the
detector's occlusion judgement, and, set down, its hand-eye checks)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from msgs_py.errors import MessageError
from msgs_py.poses import Pose2D


@dataclass(frozen=True, slots=True)
class Placement:
    """Block ``block`` released at ``pose`` (the TCP's x, y and the block's planned yaw, in
    ``world``) at ``stamp_ns``; it was perceived at ``picked_from`` when the fingers closed
    on it, along the axis at ``closing_axis_yaw`` (rad). The fingers centre a block along
    that axis only: across it, the block keeps the offset it was picked up with, unless
    ``squared``: the fingers closed on it along each of its axes in turn at this TCP (the
    camera check), so it stands on the TCP on both axes. ``pushed``: not let go but pushed
    to ``pose`` (the push's planned end; ``picked_from`` where it stood before): where it
    stands, for whether the robot covers it, and no hand-eye equation."""

    block: int
    pose: Pose2D
    picked_from: Pose2D
    closing_axis_yaw: float
    stamp_ns: int = 0
    squared: bool = False
    pushed: bool = False

    def __post_init__(self) -> None:
        if self.block < 0:
            raise MessageError("block", self.block, "block ids are >= 0")
        if not math.isfinite(self.closing_axis_yaw):
            raise MessageError("closing_axis_yaw", self.closing_axis_yaw, "must be finite")
