"""A planning time budget: one deadline and one stop request, handed down to every layer.

``dispatch.plan_goal`` starts one ``Budget`` from the ``budget_s`` parameter and the caller's
stop request (the node's shutdown); every planner and search below takes that object and no
time limit of its own. A layer that tries things in turn gives each a part of it:
``capped(s)`` ends s seconds from now at the latest, ``share(f)`` after the fraction f of the
time left; both end at the parent's deadline at the latest and stop with it.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field


class OutOfTime(Exception):
    """The budget's deadline passed or a stop was requested."""


@dataclass(frozen=True)
class Budget:
    deadline: float  # time.monotonic()
    should_stop: Callable[[], bool] | None = None
    started: float = field(default_factory=time.monotonic)

    @classmethod
    def of(cls, seconds: float, should_stop: Callable[[], bool] | None = None) -> Budget:
        now = time.monotonic()
        return cls(now + seconds, should_stop, now)

    def remaining(self) -> float:
        return self.deadline - time.monotonic()

    def elapsed(self) -> float:
        return time.monotonic() - self.started

    def stopped(self) -> bool:
        """A stop was requested (not merely out of time)."""
        return self.should_stop is not None and self.should_stop()

    def expired(self) -> bool:
        return time.monotonic() > self.deadline or self.stopped()

    def check(self) -> None:
        """Raises OutOfTime when expired (for loops deep inside a search)."""
        if self.expired():
            raise OutOfTime

    def capped(self, seconds: float) -> Budget:
        """A part ending ``seconds`` from now, or at this budget's deadline if sooner."""
        now = time.monotonic()
        return Budget(min(self.deadline, now + seconds), self.should_stop, now)

    def share(self, fraction: float) -> Budget:
        """A part ending after ``fraction`` of the time left."""
        return self.capped(fraction * max(self.remaining(), 0.0))
