"""Is an unlabeled goal met? Every slot needs some block on it (nearest-block matching).

Slots do not overlap and the tolerance is far below a block size, so a block can stand on at
most one slot and a slot holds at most one block: matching each slot to a block within
tolerance is enough, no assignment problem to solve. Yaw counts modulo 90 degrees unless the
goal asks for ``yaw_exact``. The executor verifies unlabeled goals the same way.
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


def unlabeled_goal_errors(scene: Scene, poses: Iterable[Pose2D], tol_xy: float,
                          tol_yaw: float) -> list[str]:
    """One message per unfilled slot, naming it and the nearest block's offset."""
    blocks = list(poses)
    slots = scene.goal.slot_poses(scene.block_size) if scene.goal is not None else []
    errors = []
    for k in unfilled_slots(scene, blocks, tol_xy, tol_yaw):
        slot = slots[k]
        near = min(blocks, key=lambda p: math.hypot(p.x - slot.x, p.y - slot.y), default=None)
        where = ("no block at all" if near is None else
                 f"nearest block {math.hypot(near.x - slot.x, near.y - slot.y) * 1000:.1f} mm "
                 "away")
        errors.append(f"end: goal slot {k} ({slot.x:.4f}, {slot.y:.4f}) is empty ({where})")
    return errors
