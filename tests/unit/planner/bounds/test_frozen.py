"""Frozen blocks: those no grasp or push can ever free, even with every movable block gone;
the planner fails soon on such a start and says which blocks."""

from __future__ import annotations

import dataclasses

from msgs_py import BlockPose, Goal, GridSpec, Scene, Workspace
from msgs_py.cell import BLOCK_SIZE
from nodes.planner.bounds.frozen import frozen_blocks, frozen_off_goal
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.labeled.plan_labeled import plan_scene

GAP = 0.003
WS = Workspace(0.53, 0.87, -0.17, 0.17)
CENTRE = (0.70, 0.0)


def grid_scene(hole: int, owner: list[int]) -> Scene:
    """A 3x3 grid (3 mm gaps) with ``owner[k]`` standing on slot k but for slot ``hole``,
    whose owner stands outside the grid."""
    goal = Goal(grid=GridSpec(3, 3, CENTRE, 0.0, GAP), labeled=True)
    slots = goal.slot_poses(BLOCK_SIZE)
    blocks = [BlockPose(owner[k], slots[k].x, slots[k].y, 0.0) for k in range(9) if k != hole]
    blocks.append(BlockPose(owner[hole], 0.80, -0.14, 0.0))
    return Scene(WS, BLOCK_SIZE, tuple(sorted(blocks, key=lambda b: b.id)), goal)


SWAPPED = [1, 0, 3, 2, 4, 6, 5, 8, 7]  # slot 4 (the centre) keeps its own block


def frozen(scene: Scene) -> list[int]:
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    return frozen_blocks(ctx, {b.id: b.pose for b in scene.blocks})


def test_a_hole_in_the_centre_frees_every_block():
    assert frozen(grid_scene(4, SWAPPED)) == []


def test_a_hole_on_an_edge_frees_only_its_row():
    # hole at slot 1 (bottom row, middle): the bottom corners leave across it, then every
    # block of the two upper rows has a block on one side of each axis
    scene = grid_scene(1, SWAPPED)
    bottom = {SWAPPED[0], SWAPPED[2]}
    assert set(frozen(scene)) == {SWAPPED[k] for k in range(3, 9)}
    assert not bottom & set(frozen(scene))


def test_a_hole_in_a_corner_frees_nothing():
    assert set(frozen(grid_scene(0, SWAPPED))) == {SWAPPED[k] for k in range(1, 9)}


def test_only_frozen_blocks_off_their_goal_count():
    scene = grid_scene(0, SWAPPED)
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    start = {b.id: b.pose for b in scene.blocks}
    off = frozen_off_goal(ctx, start, scene.goal_assignment(), False)
    assert off == sorted(set(frozen(scene)) - {4})  # block 4 stands on its own slot


def test_the_planner_fails_soon_and_names_the_frozen_blocks():
    config = dataclasses.replace(PlannerConfig(), frozen_budget_s=0.5)
    out = plan_scene(grid_scene(1, SWAPPED), config, Budget.of(30.0))
    assert not out.ok and out.metrics["frozen"] > 0
    # the real cause first, with the short budget it led to (not "time budget exhausted")
    assert out.error.startswith("blocks ") and "can never be freed" in out.error
    assert "frozen_budget_s = 0.5 s" in out.error
    assert str(sorted({SWAPPED[k] for k in range(3, 9)} - {4})) in out.error
