"""Scenes and goals: the workspace, the blocks in it and the layout they must reach.

A ``Scene`` validates itself on construction, so every ``Scene`` object in the program is
consistent: no overlapping blocks, every footprint inside the workspace, goal ids known,
goal slots inside the workspace and not overlapping, no more goal slots than blocks.
A goal layout as published on ``/goal_layout`` is a ``Scene`` without blocks; the planner
adds the perceived blocks with ``Scene.with_blocks`` and gets the remaining checks then.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

from msgs_py.cell import BLOCK_SIZE
from msgs_py.checks import (
    boolean,
    check_keys,
    finite_float,
    integer,
    non_negative_float,
    positive_float,
    require_list,
    require_mapping,
)
from msgs_py.errors import MessageError
from msgs_py.footprint import block_corners, overlapping_blocks
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
class GridSpec:
    """A rows x cols grid of blocks separated by ``gap`` (m), centred and rotated by theta.

    Slots are numbered row-major from the grid's (-x, -y) corner in the grid's own frame:
    slot ``r * cols + c`` sits at local ((c - (cols-1)/2) * pitch, (r - (rows-1)/2) * pitch).
    """

    rows: int
    cols: int
    center: tuple[float, float]
    theta: float = 0.0
    gap: float = 0.003

    def slot_poses(self, block_size: float) -> list[Pose2D]:
        pitch = block_size + self.gap
        c, s = math.cos(self.theta), math.sin(self.theta)
        poses = []
        for r in range(self.rows):
            for col in range(self.cols):
                lx = (col - 0.5 * (self.cols - 1)) * pitch
                ly = (r - 0.5 * (self.rows - 1)) * pitch
                poses.append(
                    Pose2D(
                        self.center[0] + c * lx - s * ly,
                        self.center[1] + s * lx + c * ly,
                        self.theta,
                    )
                )
        return poses

    def to_dict(self) -> dict[str, Any]:
        return {
            "rows": self.rows,
            "cols": self.cols,
            "center": [self.center[0], self.center[1]],
            "theta": self.theta,
            "gap": self.gap,
        }

    @classmethod
    def from_dict(cls, data: Any, field: str = "goal.grid") -> GridSpec:
        data = require_mapping(field, data)
        check_keys(field, data, ("rows", "cols", "center"), ("theta", "gap"))
        center = require_list(f"{field}.center", data["center"])
        if len(center) != 2:
            raise MessageError(f"{field}.center", data["center"], "expected [x, y]")
        return cls(
            rows=integer(f"{field}.rows", data["rows"], minimum=1),
            cols=integer(f"{field}.cols", data["cols"], minimum=1),
            center=(
                finite_float(f"{field}.center[0]", center[0]),
                finite_float(f"{field}.center[1]", center[1]),
            ),
            theta=finite_float(f"{field}.theta", data.get("theta", 0.0)),
            gap=non_negative_float(f"{field}.gap", data.get("gap", 0.003)),
        )


@dataclass(frozen=True, slots=True)
class GoalSlot:
    """One goal pose; ``id`` names the block that must fill it (None when unlabeled)."""

    x: float
    y: float
    theta: float = 0.0
    id: int | None = None

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.theta)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {} if self.id is None else {"id": self.id}
        out.update({"x": self.x, "y": self.y, "theta": self.theta})
        return out

    @classmethod
    def from_dict(cls, data: Any, field: str) -> GoalSlot:
        data = require_mapping(field, data)
        check_keys(field, data, ("x", "y"), ("theta", "id"))
        block_id = data.get("id")
        return cls(
            finite_float(f"{field}.x", data["x"]),
            finite_float(f"{field}.y", data["y"]),
            Pose2D(0.0, 0.0, finite_float(f"{field}.theta", data.get("theta", 0.0))).theta,
            None if block_id is None else integer(f"{field}.id", block_id, minimum=0),
        )


@dataclass(frozen=True, slots=True)
class Goal:
    """Target layout: explicit ``slots`` or a ``grid``; labeled or not.

    With ``labeled`` explicit slots each name a block; blocks not named are free (a
    retrieval goal). With a labeled grid, slot k belongs to the k-th smallest block id.
    With ``labeled=False`` any block may fill any slot. Cube yaw is met modulo 90 degrees
    unless ``yaw_exact``.
    """

    slots: tuple[GoalSlot, ...] = ()
    grid: GridSpec | None = None
    labeled: bool = True
    yaw_exact: bool = False

    def __post_init__(self) -> None:
        if self.grid is not None and self.slots:
            raise MessageError("goal", "poses and grid", "give either poses or grid, not both")
        if self.grid is None and not self.slots:
            raise MessageError("goal", {}, "needs poses or a grid")
        for k, slot in enumerate(self.slots):
            if self.labeled and slot.id is None:
                raise MessageError(f"goal.poses[{k}].id", None, "a labeled goal names a block")
            if not self.labeled and slot.id is not None:
                raise MessageError(
                    f"goal.poses[{k}].id", slot.id, "an unlabeled goal (labeled: false) has no ids"
                )
        ids = [s.id for s in self.slots if s.id is not None]
        _reject_duplicates("goal.poses", "id", ids)

    def slot_poses(self, block_size: float) -> list[Pose2D]:
        if self.grid is not None:
            return self.grid.slot_poses(block_size)
        return [s.pose for s in self.slots]

    @property
    def n_slots(self) -> int:
        return self.grid.rows * self.grid.cols if self.grid is not None else len(self.slots)

    def assignment(self, block_ids: Iterable[int], block_size: float) -> dict[int, Pose2D]:
        """Labeled goal: block id -> goal pose, for the blocks the goal constrains."""
        if not self.labeled:
            raise MessageError("labeled", False, "an unlabeled goal has no fixed assignment")
        poses = self.slot_poses(block_size)
        if self.grid is not None:
            return dict(zip(sorted(block_ids), poses, strict=False))
        return {s.id: p for s, p in zip(self.slots, poses, strict=True) if s.id is not None}

    def to_dict(self) -> dict[str, Any]:
        if self.grid is not None:
            return {"grid": self.grid.to_dict()}
        return {"poses": [s.to_dict() for s in self.slots]}

    @classmethod
    def from_dict(
        cls, data: Any, labeled: bool = True, yaw_exact: bool = False, field: str = "goal"
    ) -> Goal:
        data = require_mapping(field, data)
        check_keys(field, data, (), ("poses", "grid"))
        if ("poses" in data) == ("grid" in data):
            raise MessageError(field, sorted(data), "give exactly one of 'poses' or 'grid'")
        if "grid" in data:
            grid = GridSpec.from_dict(data["grid"], f"{field}.grid")
            return cls(grid=grid, labeled=labeled, yaw_exact=yaw_exact)
        raw = require_list(f"{field}.poses", data["poses"])
        if not raw:
            raise MessageError(f"{field}.poses", raw, "must list at least one pose")
        slots = tuple(GoalSlot.from_dict(p, f"{field}.poses[{k}]") for k, p in enumerate(raw))
        return cls(slots=slots, labeled=labeled, yaw_exact=yaw_exact)


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
        _reject_duplicates("blocks", "id", [b.id for b in self.blocks])
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


def _reject_duplicates(field: str, key: str, values: list[int]) -> None:
    seen: dict[int, int] = {}
    for k, value in enumerate(values):
        if value in seen:
            raise MessageError(
                f"{field}[{k}].{key}", value, f"duplicate {key} (also at {field}[{seen[value]}])"
            )
        seen[value] = k
