"""Comparing what the camera sees with what should be there.

Cube footprints repeat every 90 degrees, so yaw errors are taken modulo 90 degrees unless
a goal asks for ``yaw_exact``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from msgs_py import Pose2D, Scene
from msgs_py.cell import CUBE_SYMMETRY
from msgs_py.poses import yaw_difference


@dataclass(frozen=True, slots=True)
class Deviation:
    block: int
    position_error: float
    yaw_error: float

    def describe(self) -> str:
        return (f"block {self.block} off by {self.position_error * 1e3:.1f} mm / "
                f"{math.degrees(self.yaw_error):.1f} deg")


def deviation(actual: Pose2D, wanted: Pose2D, block: int, yaw_exact: bool = False) -> Deviation:
    symmetry = 2 * math.pi if yaw_exact else CUBE_SYMMETRY
    return Deviation(block, actual.distance_to(wanted),
                     yaw_difference(actual.theta, wanted.theta, symmetry))


def deviations(
    perceived: Mapping[int, Pose2D],
    expected: Mapping[int, Pose2D],
    pos_tol: float,
    yaw_tol: float,
    yaw_exact: bool = False,
) -> tuple[list[Deviation], list[int]]:
    """Blocks beyond tolerance, and expected blocks the camera did not see."""
    off, missing = [], []
    for block, wanted in sorted(expected.items()):
        if block not in perceived:
            missing.append(block)
            continue
        d = deviation(perceived[block], wanted, block, yaw_exact)
        if d.position_error > pos_tol or d.yaw_error > yaw_tol:
            off.append(d)
    return off, missing


def goal_errors(perceived: Mapping[int, Pose2D], scene: Scene) -> list[Deviation]:
    """Every goal slot's error: labeled -> its block; unlabeled -> the nearest perceived block."""
    goal = scene.goal
    if goal is None:
        return []
    if goal.labeled:
        return [
            deviation(perceived[b], pose, b, goal.yaw_exact) if b in perceived
            else Deviation(b, math.inf, math.inf)
            for b, pose in sorted(scene.goal_assignment().items())
        ]
    errors = []
    free = dict(perceived)
    for slot in goal.slot_poses(scene.block_size):
        if not free:
            errors.append(Deviation(-1, math.inf, math.inf))
            continue
        block = min(free, key=lambda b: free[b].distance_to(slot))
        errors.append(deviation(free.pop(block), slot, block, goal.yaw_exact))
    return errors
