"""Rearrange goals, free of ROS: check a goal layout against the cell, follow a goal's run,
and say how it ended.

The ``/rearrange`` action server (``nodes/executor/rearrange.py``) and ``densepack-run`` (which
checks its goal before sending it) share ``check_layout``; the server feeds ``GoalRun`` with
what the executor core reports and carries out what it answers (start the core, report
feedback, finish the goal).

A goal reaches the planner as a goal layout on ``/goal_layout``; the plan made for it is the
one whose scene carries that layout (the planner copies the layout into every plan's scene),
so the run knows its plan, and every replan, by content rather than by timing.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from msgs_py import BlockSet, ExecutorStatus, MessageError, Plan, PlannerStatus, Scene
from msgs_py.cell import TABLE_MARGIN
from msgs_py.status import ExecutorState as State
from msgs_py.tasks import BlockError, RearrangeFeedback
from nodes.executor.verify import goal_errors

#: Horizontal reach of the UR10e (data sheet: 1300 mm from the base axis), which a TCP
#: pointing down at the table reaches less far than this; a workspace corner beyond it is out
#: of reach for certain.
UR10E_REACH_M = 1.3

#: Executor states in which it is moving or about to: a goal sent then would fight the run.
BUSY_STATES = (State.RUNNING, State.OBSERVING, State.RECOVERING, State.REPLANNING,
               State.STOPPING)


def check_layout(layout: Scene, detection: BlockSet | None,
                 safe_box: Sequence[float], reach: float = UR10E_REACH_M) -> None:
    """Refuse a goal layout the cell cannot carry out, naming the field of the goal message.

    ``layout`` is already valid on its own (msgs_py checked NaN, overlapping slots, slots
    outside its workspace, duplicate ids). Here: the workspace (and the table margin around
    it, where fingers stand) must lie in the executor's ``safe_box`` [x_min, x_max, y_min,
    y_max, ...] and within the arm's ``reach``; every block the goal names must be one the
    cell knows (seen or occluded in ``detection``); there must be no more slots than blocks;
    and the blocks seen must stand inside the workspace or on its table margin (the executor
    brings those in before it runs a plan). ``detection=None`` (an executor just
    started, which has not seen the blocks yet) skips the checks against the blocks: the
    planner makes them when it plans, and a goal it refuses fails with its reason.

    Raises:
        MessageError: the first problem, its field under ``layout.``.
    """
    ws = layout.workspace
    x0, x1, y0, y1 = safe_box[:4]
    m = TABLE_MARGIN
    corners = [(x, y) for x in (ws.x_min - m, ws.x_max + m) for y in (ws.y_min - m, ws.y_max + m)]
    for x, y in corners:
        if not (x0 <= x <= x1 and y0 <= y <= y1):
            raise MessageError("layout.workspace", ws.to_dict(),
                               f"with its {m} m table margin it leaves the box the arm may move "
                               f"in (executor safe_box x [{x0}, {x1}], y [{y0}, {y1}])")
        if math.hypot(x, y) > reach:
            raise MessageError("layout.workspace", ws.to_dict(),
                               f"corner ({x:.3f}, {y:.3f}) is {math.hypot(x, y):.3f} m from the "
                               f"arm's base, beyond its reach ({reach} m)")
    if detection is None:
        return
    known = set(detection.ids) | set(detection.missing)
    goal = layout.goal
    assert goal is not None
    for k, slot in enumerate(goal.slots):
        if slot.id is not None and slot.id not in known:
            raise MessageError(f"layout.goal.slots[{k}].block_id", slot.id,
                               f"unknown block; the cell knows {sorted(known)}")
    if goal.n_slots > len(known):
        where = "layout.goal.grid" if goal.grid is not None else "layout.goal.slots"
        raise MessageError(where, goal.n_slots, f"more goal slots than blocks ({len(known)})")
    table = ws.grown(m)
    for block in detection.blocks:  # one on the table margin is brought in by the executor
        if not table.contains_square(block, layout.block_size):
            raise MessageError("layout.workspace", ws.to_dict(),
                               f"block {block.id} at ({block.x:.3f}, {block.y:.3f}) stands "
                               f"outside it and its {m} m table margin")


def plan_is_for(plan: Plan | None, layout: Scene) -> bool:
    """Whether ``plan`` was made for goal layout ``layout``."""
    scene = plan.scene if plan is not None else None
    return (scene is not None and scene.goal == layout.goal
            and scene.workspace == layout.workspace and scene.block_size == layout.block_size)


def block_errors(detection: BlockSet | None, plan: Plan | None) -> tuple[BlockError, ...]:
    """Each goal slot's error from the final detection (labeled: its block; unlabeled: the
    block nearest it); a labeled block not seen is ``found=False``."""
    if detection is None or plan is None or plan.scene is None:
        return ()
    errors: dict[int, BlockError] = {}
    for d in goal_errors({b.id: b.pose for b in detection.blocks}, plan.scene):
        if d.block < 0:
            continue  # an unlabeled slot no block stands near
        if math.isfinite(d.position_error):
            errors[d.block] = BlockError(d.block, d.position_error, min(d.yaw_error, math.pi))
        else:
            errors[d.block] = BlockError(d.block, 0.0, 0.0, found=False)
    return tuple(errors[b] for b in sorted(errors))


@dataclass
class Step:
    """What the server must do after ``GoalRun.update``."""

    feedback: RearrangeFeedback
    start: bool = False  # call the core's request_start()
    outcome: str = ""  # set when the goal is over: succeeded, failed, canceled
    detail: str = ""


@dataclass
class GoalRun:
    """One Rearrange goal, from the moment its layout is sent to the planner to its end.

    ``plan_before``: the id of the plan the executor held when the goal came (it may be for the
    same layout: only a newer plan is this goal's). ``plan_timeout_s``: how long to wait for the
    first plan. Times are seconds on one monotonic clock.
    """

    layout: Scene
    plan_before: str
    started_at: float
    plan_timeout_s: float
    plan_id: str = ""  # the current plan of this goal ("" before the first)
    replans_at_start: float = 0.0
    cancel_requested: bool = False
    planner: PlannerStatus | None = None  # the planner's last word since the goal came
    _last: RearrangeFeedback | None = field(default=None, repr=False)

    def on_planner_status(self, status: PlannerStatus) -> None:
        self.planner = status

    def cancel(self) -> None:
        self.cancel_requested = True

    def update(self, status: ExecutorStatus, plan: Plan | None, now: float) -> Step:
        if not self.plan_id:
            return self._before_plan(status, plan, now)
        corrections = max(0, round(status.metrics.get("replans", 0.0) - self.replans_at_start))
        feedback = RearrangeFeedback(status.state, status.action_index, status.action_total,
                                     status.block, corrections, status.detail)
        if plan is not None and not plan_is_for(plan, self.layout):
            return Step(feedback, outcome="failed",
                        detail=f"the executor took plan {plan.plan_id}, made for another goal "
                        "layout (someone else published on /goal_layout)")
        if plan is not None:
            self.plan_id = plan.plan_id
        if status.state is State.DONE:
            return Step(feedback, outcome="succeeded", detail=status.detail)
        if status.state is State.FAILED:
            return Step(feedback, outcome="failed", detail=status.last_error or status.detail)
        if status.state is State.STOPPED:
            if self.cancel_requested:
                return Step(feedback, outcome="canceled",
                            detail=f"stopped safely: {status.detail}")
            return Step(feedback, outcome="failed",
                        detail="the executor was stopped (/executor/stop) while the goal ran")
        return Step(feedback)

    def _before_plan(self, status: ExecutorStatus, plan: Plan | None, now: float) -> Step:
        """Waiting for the planner: the executor's state is the previous run's, not ours."""
        words = "waiting for a plan"
        if self.planner is not None:
            words += f" (planner: {self.planner.state}"
            words += f": {self.planner.last_error})" if self.planner.last_error else ")"
        feedback = RearrangeFeedback(State.IDLE, detail=words)
        if self.cancel_requested:
            return Step(feedback, outcome="canceled", detail="canceled before a plan came")
        if plan is not None and plan.plan_id != self.plan_before and plan_is_for(plan,
                                                                                self.layout):
            self.plan_id = plan.plan_id
            self.replans_at_start = status.metrics.get("replans", 0.0)
            return Step(RearrangeFeedback(State.IDLE, 0, len(plan.actions),
                                          detail=f"plan {plan.plan_id}: {len(plan.actions)} "
                                          "actions"), start=True)
        if self.planner is not None and self.planner.state == "failed":
            return Step(feedback, outcome="failed",
                        detail=f"the planner found no plan: {self.planner.last_error}")
        if now - self.started_at > self.plan_timeout_s:
            return Step(feedback, outcome="failed",
                        detail=f"no plan within {self.plan_timeout_s:.0f} s; {words}")
        return Step(feedback)

    def changed(self, feedback: RearrangeFeedback) -> bool:
        """Whether ``feedback`` differs from the last one reported (and remember it)."""
        if feedback == self._last:
            return False
        self._last = feedback
        return True
