"""Goals: the layout the blocks must reach, as explicit slots or a grid.

A ``Goal`` validates itself on construction (slot ids unique, labeled or not); what it can only
be checked against (the workspace, the blocks) is checked by the ``Scene`` that holds it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from msgs_py.checks import (
    check_keys,
    finite_float,
    integer,
    non_negative_float,
    reject_duplicates,
    require_list,
    require_mapping,
)
from msgs_py.errors import MessageError
from msgs_py.poses import Pose2D


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
        reject_duplicates("goal.poses", "id", ids)

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
