"""Planar poses of blocks on the table, in the ``world`` frame (REP 103: m, rad)."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from msgs_py.checks import check_keys, finite_float, integer, require_mapping


def wrap_angle(theta: float) -> float:
    """Wrap an angle to (-pi, pi], the convention of every yaw in densepack."""
    wrapped = math.remainder(theta, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


def yaw_difference(a: float, b: float, symmetry: float = 2.0 * math.pi) -> float:
    """Smallest absolute difference between two yaws modulo ``symmetry`` (pi/2 for a cube)."""
    d = math.remainder(a - b, symmetry)
    return abs(d)


@dataclass(frozen=True, slots=True)
class Pose2D:
    """A block pose without identity: centre (x, y) in m and yaw theta in rad."""

    x: float
    y: float
    theta: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "theta", wrap_angle(self.theta))

    def to_dict(self) -> dict[str, float]:
        return {"x": self.x, "y": self.y, "theta": self.theta}

    @classmethod
    def from_dict(cls, data: Any, field: str = "pose") -> Pose2D:
        data = require_mapping(field, data)
        check_keys(field, data, ("x", "y"), ("theta",))
        return cls(
            finite_float(f"{field}.x", data["x"]),
            finite_float(f"{field}.y", data["y"]),
            finite_float(f"{field}.theta", data.get("theta", 0.0)),
        )

    def distance_to(self, other: Pose2D) -> float:
        return math.hypot(self.x - other.x, self.y - other.y)


@dataclass(frozen=True, slots=True)
class BlockPose:
    """A block (identified by its AprilTag id) at a planar pose in ``world``."""

    id: int
    x: float
    y: float
    theta: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "theta", wrap_angle(self.theta))

    @property
    def pose(self) -> Pose2D:
        return Pose2D(self.x, self.y, self.theta)

    def moved_to(self, pose: Pose2D) -> BlockPose:
        return BlockPose(self.id, pose.x, pose.y, pose.theta)

    def to_dict(self) -> dict[str, float | int]:
        return {"id": self.id, "x": self.x, "y": self.y, "theta": self.theta}

    @classmethod
    def from_dict(cls, data: Any, field: str = "block") -> BlockPose:
        data = require_mapping(field, data)
        check_keys(field, data, ("id", "x", "y"), ("theta",))
        return cls(
            integer(f"{field}.id", data["id"], minimum=0),
            finite_float(f"{field}.x", data["x"]),
            finite_float(f"{field}.y", data["y"]),
            finite_float(f"{field}.theta", data.get("theta", 0.0)),
        )


def poses_to_array(poses: Iterable[Pose2D | BlockPose]) -> np.ndarray:
    """(K, 3) array of x, y, theta: poses as the vectorised geometry takes them."""
    return np.array([(p.x, p.y, p.theta) for p in poses], dtype=float).reshape(-1, 3)
