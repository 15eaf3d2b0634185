"""Scenes: the workspace, the blocks in it and (in ``msgs_py.goal``) the layout they must reach.

A ``Scene`` validates itself on construction, so every ``Scene`` object in the program is
consistent: no overlapping blocks, every footprint inside the workspace, goal ids known,
goal slots inside the workspace and not overlapping, no more goal slots than blocks.
A goal layout as published on ``/goal_layout`` is a ``Scene`` without blocks; the planner
adds the perceived blocks with ``Scene.with_blocks`` and gets the remaining checks then.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from msgs_py.cell import BLOCK_SIZE
from msgs_py.checks import (
    boolean,
    check_keys,
    finite_float,
    integer,
    positive_float,
    reject_duplicates,
    require_list,
    require_mapping,
)
from msgs_py.errors import MessageError
from msgs_py.footprint import block_corners, overlapping_blocks
from msgs_py.goal import Goal
from msgs_py.poses import BlockPose, Pose2D, poses_to_array

SCHEMA_VERSION = 1

#: Footprints may poke out of the workspace by this much (m) and still count as inside:
#: floating-point slack for slots computed from a grid spec, not a physical allowance.
CONTAINMENT_TOL = 1e-9


def square_half_extent(side: float, theta: float) -> float:
    """Half the x (and y) extent of a square of ``side`` turned by ``theta``."""
    return 0.5 * side * (abs(math.cos(theta)) + abs(math.sin(theta)))


@dataclass(frozen=True, slots=True)
class Workspace:
    """Axis-aligned table region (m, ``world``) that blocks may occupy."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float

    def __post_init__(self) -> None:
        if not self.x_min < self.x_max:
            raise MessageError("workspace.x_max", self.x_max, f"must exceed x_min={self.x_min}")
        if not self.y_min < self.y_max:
            raise MessageError("workspace.y_max", self.y_max, f"must exceed y_min={self.y_min}")

    @property
    def area(self) -> float:
        return (self.x_max - self.x_min) * (self.y_max - self.y_min)

    @property
    def center(self) -> tuple[float, float]:
        return (0.5 * (self.x_min + self.x_max), 0.5 * (self.y_min + self.y_max))

    def grown(self, margin: float) -> Workspace:
        """This region with ``margin`` added on every side (negative: taken off)."""
        return Workspace(self.x_min - margin, self.x_max + margin, self.y_min - margin,
                         self.y_max + margin)

    def contains_square(self, pose: Pose2D | BlockPose, side: float) -> bool:
        """True when the whole footprint of a square of ``side`` at ``pose`` lies inside."""
        half_extent = square_half_extent(side, pose.theta)
        return (
            pose.x - half_extent >= self.x_min - CONTAINMENT_TOL
            and pose.x + half_extent <= self.x_max + CONTAINMENT_TOL
            and pose.y - half_extent >= self.y_min - CONTAINMENT_TOL
            and pose.y + half_extent <= self.y_max + CONTAINMENT_TOL
        )

    def to_dict(self) -> dict[str, float]:
        return {"x_min": self.x_min, "x_max": self.x_max, "y_min": self.y_min, "y_max": self.y_max}

    @classmethod
    def from_dict(cls, data: Any, field: str = "workspace") -> Workspace:
        data = require_mapping(field, data)
        keys = ("x_min", "x_max", "y_min", "y_max")
        check_keys(field, data, keys)
        return cls(*(finite_float(f"{field}.{k}", data[k]) for k in keys))


@dataclass(frozen=True, slots=True)
class Scene:
    """Workspace, block size, the blocks' current poses and (optionally) the goal."""

    workspace: Workspace
    block_size: float = BLOCK_SIZE
    blocks: tuple[BlockPose, ...] = ()
    goal: Goal | None = None
    version: int = SCHEMA_VERSION

    def __post_init__(self) -> None:
        object.__setattr__(self, "blocks", tuple(self.blocks))
        if self.version != SCHEMA_VERSION:
            raise MessageError("version", self.version, f"unsupported; this is v{SCHEMA_VERSION}")
        positive_float("block_size", self.block_size)
        self._check_blocks()
        if self.goal is not None:
            self._check_goal(self.goal)

    # --- validation -------------------------------------------------------------------------
    def _check_blocks(self) -> None:
        reject_duplicates("blocks", "id", [b.id for b in self.blocks])
        for k, b in enumerate(self.blocks):
            if not self.workspace.contains_square(b, self.block_size):
                raise MessageError(
                    f"blocks[{k}]", b.to_dict(), f"footprint leaves the workspace {self._ws()}"
                )
        for i, j in overlapping_blocks(_footprints(self.blocks, self.block_size)):
            raise MessageError(
                f"blocks[{j}]",
                self.blocks[j].to_dict(),
                f"overlaps blocks[{i}] (id {self.blocks[i].id})",
            )

    def _check_goal(self, goal: Goal) -> None:
        poses = goal.slot_poses(self.block_size)
        where = "goal.grid" if goal.grid is not None else "goal.poses"
        for k, p in enumerate(poses):
            if not self.workspace.contains_square(p, self.block_size):
                raise MessageError(
                    f"{where}[{k}]", p.to_dict(), f"goal slot leaves the workspace {self._ws()}"
                )
        for i, j in overlapping_blocks(_footprints(poses, self.block_size)):
            raise MessageError(f"{where}[{j}]", poses[j].to_dict(), f"overlaps goal slot {i}")
        if not self.blocks:
            return  # a bare goal layout: the id checks wait for the blocks
        if len(poses) > len(self.blocks):
            raise MessageError(
                where, len(poses), f"more goal slots than blocks ({len(self.blocks)} blocks)"
            )
        known = {b.id for b in self.blocks}
        for k, slot in enumerate(goal.slots):
            if slot.id is not None and slot.id not in known:
                raise MessageError(
                    f"goal.poses[{k}].id", slot.id, f"unknown block id; blocks are {sorted(known)}"
                )

    def _ws(self) -> str:
        w = self.workspace
        return f"x [{w.x_min}, {w.x_max}], y [{w.y_min}, {w.y_max}]"

    # --- queries ----------------------------------------------------------------------------
    @property
    def block_ids(self) -> list[int]:
        return [b.id for b in self.blocks]

    def block(self, block_id: int) -> BlockPose:
        for b in self.blocks:
            if b.id == block_id:
                return b
        raise KeyError(block_id)

    def with_blocks(self, blocks: Sequence[BlockPose]) -> Scene:
        """The same workspace and goal with other block poses (validated anew)."""
        return Scene(self.workspace, self.block_size, tuple(blocks), self.goal, self.version)

    def with_goal(self, goal: Goal | None) -> Scene:
        return Scene(self.workspace, self.block_size, self.blocks, goal, self.version)

    def goal_assignment(self) -> dict[int, Pose2D]:
        """Labeled goal poses by block id (empty when there is no goal)."""
        if self.goal is None:
            return {}
        return self.goal.assignment(self.block_ids, self.block_size)

    @property
    def density(self) -> float:
        return len(self.blocks) * self.block_size**2 / self.workspace.area

    # --- serialisation ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "version": self.version,
            "workspace": self.workspace.to_dict(),
            "block_size": self.block_size,
            "blocks": [b.to_dict() for b in self.blocks],
        }
        if self.goal is not None:
            out["goal"] = self.goal.to_dict()
            out["labeled"] = self.goal.labeled
            out["yaw_exact"] = self.goal.yaw_exact
        return out

    @classmethod
    def from_dict(cls, data: Any, field: str = "") -> Scene:
        data = require_mapping(field or "scene", data)
        prefix = f"{field}." if field else ""
        check_keys(
            field,
            data,
            ("version", "workspace"),
            ("block_size", "blocks", "goal", "labeled", "yaw_exact"),
        )
        version = integer(f"{prefix}version", data["version"])
        if version != SCHEMA_VERSION:
            raise MessageError(
                f"{prefix}version", version, f"unsupported; expected {SCHEMA_VERSION}"
            )
        workspace = Workspace.from_dict(data["workspace"], f"{prefix}workspace")
        block_size = positive_float(f"{prefix}block_size", data.get("block_size", BLOCK_SIZE))
        raw_blocks = require_list(f"{prefix}blocks", data.get("blocks", []))
        blocks = tuple(
            BlockPose.from_dict(b, f"{prefix}blocks[{k}]") for k, b in enumerate(raw_blocks)
        )
        labeled = boolean(f"{prefix}labeled", data.get("labeled", True))
        yaw_exact = boolean(f"{prefix}yaw_exact", data.get("yaw_exact", False))
        goal = None
        if data.get("goal") is not None:
            goal = Goal.from_dict(data["goal"], labeled, yaw_exact, f"{prefix}goal")
        elif "labeled" in data or "yaw_exact" in data:
            raise MessageError(f"{prefix}labeled", labeled, "given without a goal")
        return cls(workspace, block_size, blocks, goal, version)


def _footprints(poses: Sequence[Pose2D | BlockPose], block_size: float):
    """Footprint corners (K, 4, 2) of blocks or slots."""
    xyt = poses_to_array(poses)
    return block_corners(xyt[:, 0], xyt[:, 1], xyt[:, 2], block_size)
