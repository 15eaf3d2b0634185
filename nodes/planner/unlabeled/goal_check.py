"""Which slots of an unlabeled goal hold a block (nearest-block matching)?

Slots do not overlap and the tolerance is far below a block size, so a block can stand on at
most one slot and a slot holds at most one block: matching each slot to a block within
tolerance is enough, no assignment problem to solve. Yaw counts modulo 90 degrees unless the
goal asks for ``yaw_exact``. The replay validator and the executor check the end state the
same way; here it gives the lower bound and which blocks already stand on a slot.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from msgs_py import Pose2D, Scene


def on_slot(pose: Pose2D, slot: Pose2D, tol_xy: float, tol_yaw: float, yaw_exact: bool) -> bool:
    period = 2.0 * math.pi if yaw_exact else 0.5 * math.pi
    return (math.hypot(pose.x - slot.x, pose.y - slot.y) <= tol_xy + 1e-9
            and abs(math.remainder(pose.theta - slot.theta, period)) <= tol_yaw + 1e-9)


def unfilled_slots(scene: Scene, poses: Iterable[Pose2D], tol_xy: float, tol_yaw: float
                   ) -> list[int]:
    """Indices of the goal slots no block stands on (the scene's goal must be unlabeled)."""
    goal = scene.goal
    if goal is None:
        return []
    blocks = list(poses)
    slots = goal.slot_poses(scene.block_size)
    return [k for k, slot in enumerate(slots)
            if not any(on_slot(p, slot, tol_xy, tol_yaw, goal.yaw_exact) for p in blocks)]


def goal_slots(scene: Scene) -> list[tuple[int, Pose2D]]:
    """(block id, pose) per slot of a labeled goal, (slot index, pose) of an unlabeled one:
    what plan drawings and markers show."""
    goal = scene.goal
    if goal is None:
        return []
    if goal.labeled:
        return sorted(scene.goal_assignment().items())
    return list(enumerate(goal.slot_poses(scene.block_size)))
