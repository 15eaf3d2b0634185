"""How fast simulated time runs: lockstep with the motion commands, else a real-time floor.

A real cell's time runs on whatever happens. In the sim, time can run faster than the wall
clock, but only as fast as the nodes that act on it keep up: while motion commands come (joint
trajectories from the arm node, each ending a short horizon after the executor's newest
setpoint), the sim may run as fast as it can up to ``margin`` before the end of the newest
one, however fast or slow the machine is (lockstep: the arm node and, through it, the executor
are never outrun). When no command is in force (the executor waits for a detection, or for a
plan: work whose duration is the machine's, not the robot's), simulated time passes at
``real_time_factor`` against the wall clock, as the real robot's would while it waits.
``real_time_factor`` 0 lets it run free, lockstep or not (nothing then keeps it from
outrunning the commanders).
"""

from __future__ import annotations

import time


class Pacer:
    """Decides whether the sim may take its next physics step, and how long to wait if not."""

    def __init__(self, real_time_factor: float, margin: float) -> None:
        self.real_time_factor = float(real_time_factor)
        self.margin = float(margin)
        self.commanded_until: float | None = None
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

    def on_command(self, until: float | None) -> None:
        """A motion command arrived that says what to do up to ``until`` (simulated s)."""
        if until is not None and (self.commanded_until is None or until > self.commanded_until):
            self.commanded_until = until

    def wait_before_step(self, sim_time: float, wall_time: float) -> float:
        """Wall seconds to wait before stepping from ``sim_time`` (0: step now)."""
        if not self._started:
            self.restart(sim_time, wall_time)
        if (self.margin > 0.0 and self.commanded_until is not None
                and sim_time < self.commanded_until - self.margin):
            self.restart(sim_time, wall_time)  # lockstep progress: the floor counts from here
            return 0.0
        if self.real_time_factor <= 0.0:
            return 0.0
        ahead = (sim_time - self._sim0) / self.real_time_factor - (wall_time - self._wall0)
        if ahead < -1.0:  # fell behind (rendering, load): do not try to catch up
            self.restart(sim_time, wall_time)
            return 0.0
        return max(0.0, ahead)
