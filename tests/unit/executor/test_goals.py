"""Rearrange goals without ROS: the goal checks and how a goal's run follows the executor."""

from __future__ import annotations

import math

import pytest

from msgs_py import (
    BlockPose,
    BlockSet,
    ExecutorStatus,
    Goal,
    GoalSlot,
    GridSpec,
    MessageError,
    PickPlace,
    Plan,
    PlannerStatus,
    Scene,
    Workspace,
)
from nodes.executor.config import ExecutorConfig
from nodes.executor.goals import GoalRun, block_errors, check_layout, plan_is_for

WS = Workspace(0.45, 0.95, -0.35, 0.35)
BOX = ExecutorConfig().safe_box
BLOCKS = (BlockPose(1, 0.55, -0.2, 0.3), BlockPose(2, 0.8, 0.2, 0.0))
LAYOUT = Scene(WS, 0.0508, (), Goal(slots=(GoalSlot(0.7, 0.0, 0.0, 1),
                                           GoalSlot(0.7538, 0.0, 0.0, 2))))


def refused(layout, detection, field, text):
    with pytest.raises(MessageError) as err:
        check_layout(layout, detection, BOX)
    assert err.value.field == field and text in err.value.reason, str(err.value)


def test_a_goal_the_cell_can_do_passes():
    check_layout(LAYOUT, BlockSet(BLOCKS), BOX)
    check_layout(LAYOUT, BlockSet(BLOCKS[:1], missing=(2,)), BOX)  # 2 is known, hidden
    check_layout(LAYOUT, None, BOX)  # no detection yet: the planner checks the ids
    # a block 15 mm over the workspace's edge stands on the table margin: brought in
    edge = Scene(Workspace(0.45, 0.81, -0.35, 0.35), 0.0508, (), LAYOUT.goal)
    check_layout(edge, BlockSet(BLOCKS), BOX)


def test_goals_the_cell_cannot_do_are_refused_naming_the_field():
    refused(LAYOUT, BlockSet(BLOCKS[:1]), "layout.goal.slots[1].block_id", "unknown block")
    grid = Scene(WS, 0.0508, (), Goal(grid=GridSpec(2, 2, (0.7, 0.0))))
    refused(grid, BlockSet(BLOCKS), "layout.goal.grid", "more goal slots than blocks")
    narrow = Scene(Workspace(0.6, 0.95, -0.35, 0.35), 0.0508, (), LAYOUT.goal)
    refused(narrow, BlockSet(BLOCKS), "layout.workspace", "block 1")
    far = Scene(Workspace(0.45, 1.3, -0.35, 0.35), 0.0508, (), LAYOUT.goal)
    refused(far, None, "layout.workspace", "beyond its reach")
    wide = Scene(Workspace(0.45, 0.95, -0.95, 0.35), 0.0508, (), LAYOUT.goal)
    refused(wide, None, "layout.workspace", "safe_box")


def plan_for(layout, plan_id="p1", blocks=BLOCKS):
    scene = layout.with_blocks(blocks)
    actions = tuple(PickPlace(b, scene.block(b).pose, pose)
                    for b, pose in scene.goal_assignment().items())
    return Plan(actions, plan_id=plan_id, scene=scene)


def status(state, k=0, n=2, replans=0.0, **kwargs):
    return ExecutorStatus(state, action_index=k, action_total=n, metrics={"replans": replans},
                          **kwargs)


def test_a_run_waits_for_its_own_plan_starts_it_and_succeeds():
    old = plan_for(LAYOUT, "old")
    run = GoalRun(LAYOUT, "old", started_at=0.0, plan_timeout_s=60.0)
    step = run.update(status("done", 2, 2, replans=3), old, 1.0)  # the last run's, not ours
    assert (step.feedback.state, step.start, step.outcome) == ("idle", False, "")
    assert "waiting for a plan" in step.feedback.detail
    step = run.update(status("idle", replans=3), plan_for(LAYOUT, "new"), 2.0)
    assert step.start and run.plan_id == "new" and step.feedback.action_total == 2
    step = run.update(status("running", 1, block=1, replans=4), plan_for(LAYOUT, "new2"), 3.0)
    assert (step.feedback.action_index, step.feedback.block) == (1, 1)
    assert step.feedback.corrections == 1 and not step.outcome
    step = run.update(status("done", 2, 2, replans=4, detail="verified"), None, 4.0)
    assert (step.outcome, step.detail) == ("succeeded", "verified")


def test_a_run_fails_for_the_planner_a_timeout_a_failure_a_stop_or_a_foreign_plan():
    run = GoalRun(LAYOUT, "", 0.0, 60.0)
    run.on_planner_status(PlannerStatus("failed", last_error="block 2 enclosed"))
    step = run.update(status("idle"), None, 1.0)
    assert step.outcome == "failed" and "block 2 enclosed" in step.detail
    step = GoalRun(LAYOUT, "", 0.0, 60.0).update(status("idle"), None, 61.0)
    assert step.outcome == "failed" and "no plan within 60 s" in step.detail

    def running():
        run = GoalRun(LAYOUT, "", 0.0, 60.0)
        assert run.update(status("idle"), plan_for(LAYOUT), 1.0).start
        return run

    step = running().update(status("failed", last_error="TCP did not converge"), None, 2.0)
    assert (step.outcome, step.detail) == ("failed", "TCP did not converge")
    step = running().update(status("stopped"), None, 2.0)
    assert step.outcome == "failed" and "/executor/stop" in step.detail
    other = Scene(WS, 0.0508, (), Goal(slots=(GoalSlot(0.6, 0.0, 0.0, 1),)))
    step = running().update(status("running", 1), plan_for(other, "x"), 2.0)
    assert step.outcome == "failed" and "another goal layout" in step.detail


def test_a_canceled_run_ends_canceled_once_stopped():
    run = GoalRun(LAYOUT, "", 0.0, 60.0)
    run.update(status("idle"), plan_for(LAYOUT), 1.0)
    run.cancel()
    assert not run.update(status("stopping", 1), None, 2.0).outcome
    step = run.update(status("stopped", 1, detail="stop requested"), None, 3.0)
    assert step.outcome == "canceled" and "stopped safely" in step.detail
    before = GoalRun(LAYOUT, "", 0.0, 60.0)
    before.cancel()
    assert before.update(status("idle"), None, 1.0).outcome == "canceled"


def test_block_errors_come_from_the_final_detection():
    plan = plan_for(LAYOUT)
    seen = BlockSet((BlockPose(1, 0.7005, 0.0, math.radians(91.0)),))
    errors = block_errors(seen, plan)
    assert [(e.block_id, e.found) for e in errors] == [(1, True), (2, False)]
    assert errors[0].position_error_m == pytest.approx(0.0005)
    assert errors[0].yaw_error_rad == pytest.approx(math.radians(1.0))
    assert plan_is_for(plan, LAYOUT) and not plan_is_for(Plan(()), LAYOUT)
    assert block_errors(None, plan) == () and block_errors(seen, None) == ()
