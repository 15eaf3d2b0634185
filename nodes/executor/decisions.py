"""What the executor's handlers answer, as typed values: the next state, what the arm does.

A handler does not call the handlers of other concepts: it returns a ``Decision``, and the
core dispatches it through its table until it comes to an ``Enter`` (or a ``Halt``), which
changes the state and starts the ``Script`` it carries. A script's ``Then`` says what its
end leads to, dispatched the same way. So the ways from one state to the next are these
types, and each is handled in one place.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from msgs_py import Plan
from msgs_py.status import ExecutorState as State
from nodes.executor.states import Purpose
from nodes.executor.steps import Step


# --- what a script leads to once it has run to its end ------------------------------------------
@dataclass(frozen=True, slots=True)
class TakeFrame:
    """The arm is out of the camera's view: trigger it."""


@dataclass(frozen=True, slots=True)
class ActionDone:
    """The plan's action ran (the script may end at the look pose)."""


@dataclass(frozen=True, slots=True)
class JudgeOnArrival:
    """Above the next block, moved there while the camera looked: judge its frame now."""


@dataclass(frozen=True, slots=True)
class Parked:
    """Idle, at the park pose."""


@dataclass(frozen=True, slots=True)
class Recovered:
    """A recovery ran: look again, and judge the frame for ``look_for``."""

    look_for: Purpose


@dataclass(frozen=True, slots=True)
class Stopped:
    """The arm parked after a stop or an error (``in_place``: stopped where the fingers,
    which do not open, hold a block, instead of parking)."""

    in_place: bool = False


Then = TakeFrame | ActionDone | JudgeOnArrival | Parked | Recovered | Stopped


@dataclass(frozen=True, slots=True)
class Script:
    """Steps for the arm and what their end leads to. ``brake``: first stop the motion under
    way along its path (a fault in mid-move), then play ``steps`` from where it comes to
    rest; otherwise the steps start from the last commanded pose."""

    steps: Sequence[Step]
    then: Then
    brake: bool = False


# --- decisions ---------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class Enter:
    """Change to ``state`` and play ``script`` (None: the arm goes on with what it does)."""

    state: State
    script: Script | None = None


@dataclass(frozen=True, slots=True)
class Halt:
    """Change to ``state`` and stream nothing more: the arm stays where the script left it."""

    state: State


@dataclass(frozen=True, slots=True)
class Observe:
    """Get out of the camera's view (the park pose, or with ``near`` the look pose beside the
    workspace) and take a frame for ``purpose``; ``keep_tries`` counts it with the triggers
    already made for the same look."""

    purpose: Purpose
    near: bool = False
    keep_tries: bool = False


@dataclass(frozen=True, slots=True)
class LookOnTheWay:
    """After an action: head for the next block and take the frame on the way, at the first
    moment the arm leaves the blocks to judge in view (none: from the look pose)."""


@dataclass(frozen=True, slots=True)
class LookHere:
    """The arm already stands out of view: take the frame for ``purpose`` now."""

    purpose: Purpose


@dataclass(frozen=True, slots=True)
class NextAction:
    """Run the plan's next action from the perceived poses."""


@dataclass(frozen=True, slots=True)
class StartPlan:
    """Run the plan (``plan``, taken first, if given) only if it starts from the world as
    perceived now."""

    plan: Plan | None = None


@dataclass(frozen=True, slots=True)
class VerifyGoal:
    """Every block must stand at its goal."""


@dataclass(frozen=True, slots=True)
class Replan:
    """Ask the planner for a plan from the perceived world."""

    reason: str


@dataclass(frozen=True, slots=True)
class Finish:
    """The run is done; ``detail`` says how it ended."""

    detail: str


@dataclass(frozen=True, slots=True)
class Stop:
    """Stop safely: set down what the fingers hold, then park (``failed``: after an error)."""

    reason: str
    failed: bool


Decision = (Enter | Halt | Observe | LookOnTheWay | LookHere | NextAction | StartPlan
            | VerifyGoal | Replan | Finish | Stop)
