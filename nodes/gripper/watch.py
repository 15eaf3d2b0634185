"""A 2F-85's object detection made from its knuckle joint alone.

The Robotiq driver publishes only ``robotiq_85_left_knuckle_joint``'s position (radians; its
velocity is never filled) and reads the gripper's own object-detection register without
publishing it. What the executor's grasp supervision needs is that register's meaning
(``msgs_py.status.GRIPPER_OBJECT_STATES``): moving, stopped on something while opening or
closing, or at the requested position. ``KnuckleWatch`` rebuilds it from the position samples
and the last command anyone sent (it listens on the controller's command topic, so a stray
command from another program shows too):

* at position: within ``at_position_m`` of the command (as pad gap);
* moving: the gap changed by more than ``still_speed_m_s * still_s`` over the last
  ``still_s``, or the command is younger than ``still_s`` (it must reach the gripper first);
* otherwise stopped short of the command: on something while closing (the command is
  narrower than where the fingers stand: they hold it) or while opening.

It also notices a gripper that does not move at all after a command far from where it stands
(``never_moved_s``): not activated, faulted, or unplugged.

Before the first command it sees, the request is taken to be where the fingers stand (nobody
asked for anything else): a node that has just (re)started reports at once, so a commander
that held the lease of the node that died learns from the status that nobody holds it now.
"""

from __future__ import annotations

import collections
from dataclasses import dataclass

from msgs_py.status import GripperStatus
from nodes.robot import gripper_2f85 as g85


@dataclass(frozen=True)
class WatchLimits:
    at_position_m: float = 0.0005
    still_speed_m_s: float = 0.002
    still_s: float = 0.04
    never_moved_s: float = 0.5


class KnuckleWatch:
    def __init__(self, limits: WatchLimits = WatchLimits()) -> None:
        self.limits = limits
        self.requested_gap: float | None = None
        self._command_at: float | None = None
        self._gap_at_command: float | None = None
        self._moved_since_command = False
        self._warned = False
        self._samples: collections.deque[tuple[float, float]] = collections.deque()

    def on_command(self, knuckle: float, at_s: float) -> None:
        """A knuckle command (rad) went to the driver at ``at_s`` (s), from anyone."""
        gap = g85.knuckle_to_gap(knuckle)
        if self.requested_gap is not None and abs(gap - self.requested_gap) < 1e-9:
            return  # the same command again
        self.requested_gap = gap
        self._command_at = at_s
        self._gap_at_command = self._samples[-1][1] if self._samples else None
        self._moved_since_command = False
        self._warned = False

    def on_position(self, knuckle: float, at_s: float) -> GripperStatus:
        """A knuckle position (rad) measured at ``at_s``; the status it makes (before the
        first command, the request is where the fingers stand)."""
        gap = g85.knuckle_to_gap(knuckle)
        self._samples.append((at_s, gap))
        while len(self._samples) > 2 and self._samples[1][0] <= at_s - self.limits.still_s:
            self._samples.popleft()
        if self._gap_at_command is None:
            self._gap_at_command = gap
        if abs(gap - self._gap_at_command) > self.limits.at_position_m:
            self._moved_since_command = True
        if self.requested_gap is None:
            self.requested_gap = gap
        return GripperStatus(gap, self.requested_gap, self._object(gap, at_s),
                             round(at_s * 1e9))

    def _object(self, gap: float, now: float) -> str:
        lim = self.limits
        assert self.requested_gap is not None
        if abs(gap - self.requested_gap) <= lim.at_position_m:
            return "at_position"
        oldest_t, oldest_gap = self._samples[0]
        young = self._command_at is not None and now - self._command_at < lim.still_s
        span = now - oldest_t
        moving = span > 0 and abs(gap - oldest_gap) > lim.still_speed_m_s * max(span,
                                                                                 lim.still_s)
        if young or moving or span < lim.still_s - 1e-9:
            return "moving"
        return "stopped_closing" if self.requested_gap < gap else "stopped_opening"

    def never_moved(self, now: float) -> str:
        """Words for a gripper that has not moved ``never_moved_s`` after a command far from
        where it stood, once per command ("" otherwise)."""
        if (self._warned or self._moved_since_command or self._command_at is None
                or self.requested_gap is None or self._gap_at_command is None):
            return ""
        far = abs(self.requested_gap - self._gap_at_command) > self.limits.at_position_m
        if not far or now - self._command_at < self.limits.never_moved_s:
            return ""
        self._warned = True
        return (f"the gripper did not move in {now - self._command_at:.1f} s after a command "
                f"to {self.requested_gap * 1e3:.1f} mm (it stands at "
                f"{self._gap_at_command * 1e3:.1f} mm): is it activated?")
