"""Grasp supervision: is what the fingers report what the executor expects?

A Robotiq 2F-85 driver reports, besides the finger position, an object-detection status
(``gOBJ``): the fingers are moving, they stopped on an object while opening or while
closing, or they reached the requested position (no object). With the measured gap and the
gap last requested (by anyone: a stray command from another program shows here too), that
tells the executor, within one status period, whether

* a grip closed on a block of the expected width (else: a miss),
* a held block is still held while the arm lifts, carries and lowers it (else: a drop, seen
  as the fingers closing past the block's width; a block that slips but stays between the
  pads still reads as held and is caught when the camera sees where it was set down),
* the fingers are empty after a release,
* nobody else moved the fingers (a stray open or close command: a misfire).

``GraspSupervisor`` is pure logic: the core tells it what to expect, feeds it readings and
acts on the ``GraspFault`` it returns.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from msgs_py.status import GripperStatus


class Expect(enum.Enum):
    """What the fingers should be doing."""

    NOTHING = "nothing"  #: not judged (no script running, or the gripper is being commanded)
    OPEN = "open"  #: open (or opening) to ``opening``, empty
    HOLD = "hold"  #: holding a block of ``block_size``


class FaultKind(enum.Enum):
    MISSED = "grasp missed"  #: a grip closed on nothing, or on something not a block wide
    DROPPED = "dropped"  #: a held block left the fingers
    MISFIRE = "gripper misfire"  #: the gripper was commanded by someone else
    NOT_RELEASED = "not released"  #: the fingers did not let go after a release


@dataclass(frozen=True, slots=True)
class GraspFault:
    kind: FaultKind
    detail: str
    holding_something: bool  #: the fingers have something in them now

    def describe(self) -> str:
        return f"{self.kind.value}: {self.detail}"


#: A held block reads this much narrower or wider than its size (pads compress, m).
HELD_BELOW = 0.002
HELD_ABOVE = 0.0015
#: A requested gap further than this from the executor's own command is not ours (m) ...
COMMAND_TOL = 0.0005
#: ... except in reports from before the executor's last command can have reached it (s),
COMMAND_IN_TRANSIT_S = 0.3
#: ... or, for this long (s), reports that still echo the command before it: once in a
#: default run the driver's echo of a new command came 0.35 s after it (cause not found; a
#: false misfire: the run stopped, let go and looked); a stray command's request is neither.
PREVIOUS_IN_TRANSIT_S = 1.0


class GraspSupervisor:
    """Judges gripper readings against what the executor expects.

    Args:
        block_size: the cube's side (m): the gap of a held block.
    """

    def __init__(self, block_size: float) -> None:
        self.block_size = block_size
        self.expect = Expect.NOTHING
        self.block: int | None = None
        self.commanded: float | None = None  #: the executor's own last gripper command
        self._commanded_at = 0.0
        self._previous: float | None = None  #: the one before it, differing
        self.last: GripperStatus | None = None

    # --- what to expect ------------------------------------------------------------------------
    def commanding(self, opening: float, at: float) -> None:
        """The executor sends ``opening`` at time ``at`` (s): stop judging the fingers until
        they have done it."""
        if self.commanded is not None and abs(opening - self.commanded) > COMMAND_TOL:
            self._previous = self.commanded
        self.commanded, self._commanded_at = opening, at
        self.expect = Expect.NOTHING

    def reassert(self, at: float) -> None:
        """The executor sent its own command again at ``at`` (s), after a stray one."""
        self._commanded_at = at

    def expect_open(self) -> None:
        self.expect, self.block = Expect.OPEN, None

    def expect_hold(self, block: int) -> None:
        self.expect, self.block = Expect.HOLD, block

    def stop_judging(self) -> None:
        self.expect, self.block = Expect.NOTHING, None

    # --- what the fingers hold now -------------------------------------------------------------
    def holds_block(self, reading: GripperStatus | None = None) -> bool:
        """The fingers stopped closing on something a block wide."""
        r = reading or self.last
        return r is not None and r.holds_object and self._block_wide(r)

    def holds_something(self, reading: GripperStatus | None = None) -> bool:
        r = reading or self.last
        return r is not None and r.holds_object

    def _block_wide(self, r: GripperStatus) -> bool:
        return self.block_size - HELD_BELOW <= r.gap <= self.block_size + HELD_ABOVE

    # --- judging -----------------------------------------------------------------------------
    def _ours(self, reading: GripperStatus) -> bool:
        """The request the gripper reports is the executor's, or comes from before its last
        command reached the gripper (any request, or the executor's command before it)."""
        assert self.commanded is not None
        since = reading.stamp_ns * 1e-9 - self._commanded_at
        echoes_previous = (self._previous is not None and since <= PREVIOUS_IN_TRANSIT_S
                           and abs(reading.requested_gap - self._previous) <= COMMAND_TOL)
        return (abs(reading.requested_gap - self.commanded) <= COMMAND_TOL
                or since <= COMMAND_IN_TRANSIT_S or echoes_previous)

    def _dropped(self, r: GripperStatus) -> bool:
        """The held block is gone: the force-limited fingers close past its width at once
        (within a report or two). A block sliding in the pads makes the gripper report
        "moving" for a moment, but the gap stays the block's width: that is not a drop."""
        return not self._block_wide(r)

    def after_grip(self, reading: GripperStatus) -> GraspFault | None:
        """Judge a finished grip: a block of the expected width is held, or a miss."""
        self.last = reading
        if self.holds_block(reading):
            return None
        held = reading.holds_object
        what = (f"the fingers stopped at {reading.gap * 1e3:.1f} mm, not on a "
                f"{self.block_size * 1e3:.1f} mm block" if held
                else f"the fingers closed to {reading.gap * 1e3:.1f} mm on nothing")
        return GraspFault(FaultKind.MISSED, what, holding_something=held)

    def after_release(self, reading: GripperStatus) -> GraspFault | None:
        """Judge a finished release: the fingers are open and empty."""
        self.last = reading
        if reading.holds_object:
            return GraspFault(FaultKind.NOT_RELEASED,
                              f"the fingers still hold something ({reading.gap * 1e3:.1f} mm)",
                              holding_something=True)
        return None

    def on_reading(self, reading: GripperStatus) -> GraspFault | None:
        """A reading while a script runs; a fault when the fingers are not as expected."""
        self.last = reading
        if self.commanded is not None and not self._ours(reading):
            return GraspFault(
                FaultKind.MISFIRE,
                f"the gripper was sent to {reading.requested_gap * 1e3:.1f} mm by someone else "
                f"(the executor asked for {self.commanded * 1e3:.1f} mm)",
                holding_something=reading.holds_object)
        if self.expect is Expect.HOLD and self._dropped(reading):
            return GraspFault(FaultKind.DROPPED,
                              f"block {self.block} left the fingers (gap "
                              f"{reading.gap * 1e3:.1f} mm)", holding_something=False)
        if self.expect is Expect.OPEN and reading.holds_object:
            return GraspFault(FaultKind.MISFIRE,
                              f"the fingers closed on something ({reading.gap * 1e3:.1f} mm)",
                              holding_something=True)
        return None
