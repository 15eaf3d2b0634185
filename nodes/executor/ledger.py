"""Where the simulated time of a run goes: per action kind, looking, replanning.

The executor charges the time between two ticks to what it was doing (a pick-and-place,
a push, looking, waiting for a plan), so a run report can hold its simulated time per action
kind against what the robot's data sheets allow (docs/benchmarks.md).
"""

from __future__ import annotations

from collections import defaultdict


class TimeLedger:
    """Seconds per activity, from the ticks' clock."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = defaultdict(float)
        self._last: float | None = None

    def charge(self, now: float, activity: str) -> None:
        """Charge the time since the previous call to ``activity``."""
        if self._last is not None and now > self._last:
            self.seconds[activity] += now - self._last
        self._last = now

    def metrics(self) -> dict[str, float]:
        return {f"time_{name}_s": round(value, 3) for name, value in sorted(self.seconds.items())}
