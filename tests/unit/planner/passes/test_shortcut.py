"""Shortcutting merges two moves of one block only when everything in between still works."""

from __future__ import annotations

from msgs_py import BlockPose, PickPlace, Pose2D, Scene, Workspace
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.passes.shortcut import shortcut

S = 0.0508
WS = Workspace(0.40, 1.00, -0.30, 0.30)
A, B, C = Pose2D(0.5, 0.0, 0.0), Pose2D(0.5, 0.2, 0.0), Pose2D(0.8, 0.0, 0.0)
Y0, Y1 = Pose2D(0.9, -0.2, 0.0), Pose2D(0.7, -0.2, 0.0)


def ctx_and_start(extra=()):
    blocks = (BlockPose(0, A.x, A.y, A.theta), BlockPose(1, Y0.x, Y0.y, Y0.theta), *extra)
    scene = Scene(WS, S, blocks)
    return PlanContext.for_scene(scene, PlannerConfig()), {b.id: b.pose for b in blocks}


def test_a_detour_that_nothing_needed_becomes_one_move():
    ctx, start = ctx_and_start()
    plan = [PickPlace(0, A, B, 0), PickPlace(1, Y0, Y1, 0), PickPlace(0, B, C, 1)]
    out = shortcut(ctx, start, plan)
    assert len(out) == 2
    assert [(a.block, a.to) for a in out] == [(0, C), (1, Y1)]


def test_a_move_that_clears_the_way_is_kept():
    # block 2 stands beside A along x, so block 1 can only be set down on A with the y grasp;
    # block 0's final pose C2 is beside A along y, where those fingers go. Block 0 can neither
    # stay on A nor reach C2 before block 1 is down: the two moves must stay apart.
    beside = BlockPose(2, A.x + S + 0.003, A.y, 0.0)
    c2 = Pose2D(A.x, A.y + S + 0.003, 0.0)
    ctx, start = ctx_and_start((beside,))
    plan = [PickPlace(0, A, B, 1), PickPlace(1, Y0, A, 1), PickPlace(0, B, c2, 0)]
    assert shortcut(ctx, start, plan) == plan


def test_away_and_back_disappears():
    ctx, start = ctx_and_start()
    plan = [PickPlace(0, A, B, 0), PickPlace(1, Y0, Y1, 0), PickPlace(0, B, A, 0)]
    assert shortcut(ctx, start, plan) == [PickPlace(1, Y0, Y1, 0)]
