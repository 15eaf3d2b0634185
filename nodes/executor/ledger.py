"""Where the simulated time of a run goes: per action kind, looking, replanning.

The executor charges the time between two ticks to what it was doing (a pick-and-place,
a push, looking, waiting for a plan), so a run report can hold its simulated time per action
kind against what the robot's data sheets allow (docs/benchmarks.md).
"""

from __future__ import annotations

from collections import defaultdict

from msgs_py.status import ExecutorState as State
from nodes.executor.belief import Belief
from nodes.executor.steps import Activity, Step


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


def activity_of(state: State, belief: Belief, step: Step | None) -> str:
    """What a tick in ``state`` with ``step`` playing (None: none) goes to: waiting for a
    plan, recovering, the camera check, the kind of the plan's current action (a step of
    handling its block, while running it or moving on to it), looking (getting out of the
    camera's view: ``look``; at rest for the frame and its detection: ``look_wait``), or
    other."""
    if state is State.REPLANNING:
        return "replan"
    if state is State.RECOVERING:
        return "recover"
    if belief.checking_camera:
        return "camera_check"
    if step is not None and step.activity is Activity.BLOCK and state in (
            State.RUNNING, State.OBSERVING):
        action = belief.current
        return action.type if action is not None and action.block == step.block else "other"
    if state is State.OBSERVING and step is None:
        return "look_wait"  # at rest: the frame, or its detection, is on its way
    if state is State.OBSERVING or (step is not None and step.activity is Activity.LOOK):
        return "look"
    return "other"
