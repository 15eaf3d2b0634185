"""Locked blocks: none of them can be taken away (picked, or nudged and picked) even with every
block that can gone. The scene generator redraws such starts; a planner failure on one names
them first.

The jam is the one the random 9-block scene of seed 8 at density 0.3 drew before the generator
checked for it (no method planned it): block 4 stands turned 141 degrees between blocks 3 and
8 at the workspace's edge, every grasp of each of the three lands on another, and each has a
free push of 5 mm (so none is frozen) but no nudge after which a grasp fits.
"""

from __future__ import annotations

from dataclasses import replace

from msgs_py import BlockPose, Goal, GoalSlot, GridSpec, Scene, Workspace
from msgs_py.cell import BLOCK_SIZE
from nodes.bench.instances import instance
from nodes.planner.bounds.frozen import frozen_blocks, locked_blocks
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.labeled.plan_labeled import plan_scene
from nodes.sim.layout import random_sim_scene

WS = Workspace(0.5608784703936878, 0.8391215296063121, -0.1391215296063122, 0.1391215296063122)
JAM = (BlockPose(3, 0.7609320702086424, 0.102122122450999, -0.2502007901008132),
       BlockPose(4, 0.7281338050472821, 0.044149759336527844, 2.4590214590863857),
       BlockPose(8, 0.6974601268054479, 0.10856070754573344, 0.06928221685607161))
SLOTS = Goal(grid=GridSpec(3, 3, (0.70, 0.0), 0.0, 0.003), labeled=True).slot_poses(BLOCK_SIZE)


def scene_of(blocks) -> Scene:
    """The blocks, each with its slot of the 3x3 grid as its goal."""
    blocks = tuple(sorted(blocks, key=lambda b: b.id))
    goal = Goal(slots=tuple(GoalSlot(SLOTS[b.id].x, SLOTS[b.id].y, 0.0, b.id) for b in blocks))
    return Scene(WS, BLOCK_SIZE, blocks, goal)


def state_and_ctx(scene: Scene):
    return PlanContext.for_scene(scene, PlannerConfig()), {b.id: b.pose for b in scene.blocks}


def test_three_blocks_that_hem_each_other_in_are_locked_but_not_frozen():
    ctx, state = state_and_ctx(scene_of(JAM))
    assert locked_blocks(ctx, state) == [3, 4, 8]
    assert frozen_blocks(ctx, state) == []  # a 5 mm push moves each: no proof of "no plan"


def test_without_one_of_them_the_others_can_be_taken_away():
    for gone in (3, 4, 8):
        ctx, state = state_and_ctx(scene_of(b for b in JAM if b.id != gone))
        assert locked_blocks(ctx, state) == []


def test_the_generator_draws_again_where_a_start_locks_blocks():
    scene = instance("random", 9, 0.3, 8)
    ctx, state = state_and_ctx(scene)
    assert locked_blocks(ctx, state) == []
    assert {(b.x, b.y) for b in JAM}.isdisjoint((b.x, b.y) for b in scene.blocks)


def test_a_failure_on_a_locked_start_names_the_locked_blocks_first():
    free = [BlockPose(k, 0.60 + 0.06 * k, -0.10, 0.0) for k in (0, 1, 2)]
    config = replace(PlannerConfig(), budget_s=2.0, improve_max_s=0.0)
    out = plan_scene(scene_of([*free, *JAM]), config)
    assert not out.ok
    assert out.error.startswith("blocks [3, 4, 8] are locked where they start")


def test_the_cells_own_scenes_lock_nothing():
    for seed in range(5):
        ctx, state = state_and_ctx(random_sim_scene(25, 0.10, seed))
        assert locked_blocks(ctx, state) == []
