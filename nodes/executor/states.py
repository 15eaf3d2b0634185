"""The executor's states, the one table of the changes between them, and its small records.

The states are ``msgs_py.status.ExecutorState`` (what ``/executor/status`` publishes, the
one list the goal handling and the codecs use too); ``TRANSITIONS`` lists every change the
executor may make, with its reason (``ExecutorCore`` refuses any other; docs/nodes.md prints
the table). ``Purpose`` says what a frame is judged against, ``Held`` what the fingers hold,
``Tries`` how often something was tried, ``Outputs`` what a tick hands the node.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from msgs_py import Pose2D
from msgs_py.placement import Placement
from msgs_py.status import ExecutorState as State
from nodes.executor.motion import ToolPose

#: Every state change, and why it happens (the executor refuses any other).
TRANSITIONS: dict[State, dict[State, str]] = {
    State.IDLE: {
        State.OBSERVING: "a plan and a start, or a block in the fingers with no run going: "
                         "look before acting",
        State.RECOVERING: "the fingers hold a block at start-up: set it down",
        State.STOPPING: "a motion with no run going (the start-up park) failed: stop safely",
        State.STOPPED: "stop requested",
    },
    State.OBSERVING: {
        State.OBSERVING: "look again (from the park pose)",
        State.RUNNING: "the world is as expected: the next action",
        State.RECOVERING: "a block outside the workspace, two blocks overlapping, or one in the "
                          "fingers: deal with it",
        State.REPLANNING: "the world drifted, or a plan must be checked against it",
        State.DONE: "every block verified at its goal",
        State.IDLE: "the plan is gone, or a block found in the fingers with no run going is "
                    "set down",
        State.STOPPING: "a block is gone, or stop requested",
    },
    State.RUNNING: {
        State.OBSERVING: "action done, or a descent stopped above its end or by a protective "
                         "stop (something in the way): look",
        State.RECOVERING: "a grasp fault: stop, let go, look; or a held block stopped the arm "
                          "on the table (it slid in the fingers): let go there, look",
        State.STOPPING: "an error, or stop requested",
    },
    State.RECOVERING: {
        State.OBSERVING: "recovery done: look again",
        State.RECOVERING: "a fault while recovering",
        State.STOPPING: "no way to recover, or stop requested",
    },
    State.REPLANNING: {
        State.OBSERVING: "the planner has no detection to plan from (restarted): look again",
        State.RUNNING: "a plan that starts from the perceived world",
        State.REPLANNING: "that plan does not fit, or none came",
        State.DONE: "no correction possible, residual within the acceptance tolerance",
        State.STOPPING: "too many replans, or stop requested",
    },
    State.STOPPING: {
        State.STOPPED: "parked after a stop request",
        State.FAILED: "parked after an error (fingers that do not open: stopped where they "
                      "hold the block)",
        State.STOPPING: "set down what the fingers hold first",
    },
    State.STOPPED: {State.IDLE: "start requested"},
    State.DONE: {State.IDLE: "a new plan"},
    State.FAILED: {State.IDLE: "a new plan"},
}

#: States in which the arm is busy with a run: a plan that comes then waits for it to end.
PLANS_WAIT_IN = (State.RUNNING, State.OBSERVING, State.RECOVERING, State.STOPPING)

#: States of a run: the executor holds the arm's and the gripper's leases in them (one
#: commander at a time, ``nodes.common.lease``) and gives them back when the run ends.
CONTROL_STATES = (State.OBSERVING, State.RUNNING, State.RECOVERING, State.REPLANNING,
                  State.STOPPING)


class Purpose(enum.Enum):
    """Why a frame is taken: what the detection is judged against."""

    START = "start"  #: before the first action: the plan must start from the world
    AFTER_ACTION = "after action"  #: every block where it should be after the action
    RESUME = "resume"  #: after a stop: as before
    RECOVERY = "recovery"  #: after a fault: where are the blocks now?
    GOAL = "goal"  #: after the last action: every block at its goal
    IDLE = "idle"  #: no run going (a block found in the fingers is set down): then idle


@dataclass
class Outputs:
    """Side effects the node must carry out after a tick."""

    setpoint: ToolPose | None = None
    #: the setpoints of ticks that came too late (time s, pose), streamed before ``setpoint``
    missed: tuple[tuple[float, ToolPose], ...] = ()
    gripper: float | None = None
    trigger_camera: bool = False
    request_replan: bool = False
    placement: Placement | None = None  #: a block the arm just set down, and where
    unlock_arm: bool = False  #: call /arm/unlock_protective_stop
    log: list[str] = field(default_factory=list)


@dataclass
class Held:
    """A block in the fingers: which (None: not known), where it was picked up, and whether
    it was gripped along both of its axes in turn (centred on the TCP on both)."""

    block: int | None
    picked_from: Pose2D | None = None
    squared: bool = False


@dataclass
class Streak:
    """Tries at the same thing in a row: ``count`` of them, at ``of`` (a block, say)."""

    of: int | None = None
    count: int = 0

    def again(self, of: int) -> int:
        """One more try at ``of``: how many in a row that makes."""
        self.count = self.count + 1 if of == self.of else 1
        self.of = of
        return self.count

    def reset(self) -> None:
        self.of, self.count = None, 0


@dataclass
class Tries:
    """How often the executor has tried to get one thing right, so it can give up in time."""

    grasps: int = 0  #: failed grasps of the current action (each tried again, then replanned)
    release_stalls: int = 0  #: openings that stalled since the last finished action
    stall_z: float = 0.0  #: the tool height where the first of them began (m)
    separations: int = 0  #: overlapping blocks set apart in a row
    setting_apart: int | None = None  #: the block a set-apart is going down for
    apart_blocked: set[int] = field(default_factory=set)  #: ... whose descent met its partner
    bring_ins: Streak = field(default_factory=Streak)  #: a block brought into the workspace


def transitions_markdown() -> str:
    """``TRANSITIONS`` as the Markdown table docs/nodes.md shows (a test keeps the two equal)."""
    lines = ["| from | to | when |", "| --- | --- | --- |"]
    for source, targets in TRANSITIONS.items():
        for target, why in targets.items():
            lines.append(f"| `{source.value}` | `{target.value}` | {why} |")
    return "\n".join(lines)
