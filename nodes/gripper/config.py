"""The gripper node's parameters (frozen dataclass; names, defaults, units as in
config/gripper.yaml)."""

from __future__ import annotations

from dataclasses import dataclass

from nodes.common.lease import LeaseConfig
from nodes.common.params import param
from nodes.gripper.watch import WatchLimits


@dataclass(frozen=True)
class GripperConfig:
    at_position: float = param(
        0.0005, "the fingers are at their command within this gap (the 2F-85's position "
        "resolution is about 0.4 mm)", unit="m")
    still_speed: float = param(
        0.002, "fingers slower than this (gap change per second) have stopped", unit="m/s")
    still_s: float = param(
        0.04, "... measured over this long; also how long a new command counts as moving",
        unit="s")
    never_moved_s: float = param(
        0.5, "a gripper that has not moved this long after a command far from where it stands "
        "is reported (not activated, faulted)", unit="s")

    def __post_init__(self) -> None:
        for name in ("at_position", "still_speed", "still_s", "never_moved_s"):
            if not getattr(self, name) > 0.0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")

    def limits(self) -> WatchLimits:
        return WatchLimits(self.at_position, self.still_speed, self.still_s, self.never_moved_s)


GRIPPER_PARAMETERS = (("", GripperConfig), ("lease.", LeaseConfig))
