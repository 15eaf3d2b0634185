"""The start-of-run camera check: which block it grips in place, how, and how the run
goes on after it."""

from __future__ import annotations

import math

from msgs_py import BlockPose, PickPlace, Plan, Pose2D, Workspace
from msgs_py.cell import GripperGeometry
from nodes.executor.camera_check import probe_actions, probe_block, probe_steps
from nodes.executor.config import ExecutorConfig
from nodes.executor.core import ExecutorCore
from nodes.executor.states import State
from nodes.executor.steps import Grip, Move, Rise
from tests.unit.executor.world import (
    CHECKING,
    GOAL,
    START,
    Gripper,
    World,
    scene,
    two_action_plan,
    xyt,
)

TABLE = Workspace(0.45, 0.95, -0.35, 0.35)
GEO = GripperGeometry()


def test_the_block_with_room_on_every_side_nearest_the_centre_is_chosen():
    perceived = {
        1: Pose2D(0.70, 0.00, 0.0), 2: Pose2D(0.7538, 0.0, 0.0),  # a tight pair in the centre
        3: Pose2D(0.60, -0.25, 0.3),  # alone, near a corner
        4: Pose2D(0.80, 0.20, 0.0),  # alone, nearer the centre
    }
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.015) == 4


def test_a_neighbour_across_either_closing_axis_rules_a_block_out():
    # block 2 stands 95 mm from block 1 along y: fingers closing along y come within 15 mm
    perceived = {1: Pose2D(0.70, 0.00, 0.0), 2: Pose2D(0.70, 0.095, 0.0)}
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.015) is None
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.0) is not None


def test_a_block_whose_fingers_leave_the_table_is_not_chosen():
    perceived = {1: Pose2D(0.46, 0.0, 0.0)}
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.015) is None


def test_the_check_is_one_entry_that_leaves_the_block_where_it_stands():
    at = Pose2D(0.7, 0.1, 0.4)
    assert probe_actions(3, at) == (PickPlace(3, at, at, 0),)


def test_the_fingers_grip_along_one_axis_then_turn_over_the_block_and_grip_along_the_other():
    cfg = ExecutorConfig()
    at = Pose2D(0.7, 0.1, 0.4)
    steps = probe_steps(3, at, GEO, cfg, opening=0.085)
    grips = [s for s in steps if isinstance(s, Grip) and s.holds is not None]
    assert [(g.holds, g.squares) for g in grips] == [(3, False), (3, True)]
    # follow the commanded tool: x, y never leave the block; the yaw turns a quarter turn
    # between the grips, only with the fingertips over the block's top
    z, yaw, yaws_at_grip = cfg.travel_height, None, []
    for step in steps:
        if isinstance(step, Move):
            assert (step.target.x, step.target.y) == (at.x, at.y)
            if yaw is not None and abs(step.target.yaw - yaw) > 1e-9:
                assert min(z, step.target.z) > GEO.block_size, step.label
            z, yaw = step.target.z, step.target.yaw
        elif isinstance(step, Rise):
            z = max(z, step.z)
        elif step in grips:
            assert z == cfg.grasp_height
            yaws_at_grip.append(yaw)
    turn = math.remainder(yaws_at_grip[1] - yaws_at_grip[0], math.pi)
    assert abs(abs(turn) - math.pi / 2) < 1e-9
    assert math.remainder(yaws_at_grip[0] - at.theta, math.pi / 2) == 0.0
    # the fingers open fully after each grip, and the tool ends at travel height
    after = [steps[steps.index(g) + 1] for g in grips]
    assert all(isinstance(s, Grip) and s.holds is None and s.opening == 0.085 for s in after)
    assert z == cfg.travel_height


def test_the_first_run_grips_the_most_isolated_block_on_both_axes_then_runs_the_plan():
    core = ExecutorCore(CHECKING)
    world = World(core, START)
    Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    # block 1 stands 0.25 m from the workspace's centre, block 2 0.22 m: block 2 is checked
    assert core.plan.actions[0] == PickPlace(2, START[1].pose, START[1].pose, 0)
    assert core.report.metrics["camera_check_regrips"] == 2
    # the check's last word on block 2 is a squared placement where it stood, reported before
    # any plan action's
    check = [p for p in world.placements if p.squared]
    assert len(check) == 1 and world.placements.index(check[0]) < 2
    assert (check[0].block, check[0].pose) == (2, START[1].pose)
    # one look at the start, one after the check (not one per grip), one after each action
    assert len(world.trigger_poses) == 1 + 1 + 3
    assert core.report.metrics["actions_executed"] == 3 and world.replan_requests == 0
    # the status counts the plan's actions: 0 of 3 while checking, never negative
    assert ("running", 0, 3) in world.progress and ("running", 1, 3) in world.progress
    assert all(0 <= k <= n == 3 for _, k, n in world.progress)
    assert world.blocks[1].distance_to(GOAL[1]) < 1e-9
    # once in the executor's lifetime: a second plan runs without the check
    core.on_plan(two_action_plan("p2", blocks=[BlockPose(1, *xyt(world.blocks[1])),
                                               BlockPose(2, *xyt(world.blocks[2]))]))
    world.run(lambda: core.state is State.DONE and core.plan.plan_id == "p2")
    assert core.report.metrics["camera_check_regrips"] == 2


def test_a_view_corrected_by_the_camera_check_makes_the_plan_replanned():
    core = ExecutorCore(CHECKING)
    world = World(core, START)
    Gripper(world)
    core.on_plan(two_action_plan())
    world.run(lambda: core.report.metrics.get("camera_check_regrips", 0) == 2)
    # the detector corrected its calibration from the check's grips: the other block is now
    # seen 5 mm from where the uncorrected plan had it
    p = world.blocks[1]
    world.blocks[1] = Pose2D(p.x + 0.005, p.y, p.theta)
    world.run(lambda: world.replan_requests > 0)
    assert core.state is State.REPLANNING and "block 1" in core.report.detail


def test_no_camera_check_when_no_block_has_room_for_open_fingers():
    crowded = [BlockPose(1, 0.70, 0.0, 0.0), BlockPose(2, 0.7538, 0.0, 0.0),
               BlockPose(3, 0.70, 0.0538, 0.0), BlockPose(4, 0.7538, 0.0538, 0.0)]
    goal = {b.id: b.pose for b in crowded}
    plan = Plan((PickPlace(1, crowded[0].pose, Pose2D(0.6, -0.2, 0.0), 0),), plan_id="c",
                scene=scene(crowded, goal), params={"block_size": 0.0508})
    core = ExecutorCore(CHECKING)
    world = World(core, crowded)
    core.on_plan(plan)
    world.run(lambda: core.state is State.RUNNING)
    world.run(lambda: any("camera check skipped" in line for line in world.logs), max_t=1.0)
    assert len(core.plan.actions) == 1
