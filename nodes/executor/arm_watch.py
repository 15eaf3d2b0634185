"""Is the arm node there to take the executor's setpoints? Its status cannot say so when the
node is gone, so the executor judges from what arrives.

A chaos run killed the arm node mid-descent: the executor streamed on along its script while
nobody listened, and the node that came back chased the latest setpoints, the fingers onto a
block at 378 N. ``ArmWatch`` names the loss so the core holds the script (``ArmHold``) and,
once the arm takes the executor's setpoints again, backs up and looks from where the arm
stands.

* Gone: no ``/arm/tcp_pose`` between ``silent_ticks`` of the executor's ticks. Counted on
  arrival, not by the reports' stamps: a loaded executor reads late reports in a burst, but
  never a tick's worth of none while the arm node lives (it reports at the joint-state rate).
* Back: reporting again and, when the executor wants the arm, its status names the executor
  as the lease holder and the setpoints go on that lease's topic. A node that restarted
  holds no lease: until the executor took it again, setpoints would be refused or unheard.
* Inherited: an executor that restarted finds the arm leased to its own name, by the
  executor that died. The public topic is closed to it until it takes the lease again
  (about a second): a script streamed meanwhile would run on unheard, and the arm would
  jump to wherever it had got to. Held the same way, as if the arm had been lost.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

#: The arm node is judged gone after this long without a TCP report (s): many joint-state
#: periods of any driver (the UR's 500 Hz, the sim's), far less than a node's respawn.
ARM_SILENT_S = 0.5


@dataclass
class ArmWatch:
    silent_ticks: int  #: ticks without a TCP report that make the arm node gone
    _quiet_ticks: int = 0
    _heard: bool = False  # a TCP report ever arrived
    holder: str = ""  #: the arm's lease holder as its status last named it (since it was lost)
    lost: str | None = None  #: why the arm does not take the setpoints now, or None

    @classmethod
    def at_rate(cls, rate_hz: float) -> ArmWatch:
        return cls(max(2, round(ARM_SILENT_S * rate_hz)))

    def on_tcp(self) -> None:
        self._heard, self._quiet_ticks = True, 0

    def on_status(self, holder: str) -> None:
        self.holder = holder

    def on_tick(self, wants_arm: bool, takes_my_commands: Callable[[str], bool],
                inherited: Callable[[str], bool] = lambda holder: False) -> str | None:
        """Why the arm cannot take the executor's setpoints at this tick, or None.
        ``takes_my_commands(holder)``: the lease client's word on the holder a status named;
        ``inherited(holder)``: that holder is a predecessor under this executor's name."""
        if self._heard:
            self._quiet_ticks += 1
        if self._quiet_ticks > self.silent_ticks:
            # whatever the dead node said of its lease is void: the next one must name us
            self.lost, self.holder = (
                f"the arm node is silent (no /arm/tcp_pose for {ARM_SILENT_S} s)", "")
        elif self.lost is not None and wants_arm and not takes_my_commands(self.holder):
            self.lost = (f"the arm node is back, its lease held by {self.holder or 'nobody'}: "
                         "taking it again")
        elif wants_arm and inherited(self.holder):
            # a predecessor of this name (an executor respawned), or this node's own lease
            # granted a moment before its private topic connects (every first start)
            self.lost = (f"the arm is leased to {self.holder}, this node's name, but not on "
                         "this node's connected lease yet: taking it")
        else:
            self.lost = None
        return self.lost
