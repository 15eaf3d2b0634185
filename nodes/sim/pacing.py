"""How fast simulated time runs: lockstep with the motion commands, else a real-time floor.

A real cell's time runs on whatever happens. In the sim, time can run faster than the wall
clock, but only as fast as the nodes that act on it keep up. Motion commands (joint trajectory
snippets from the arm node, each ending a short horizon after the executor's newest setpoint)
say what the arm does until their end:

* while the newest command moves the arm, the sim runs as fast as it can up to ``margin``
  before its end, and there waits for the next one (lockstep: the arm node and, through it,
  the executor are never outrun, however loaded the machine; a real arm is given its next
  piece of trajectory in time). A commander that sends nothing for ``stall_wall_s`` of wall
  time has stopped: the floor below applies again.
* while the newest command holds the arm still, the same lockstep holds for as long as the
  commander keeps sending (it holds the arm while it waits for something the robot does: the
  fingers closing, the tool settling), but no further than ``HOLD_LEAD_S`` past the command's
  start, however far ahead it holds (the commander waits for an event and reacts to it only
  as fast as this lets it see it), and it gives up after ``hold_stall_wall_s``: a commander
  that has gone quiet is waiting for something that is not the robot's.
* when no command is in force (the executor waits for a detection or a plan: work whose
  duration is the machine's, not the robot's), simulated time passes at ``real_time_factor``
  against the wall clock, as the real robot's would.

Without the lockstep on holds, every wait of the executor for the robot ran at the floor, so
the latency of the nodes' round trip (wall time, longer on a loaded machine) became simulated
time: the same default run took 84-96 s of simulated time.

``real_time_factor`` 0 lets it run free (nothing then keeps it from outrunning the
commanders).
"""

from __future__ import annotations

import time

#: A commander mid-motion that sends nothing this long (wall s) has stopped.
STALL_WALL_S = 0.5
#: A commander holding the arm still that sends nothing this long (wall s) has gone quiet.
HOLD_STALL_WALL_S = 0.1
#: A command that holds the arm still lets the sim run at most this far past its start (s):
#: whoever sent it waits for something the robot does, and sees it this much later at most.
HOLD_LEAD_S = 0.08
#: While waiting for a commander, look again this often (wall s).
LOCKSTEP_POLL_S = 0.002


class Pacer:
    """Decides whether the sim may take its next physics step, and how long to wait if not."""

    def __init__(self, real_time_factor: float, margin: float,
                 stall_wall_s: float = STALL_WALL_S,
                 hold_stall_wall_s: float = HOLD_STALL_WALL_S) -> None:
        self.real_time_factor = float(real_time_factor)
        self.margin = float(margin)
        self.stall_wall_s = float(stall_wall_s)
        self.hold_stall_wall_s = float(hold_stall_wall_s)
        self.commanded_until: float | None = None
        self.moving = False  #: the newest command moves the arm
        self.waiting = "floor"  #: why the last wait (lockstep: a command is due; floor)
        self._command_start: float | None = None
        self._command_wall: float | None = None
        self._wall0 = 0.0
        self._sim0 = 0.0
        self._started = False

    def restart(self, sim_time: float, wall_time: float | None = None) -> None:
        """Measure the real-time floor from here (after a reset or a render)."""
        self._wall0 = time.monotonic() if wall_time is None else wall_time
        self._sim0 = sim_time
        self._started = True
        if self.commanded_until is not None and self.commanded_until > sim_time + 1.0:
            self.commanded_until = None  # from before a reset
            self._command_start = None
            self.moving = False

    def on_command(self, until: float | None, moving: bool = True,
                   wall_time: float | None = None, start: float | None = None) -> None:
        """A motion command arrived that says what to do up to ``until`` (simulated s); one
        that holds still counts no further than HOLD_LEAD_S past its ``start``."""
        if until is None:
            return
        self._command_wall = time.monotonic() if wall_time is None else wall_time
        if start is not None:  # a trajectory replaces the one before it (if not older)
            if self._command_start is not None and start < self._command_start:
                return
            self._command_start = start
            self.commanded_until = until if moving else min(until, start + HOLD_LEAD_S)
            self.moving = moving
        elif self.commanded_until is None or until >= self.commanded_until:
            self.commanded_until = until
            self.moving = moving

    def wait_before_step(self, sim_time: float, wall_time: float) -> float:
        """Wall seconds to wait before stepping from ``sim_time`` (0: step now)."""
        if not self._started:
            self.restart(sim_time, wall_time)
        until = self.commanded_until
        if self.margin > 0.0 and until is not None:
            if sim_time < until - self.margin:
                self.restart(sim_time, wall_time)  # lockstep progress: the floor counts from here
                return 0.0
            patience = self.stall_wall_s if self.moving else self.hold_stall_wall_s
            stalled = (self._command_wall is None
                       or wall_time - self._command_wall > patience)
            if not stalled:
                self.restart(sim_time, wall_time)
                self.waiting = "lockstep"
                return LOCKSTEP_POLL_S  # the commander's next command is due
        self.waiting = "floor"
        if self.real_time_factor <= 0.0:
            return 0.0
        ahead = (sim_time - self._sim0) / self.real_time_factor - (wall_time - self._wall0)
        if ahead < -1.0:  # fell behind (rendering, load): do not try to catch up
            self.restart(sim_time, wall_time)
            return 0.0
        return max(0.0, ahead)


class LoopTimes:
    """Where the sim loop's wall time goes (stepping, publishing, commands such as renders,
    waiting for the commanders, the real-time floor), summed up in the log now and then: on a
    loaded machine, the first thing to look at when the cell runs slowly."""

    def __init__(self, period_wall_s: float = 30.0) -> None:
        self.period = period_wall_s
        self.seconds: dict[str, float] = {}
        self._since = time.monotonic()
        self._sim_since: float | None = None

    def add(self, what: str, seconds: float) -> None:
        self.seconds[what] = self.seconds.get(what, 0.0) + seconds

    def report(self, sim_time: float, wall_time: float | None = None) -> str | None:
        """A summary line once a period has passed (and the counts start again), else None."""
        now = time.monotonic() if wall_time is None else wall_time
        if self._sim_since is None:
            self._sim_since = sim_time
        span = now - self._since
        if span < self.period:
            return None
        parts = ", ".join(f"{what} {100 * v / span:.0f}%"
                          for what, v in sorted(self.seconds.items(), key=lambda kv: -kv[1]))
        line = (f"sim loop, last {span:.0f} s: {sim_time - self._sim_since:.1f} s simulated "
                f"({(sim_time - self._sim_since) / span:.2f}x); {parts}")
        self.seconds, self._since, self._sim_since = {}, now, sim_time
        return line


def period_steps(physics_hz: float, rates_hz: dict[str, float]) -> dict[str, int]:
    """Every how many physics steps each of ``rates_hz`` (Hz of simulated time) is due; 0 for
    a rate of 0 (never)."""
    return {name: max(1, round(physics_hz / hz)) if hz > 0 else 0
            for name, hz in rates_hz.items()}
