"""Stopping safely: a held block set down first, resuming after a start, fingers that do not
open."""

from __future__ import annotations

import pytest

from nodes.executor.core import ExecutorCore
from nodes.executor.states import State
from tests.unit.executor.world import (
    CFG,
    DT,
    GOAL,
    START,
    Gripper,
    StallingGripper,
    World,
    two_action_plan,
)


def test_a_tcp_that_does_not_follow_stops_the_arm_and_reports():
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.RUNNING)
    frozen = core.inbox.tcp
    t = 100.0
    while core.state is State.RUNNING and t < 200:
        core.tick(t)
        core.on_tcp(frozen)  # the arm holds still (an unreachable setpoint, say)
        t += DT
    assert core.state is State.STOPPING
    assert "TCP did not reach" in core.status().last_error


def test_stop_while_carrying_sets_the_block_back_down_and_start_redoes_the_action():
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.belief.held is not None and core.belief.held.block == 1)
    core.request_stop()
    world.run(lambda: core.state is State.STOPPED)
    # the arm never parks with a block in its fingers: it set block 1 down where it took it
    assert core.belief.held is None and core.player.commanded == CFG.park
    assert world.blocks[1].distance_to(START[0].pose) < 1e-9
    replans = []
    world.on_replan = lambda: replans.append(1) or None
    core.request_start()
    world.run(lambda: core.state is State.RUNNING and core.belief.index == 0
              and core.belief.held is None, max_t=200)
    # block 1 is back where it was picked, the world matches plan p1's start again: resume
    assert world.blocks[1].distance_to(START[0].pose) < 1e-9
    assert replans == []


def test_a_stop_as_the_grip_closes_sets_the_block_down_though_the_belief_had_not_recorded_it():
    """The fingers close on block 1 and a stop comes before the grip step has recorded the
    hold: the stop trusts the gripper, not the belief, and sets the block back down."""
    core = ExecutorCore(CFG)
    world = World(core, START)
    gripper = Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: gripper.holding == 1 and core.belief.held is None)
    core.request_stop()
    world.run(lambda: core.state is State.STOPPED)
    assert gripper.holding is None and core.player.commanded == CFG.park
    assert world.blocks[1].distance_to(START[0].pose) < 1e-6
    assert any("the fingers hold something the executor had not recorded: block 1" in line
               for line in world.logs)


def test_stop_between_actions_then_start_resumes_at_the_next_action():
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.report.metrics["actions_executed"] == 1)
    core.request_stop()
    world.run(lambda: core.state is State.STOPPED)
    core.request_start()
    world.run(lambda: core.state is State.DONE)
    assert world.replan_requests == 0 and core.report.metrics["actions_executed"] == 3


def test_fingers_that_never_open_stop_the_run_there_with_the_block_not_carried_off():
    core = ExecutorCore(CFG)
    world = World(core, START)
    gripper = StallingGripper(world, freed_by_grip=False)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state in (State.DONE, State.FAILED))
    assert core.state is State.FAILED
    assert "the fingers do not open: stopped with block 1 in the fingers" in core.report.last_error
    assert core.report.metrics["faults_not_released"] == 3
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-3  # never carried off
    assert world.setpoints[-1][2].z == pytest.approx(gripper.stuck_z)
    assert world.logs[-1] == "arm stopped over the block it holds: failed"
