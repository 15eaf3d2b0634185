"""The executor's loop as a whole, in the scripted world: observe, act, verify."""

from __future__ import annotations

from msgs_py import BlockPose, BlockSet
from nodes.executor.core import ExecutorCore
from nodes.executor.states import State
from tests.unit.executor.world import (
    CFG,
    GOAL,
    START,
    Gripper,
    World,
    two_action_plan,
)


def test_a_plan_runs_observing_after_every_action_and_ends_verified():
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    assert world.states == ["observing", "running", "observing", "running", "observing",
                            "running", "observing", "done"]
    assert core.report.metrics["actions_executed"] == 3 and core.report.metrics["observations"] == 4
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-9
    assert world.max_speed <= CFG.speed * 1.01
    status = core.status()
    assert status.action_index == status.action_total == 3 and status.last_error == ""


def test_a_replan_asked_for_by_a_detection_callback_leaves_with_the_next_tick():
    """Regression: a request made outside tick() (in the detection callback) was dropped."""
    core = ExecutorCore(CFG)
    moved = [BlockPose(1, GOAL[1].x, GOAL[1].y, 0.0), START[1]]
    world = World(core, moved)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.OBSERVING and core.camera.trigger_ns is not None)
    core.on_detection(BlockSet(tuple(moved), core.camera.trigger_ns))  # a callback, between ticks
    assert core.state is State.REPLANNING
    assert core.tick(500.0).request_replan
    assert not core.tick(500.01).request_replan


def test_with_a_reporting_gripper_the_plan_runs_supervised_to_the_goal():
    core = ExecutorCore(CFG)
    world = World(core, START)
    Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    assert core.report.metrics["faults"] == 0
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-3
