"""Event monitor: unintended contacts and lost blocks, as the cell benchmark counts them.

Pure logic: the world hands over, every few physics steps, the contact pairs it sees (already
classified as arm / gripper / finger / block) and each block's pose and speeds.

* **Unintended contact**: the robot (fingers, gripper body or arm) touching a block other
  than the one being manipulated (``manipulated``, learned from ``/executor/status``), or two
  blocks touching while one of them moves. One contact *episode* counts once: a pair that
  stays in touch is not counted again until it has been apart for ``release_s``. An episode
  that began on the manipulated block stays intended while it lasts, whatever
  ``/executor/status`` says meanwhile: the fingers still holding a block when the executor's
  status stops naming it (a respawned executor that does not yet know what it holds) did
  not touch it anew.
* **Block lost**: a resting block off the table, with its centre more than ``lost_margin``
  outside the workspace, or tipped over (its tag face more than ``tip_angle`` from up).
  Each block is lost at most once.
* **Raised**: a block whose centre stands more than a block size above the table, now (in
  the fingers). Not an event: at the end of a run, a block still raised was left held.

Counts are cumulative since the monitor was made (the world makes a new one on reset).
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from msgs_py import Workspace


class ContactKind(enum.Enum):
    ARM = "arm"
    GRIPPER = "gripper"
    FINGER = "finger"
    BLOCK = "block"


Party = tuple[ContactKind, int]  # (kind, block id or robot link index)
ROBOT_KINDS = (ContactKind.ARM, ContactKind.GRIPPER, ContactKind.FINGER)


@dataclass
class EventMonitor:
    workspace: Workspace
    table_extent: tuple[float, float, float, float]
    block_size: float
    lost_margin: float = 0.02
    moving_speed: float = 0.01  #: m/s: a block faster than this is "moving"
    moving_spin: float = 0.2  #: rad/s: or spinning faster than this
    release_s: float = 0.1  #: s apart before the same pair can count again
    tip_angle: float = math.radians(30.0)
    manipulated: int | None = None
    unintended_contacts: int = 0
    blocks_lost: int = 0
    events: list[dict[str, Any]] = field(default_factory=list)
    _active: dict[tuple, float] = field(default_factory=dict)  # pair -> last time seen
    _counted: set = field(default_factory=set)  # pairs counted in their current episode
    _intended: set = field(default_factory=set)  # robot-block pairs whose episode began intended
    _lost: set = field(default_factory=set)
    _raised: set = field(default_factory=set)  # blocks off the table in the last observation

    def update(self, t: float, contacts: list[tuple[Party, Party]],
               blocks: dict[int, tuple[np.ndarray, np.ndarray, float, float]]) -> list[dict]:
        """Feed one observation; returns the events it produced.

        Args:
            t: simulated time (s).
            contacts: touching pairs, each party (kind, block id | robot link).
            blocks: block id -> (position, quaternion xyzw, linear speed, angular speed).
        """
        new: list[dict[str, Any]] = []
        for a, b in contacts:
            key, event = self._contact_event(a, b, blocks)
            if key is None:
                continue
            self._active[key] = t
            if event is None and key[0] == "robot":
                self._intended.add(key)
            if event is not None and key not in self._counted and key not in self._intended:
                self._counted.add(key)
                self.unintended_contacts += 1
                new.append({"t": round(t, 4), **event})
        for key, seen in list(self._active.items()):
            if t - seen > self.release_s:
                del self._active[key]
                self._counted.discard(key)
                self._intended.discard(key)
        self._raised = {i for i, (pos, *_) in blocks.items() if self._off_table(float(pos[2]))}
        for block_id, (pos, quat, speed, spin) in blocks.items():
            if block_id in self._lost:
                continue
            reason = self._lost_reason(pos, quat, speed, spin)
            if reason:
                self._lost.add(block_id)
                self.blocks_lost += 1
                new.append({"t": round(t, 4), "type": "block_lost", "block": block_id,
                            "reason": reason})
        self.events.extend(new)
        return new

    def _contact_event(self, a: Party, b: Party, blocks) -> tuple[tuple | None, dict | None]:
        if a[0] != ContactKind.BLOCK:
            a, b = b, a
        if a[0] != ContactKind.BLOCK:
            return None, None  # robot with itself: not an event
        block = a[1]
        if b[0] in ROBOT_KINDS:
            key = ("robot", block, b[0].value)
            if block == self.manipulated:
                return key, None
            return key, {"type": "unintended_contact", "robot": b[0].value, "block": block,
                         "manipulated": self.manipulated}
        other = b[1]
        key = ("blocks", min(block, other), max(block, other))
        if self._moving(blocks.get(block)) or self._moving(blocks.get(other)):
            return key, {"type": "block_contact", "blocks": [key[1], key[2]],
                         "manipulated": self.manipulated}
        return key, None

    def _moving(self, state) -> bool:
        return state is not None and (state[2] > self.moving_speed or state[3] > self.moving_spin)

    def _lost_reason(self, pos, quat, speed: float, spin: float) -> str:
        x0, x1, y0, y1 = self.table_extent
        x, y, z = (float(v) for v in pos)
        if z < -self.block_size or not (x0 <= x <= x1 and y0 <= y <= y1):
            return "off the table"
        resting = speed < self.moving_speed and spin < self.moving_spin
        if not resting or self._off_table(z):  # carried or in flight: judged when it rests
            return ""
        qx, qy = float(quat[0]), float(quat[1])
        up_z = 1.0 - 2.0 * (qx * qx + qy * qy)  # world z of the block's z axis
        if up_z < math.cos(self.tip_angle):
            return "tipped over"
        ws, m = self.workspace, self.lost_margin
        if not (ws.x_min - m <= x <= ws.x_max + m and ws.y_min - m <= y <= ws.y_max + m):
            return "out of the workspace"
        return ""

    def _off_table(self, z: float) -> bool:
        """A block centre at height ``z`` (m) stands off the table: carried, or in flight."""
        return z > self.block_size

    def summary(self) -> dict[str, Any]:
        return {"unintended_contacts": self.unintended_contacts, "blocks_lost": self.blocks_lost,
                "events": list(self.events), "blocks_raised": sorted(self._raised)}
