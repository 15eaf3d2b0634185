"""What the simulated cell reports and takes beyond the robot's own topics.

``SimEvents``: the event monitor's counts and events since the last reset (``/sim/events``);
``SimEvent``: one counted event (an unintended contact, two blocks touching while one moves, a
block lost); ``Disturbance``: a simulated hand nudging a block (``/sim/disturb``, fault
injection). Like the rest of msgs_py they validate themselves on construction and import no
ROS package; the codecs are in ``msgs_py.ros.sim``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from msgs_py.checks import finite_float, integer
from msgs_py.errors import MessageError

#: Kinds of event the monitor counts (``nodes/sim/events.py``).
SIM_EVENT_TYPES = ("unintended_contact", "block_contact", "block_lost", "fault")
#: Faults the sim can be asked to inject (``/sim/fault``; ``SimFault``).
SIM_FAULT_KINDS = ("drop", "slip", "miss", "remove_block", "add_block", "camera_noise")

#: What a robot part touching a block is called.
ROBOT_PARTS = ("arm", "gripper", "finger")


def _block(where: str, value: Any, optional: bool = False) -> int | None:
    if value is None and optional:
        return None
    return integer(where, value, minimum=0)


@dataclass(frozen=True, slots=True)
class SimEvent:
    """One counted event at simulated time ``time_s``.

    ``unintended_contact``: ``robot`` (arm, gripper, finger) touched ``block``, which was not
    the ``manipulated`` one. ``block_contact``: ``block`` and ``other_block`` touched while one
    of them moved. ``block_lost``: ``block`` is lost for ``reason``.
    """

    type: str
    time_s: float
    block: int
    other_block: int | None = None
    manipulated: int | None = None
    robot: str = ""
    reason: str = ""

    def __post_init__(self) -> None:
        if self.type not in SIM_EVENT_TYPES:
            raise MessageError("type", self.type, f"expected one of {list(SIM_EVENT_TYPES)}")
        finite_float("time_s", self.time_s)
        _block("block", self.block)
        _block("other_block", self.other_block, optional=True)
        _block("manipulated", self.manipulated, optional=True)
        contact = self.type == "block_contact"
        if contact != (self.other_block is not None):
            raise MessageError("other_block", self.other_block,
                               "a block contact names the other block; other events do not")
        if (self.type == "unintended_contact") != bool(self.robot):
            raise MessageError("robot", self.robot,
                               "an unintended contact names the robot part; other events do not")
        if self.robot and self.robot not in ROBOT_PARTS:
            raise MessageError("robot", self.robot, f"expected one of {list(ROBOT_PARTS)}")
        if (self.type in ("block_lost", "fault")) != bool(self.reason):
            raise MessageError("reason", self.reason,
                               "a lost block or a fault has a reason; other events do not")
        if self.type in ("block_lost", "fault") and self.manipulated is not None:
            raise MessageError("manipulated", self.manipulated, "contacts only")

    def to_dict(self) -> dict[str, Any]:
        """The event as the monitor writes it (run reports keep this form)."""
        out: dict[str, Any] = {"t": self.time_s, "type": self.type}
        if self.type == "unintended_contact":
            out.update(robot=self.robot, block=self.block, manipulated=self.manipulated)
        elif self.type == "block_contact":
            out.update(blocks=[self.block, self.other_block], manipulated=self.manipulated)
        else:
            out.update(block=self.block, reason=self.reason)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "event") -> SimEvent:
        """From the monitor's dict (``EventMonitor.events``)."""
        kind = data.get("type")
        try:
            if kind == "block_contact":
                first, second = data["blocks"]
                return cls(kind, data["t"], first, other_block=second,
                           manipulated=data.get("manipulated"))
            if kind == "unintended_contact":
                return cls(kind, data["t"], data["block"], robot=data["robot"],
                           manipulated=data.get("manipulated"))
            return cls(kind, data["t"], data["block"], reason=data.get("reason", ""))
        except (KeyError, TypeError, ValueError) as err:
            raise MessageError(where, data, f"not a monitor event ({err})") from None
        except MessageError as err:
            raise MessageError(f"{where}.{err.field}", err.value, err.reason) from None


@dataclass(frozen=True, slots=True)
class SimEvents:
    """The monitor's counts and events since the last reset, at simulated time ``stamp_ns``."""

    unintended_contacts: int = 0
    blocks_lost: int = 0
    events: tuple[SimEvent, ...] = ()
    stamp_ns: int = 0
    #: blocks off the table at ``stamp_ns`` (in the fingers): a run that ended with one left
    #: it held
    raised: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "events", tuple(self.events))
        object.__setattr__(self, "raised", tuple(self.raised))
        integer("unintended_contacts", self.unintended_contacts, minimum=0)
        integer("blocks_lost", self.blocks_lost, minimum=0)
        for k, block in enumerate(self.raised):
            integer(f"raised[{k}]", block, minimum=0)

    def to_dict(self) -> dict[str, Any]:
        return {"unintended_contacts": self.unintended_contacts, "blocks_lost": self.blocks_lost,
                "events": [e.to_dict() for e in self.events], "blocks_raised": list(self.raised)}

    @classmethod
    def from_summary(cls, summary: dict[str, Any], stamp_ns: int = 0) -> SimEvents:
        """From ``EventMonitor.summary()``; an event of a kind this layer does not know raises
        MessageError naming it (``events[3]``)."""
        events = tuple(SimEvent.from_dict(e, f"events[{k}]")
                       for k, e in enumerate(summary.get("events", ())))
        return cls(summary["unintended_contacts"], summary["blocks_lost"], events, stamp_ns,
                   tuple(summary.get("blocks_raised", ())))


@dataclass(frozen=True, slots=True)
class Disturbance:
    """Nudge ``block`` by about (``dx``, ``dy``) metres in world."""

    block: int
    dx: float
    dy: float

    def __post_init__(self) -> None:
        _block("block", self.block)
        finite_float("dx", self.dx)
        finite_float("dy", self.dy)


@dataclass(frozen=True, slots=True)
class SimFault:
    """A fault for the sim to inject: ``kind`` (``SIM_FAULT_KINDS``); ``block`` for
    remove_block / add_block, ``pose`` (x, y, theta in world) for add_block, ``value`` (grey
    levels) for camera_noise."""

    kind: str
    block: int | None = None
    pose: tuple[float, float, float] | None = None
    value: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in SIM_FAULT_KINDS:
            raise MessageError("kind", self.kind, f"expected one of {list(SIM_FAULT_KINDS)}")
        if self.kind in ("remove_block", "add_block"):
            _block("block", self.block)
        if self.kind == "add_block":
            if self.pose is None or len(self.pose) != 3:
                raise MessageError("pose", self.pose, "add_block needs x, y, theta")
            for name, v in zip(("pose.x", "pose.y", "pose.theta"), self.pose, strict=True):
                finite_float(name, v)
        if self.kind == "camera_noise" and not finite_float("value", self.value) >= 0.0:
            raise MessageError("value", self.value, "a noise level is >= 0")
