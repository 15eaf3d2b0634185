"""Observing: frames asked for, retried, looked at from the park pose, and idle looks."""

from __future__ import annotations

import itertools

import pytest

from msgs_py import BlockPose, Plan
from nodes.executor.belief import Belief
from nodes.executor.core import ExecutorCore
from nodes.executor.motion import ToolPose
from nodes.executor.observe import judged_after
from nodes.executor.states import State
from tests.unit.executor.world import (
    CFG,
    DT,
    GOAL,
    START,
    WS,
    World,
    scene,
    two_action_plan,
)


def test_no_detection_is_retried_then_reported():
    core = ExecutorCore(CFG)
    world = World(core, START, camera_works=False)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state in (State.FAILED, State.STOPPING))
    assert f"no detection after {CFG.detection_retries} camera triggers" in core.report.last_error


def test_without_a_plan_the_arm_parks_and_the_camera_is_triggered_periodically():
    core = ExecutorCore(CFG)
    core.on_tcp(ToolPose(0.6, 0.0, 0.3, 0.0))  # somewhere over the table
    triggers, t = [], 0.0
    while t < 30.0:
        out = core.tick(t)
        if out.setpoint is not None:
            core.on_tcp(out.setpoint)
        if out.trigger_camera:
            triggers.append(t)
        t += DT
    assert core.player.commanded == CFG.park
    assert len(triggers) >= 3
    gaps = [b - a for a, b in itertools.pairwise(triggers)]
    assert all(g == pytest.approx(CFG.idle_look_period_s, abs=DT) for g in gaps)


def test_a_waiting_planner_gets_a_fresh_look_without_waiting_a_whole_idle_period():
    core = ExecutorCore(CFG)
    core.on_tcp(CFG.park)
    triggers, t = [], 0.0
    while t < 9.0:
        if abs(t - 2.0) < DT / 2:  # a planner that started late says it waits for a detection
            core.on_planner_waiting(True)
        if abs(t - 3.0) < DT / 2:  # ... and has one: it plans
            core.on_planner_waiting(False)
        out = core.tick(t)
        if out.trigger_camera:
            triggers.append(t)
        t += DT
    # one look at once, looks every IDLE_LOOK_SOON_S while the planner waits, then the period
    soon = [k for k in triggers if 1.9 < k < 3.1]
    assert triggers[0] == pytest.approx(0.0, abs=2 * DT)
    assert soon == pytest.approx([2.0, 2.5], abs=2 * DT)
    assert triggers[-1] == pytest.approx(soon[-1] + CFG.idle_look_period_s, abs=2 * DT)
    assert len(triggers) == 1 + len(soon) + 1


def test_the_arm_moves_on_to_the_next_block_while_the_camera_looks():
    """After an action the arm stops at the look pose outside the workspace; once the frame is
    taken it heads for the next block at travel height, and acts only once the world is
    judged."""
    core = ExecutorCore(CFG)
    world = World(core, START, camera_delay=0.8, answers_trigger=True)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    assert world.states == ["observing", "running", "observing", "running", "observing",
                            "running", "observing", "done"]
    after_action = world.trigger_poses[1:-1]  # the first and last looks are from the park pose
    assert after_action and all(p.x == pytest.approx(WS.x_min - CFG.look_offset)
                                and p.z == pytest.approx(CFG.look_height) for p in after_action)
    assert world.trigger_poses[-1] == CFG.park
    first_look = next(k for k, (t, state, p) in enumerate(world.setpoints)
                      if state == "observing" and p == after_action[0])
    waiting = [p for _, state, p in world.setpoints[first_look:] if state == "observing"]
    assert waiting[-1].distance_to(after_action[0]) > 0.1  # it moved on while it waited ...
    assert all(p.z >= CFG.travel_height - 1e-9 for p in waiting)  # ... above the blocks
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-9


def test_blocks_the_arm_hides_at_the_look_pose_are_looked_at_from_the_park_pose():
    core = ExecutorCore(CFG)

    def hides(tool):  # at the look pose the arm hides block 2
        return {2} if tool.x == pytest.approx(WS.x_min - CFG.look_offset) else set()

    world = World(core, START, hides=hides)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    assert any("not seen; looking again from the park pose" in line for line in world.logs)
    assert CFG.park in world.trigger_poses[1:-1]
    assert core.report.metrics["actions_executed"] == 3
    assert core.report.metrics["looks_again_from_park_pose"] >= 1  # in the run's figures


def test_an_empty_plan_for_a_reached_goal_is_verified_and_done():
    at_goal = [BlockPose(i, p.x, p.y, p.theta) for i, p in GOAL.items()]
    core = ExecutorCore(CFG)
    world = World(core, at_goal)
    core.on_plan(Plan((), plan_id="empty", scene=scene(at_goal, GOAL)))
    world.run(lambda: core.state is State.DONE)
    assert core.report.metrics["final_pos_err_max_m"] == pytest.approx(0.0)


def test_a_replan_names_what_the_look_judged():
    assert judged_after(Belief(index=2, probes=2)) == "after the camera check"
    assert judged_after(Belief(index=5, probes=2)) == "after action 3"
    # a block let go where a protective stop left it, before the first action was done
    assert judged_after(Belief(index=0, probes=0)) == "before action 1"
    assert judged_after(Belief(index=2, probes=2)) != judged_after(Belief(index=2, probes=0))
