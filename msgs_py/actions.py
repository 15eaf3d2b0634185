"""Manipulation actions and plans.

``PickPlace`` lifts a block with one of its two grasps and sets it down elsewhere; ``Push``
slides it in a straight line along ``direction`` (a unit vector in ``world``) by
``distance`` metres, yaw unchanged. The structural checks here (unit direction, endpoints
consistent with direction and distance, grasp 0 or 1) keep malformed actions out; whether
an action is *feasible* among the other blocks is the replay validator's job.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

from msgs_py.checks import (
    check_keys,
    finite_float,
    integer,
    non_negative_float,
    require_list,
    require_mapping,
    text,
)
from msgs_py.errors import MessageError
from msgs_py.poses import Pose2D
from msgs_py.scene import SCHEMA_VERSION, Scene

#: Slack (m) between a push's endpoints and from + direction * distance; also the tolerance on
#: |direction| = 1. Far below any physical effect, large enough for JSON float round-trips.
PUSH_CONSISTENCY_TOL = 1e-6


@dataclass(frozen=True, slots=True)
class PickPlace:
    """Grasp ``block`` at ``from_``, carry it above the blocks, place it at ``to``.

    ``grasp`` 0 closes the fingers along the block's local x axis, 1 along its local y axis.
    """

    block: int
    from_: Pose2D
    to: Pose2D
    grasp: int = 0
    type: ClassVar[str] = "pick_place"

    def __post_init__(self) -> None:
        if self.grasp not in (0, 1):
            raise MessageError("grasp", self.grasp, "must be 0 (local x) or 1 (local y)")

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type,
            "block": self.block,
            "from": self.from_.to_dict(),
            "to": self.to.to_dict(),
            "grasp": self.grasp,
        }


@dataclass(frozen=True, slots=True)
class Push:
    """Slide ``block`` from ``from_`` along the unit ``direction`` by ``distance`` (m)."""

    block: int
    from_: Pose2D
    to: Pose2D
    direction: tuple[float, float]
    distance: float
    type: ClassVar[str] = "push"

    def __post_init__(self) -> None:
        dx, dy = self.direction
        if abs(math.hypot(dx, dy) - 1.0) > PUSH_CONSISTENCY_TOL:
            raise MessageError("direction", list(self.direction), "must be a unit vector")
        if self.distance <= 0.0:
            raise MessageError("distance", self.distance, "must be > 0")
        ex, ey = self.from_.x + dx * self.distance, self.from_.y + dy * self.distance
        if math.hypot(ex - self.to.x, ey - self.to.y) > PUSH_CONSISTENCY_TOL:
            raise MessageError("to", self.to.to_dict(), "must equal from + direction * distance")
        if abs(math.remainder(self.to.theta - self.from_.theta, 2 * math.pi)) > 1e-9:
            raise MessageError("to.theta", self.to.theta, "a push keeps the yaw of 'from'")

    @classmethod
    def between(cls, block: int, start: Pose2D, end: Pose2D) -> Push:
        """The push from ``start`` to ``end`` (same yaw), with direction and distance derived."""
        dx, dy = end.x - start.x, end.y - start.y
        distance = math.hypot(dx, dy)
        if distance == 0.0:
            raise MessageError("distance", 0.0, "a push must move the block")
        return cls(block, start, Pose2D(end.x, end.y, start.theta), (dx / distance, dy / distance),
                   distance)

    def to_dict(self) -> dict[str, Any]:
        return {
            "type": self.type,
            "block": self.block,
            "from": self.from_.to_dict(),
            "to": self.to.to_dict(),
            "direction": [self.direction[0], self.direction[1]],
            "distance": self.distance,
        }


Action = PickPlace | Push


def action_from_dict(data: Any, field: str = "action") -> Action:
    data = require_mapping(field, data)
    kind = data.get("type")
    block = integer(f"{field}.block", data.get("block"), minimum=0) if "block" in data else None
    try:
        if kind == "pick_place":
            check_keys(field, data, ("type", "block", "from", "to"), ("grasp",))
            return PickPlace(
                block,
                Pose2D.from_dict(data["from"], f"{field}.from"),
                Pose2D.from_dict(data["to"], f"{field}.to"),
                integer(f"{field}.grasp", data.get("grasp", 0)),
            )
        if kind == "push":
            check_keys(field, data, ("type", "block", "from", "to", "direction", "distance"))
            direction = require_list(f"{field}.direction", data["direction"])
            if len(direction) != 2:
                raise MessageError(f"{field}.direction", direction, "expected [dx, dy]")
            return Push(
                block,
                Pose2D.from_dict(data["from"], f"{field}.from"),
                Pose2D.from_dict(data["to"], f"{field}.to"),
                (
                    finite_float(f"{field}.direction[0]", direction[0]),
                    finite_float(f"{field}.direction[1]", direction[1]),
                ),
                finite_float(f"{field}.distance", data["distance"]),
            )
    except MessageError as err:
        if err.field.startswith(field):
            raise
        raise MessageError(f"{field}.{err.field}", err.value, err.reason) from None
    raise MessageError(f"{field}.type", kind, "expected 'pick_place' or 'push'")


@dataclass(frozen=True, slots=True)
class Plan:
    """An action sequence with everything needed to check it on its own.

    ``params`` holds every geometry and cost parameter the planner used; ``scene`` (when
    given) is the start state and goal the plan was made for.
    """

    actions: tuple[Action, ...]
    planner: str = "pirs"
    params: dict[str, Any] = field(default_factory=dict)
    seed: int = 0
    planning_time_s: float = 0.0
    cost: float = 0.0
    plan_id: str = ""
    scene: Scene | None = None
    version: int = SCHEMA_VERSION

    def __post_init__(self) -> None:
        object.__setattr__(self, "actions", tuple(self.actions))

    def __len__(self) -> int:
        return len(self.actions)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "version": self.version,
            "plan_id": self.plan_id,
            "planner": self.planner,
            "params": dict(self.params),
            "seed": self.seed,
            "planning_time_s": self.planning_time_s,
            "cost": self.cost,
        }
        if self.scene is not None:
            out["scene"] = self.scene.to_dict()
        out["actions"] = [a.to_dict() for a in self.actions]
        return out

    @classmethod
    def from_dict(cls, data: Any, field: str = "") -> Plan:
        data = require_mapping(field or "plan", data)
        p = f"{field}." if field else ""
        check_keys(
            field,
            data,
            ("version", "actions"),
            ("plan_id", "planner", "params", "seed", "planning_time_s", "cost", "scene"),
        )
        version = integer(f"{p}version", data["version"])
        if version != SCHEMA_VERSION:
            raise MessageError(f"{p}version", version, f"unsupported; expected {SCHEMA_VERSION}")
        params = dict(require_mapping(f"{p}params", data.get("params", {})))
        for key, value in params.items():
            _check_param(f"{p}params.{key}", value)
        actions = require_list(f"{p}actions", data["actions"])
        return cls(
            actions=tuple(action_from_dict(a, f"{p}actions[{k}]") for k, a in enumerate(actions)),
            planner=text(f"{p}planner", data.get("planner", "pirs")),
            params=params,
            seed=integer(f"{p}seed", data.get("seed", 0)),
            planning_time_s=non_negative_float(
                f"{p}planning_time_s", data.get("planning_time_s", 0.0)
            ),
            cost=finite_float(f"{p}cost", data.get("cost", 0.0)),
            plan_id=text(f"{p}plan_id", data.get("plan_id", "")),
            scene=Scene.from_dict(data["scene"], f"{p}scene") if data.get("scene") else None,
            version=version,
        )


def _check_param(field: str, value: Any) -> None:
    """Plan parameters are plain scalars (or lists of them): numbers must be finite."""
    if isinstance(value, list | tuple):
        for k, item in enumerate(value):
            _check_param(f"{field}[{k}]", item)
    elif isinstance(value, bool | str) or value is None:
        return
    else:
        finite_float(field, value)
