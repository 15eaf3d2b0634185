"""Input the planner samples or grids over is bounded before anything is built for it: a
workspace beyond the arm's reach is clipped to it, too many blocks, an endless budget or a
huge sample count are refused naming the field."""

from __future__ import annotations

import dataclasses

import pytest

from msgs_py import BlockPose, Goal, GridSpec, MessageError, Scene, Workspace
from msgs_py.cell import BLOCK_SIZE
from nodes.bench.instances import instance
from nodes.planner.bounds import exact
from nodes.planner.config import MAX_BUDGET_S, MAX_SAMPLES, PlannerConfig
from nodes.planner.dispatch import check_goal, plan_goal
from nodes.planner.geometry.context import MAX_SCENE_BLOCKS, PlanContext
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.passes import reinsert
from nodes.planner.unlabeled import cell_geometry

WIDE = Workspace(-3.0, 3.0, -3.0, 3.0)
#: Blocks 0 and 1 stand on each other's slots (each must be cleared), block 2 aside.
SWAPPED = (BlockPose(0, 0.7269, -0.04, 0.0), BlockPose(1, 0.6731, -0.04, 0.0),
           BlockPose(2, 0.9, 0.3, 0.2))


def swapped_scene(workspace: Workspace) -> Scene:
    return Scene(workspace, BLOCK_SIZE, SWAPPED,
                 Goal(grid=GridSpec(1, 3, (0.70, -0.04), 0.0, 0.003)))


def test_a_workspace_beyond_the_arm_is_clipped_to_its_reach_and_planned():
    config = dataclasses.replace(PlannerConfig(), improve_max_s=0.0)
    scene = swapped_scene(WIDE)
    ctx = PlanContext.for_scene(scene, config)
    r = ctx.reach.r_max
    assert (ctx.workspace.x_min, ctx.workspace.x_max) == (-r, r)
    assert (ctx.workspace.y_min, ctx.workspace.y_max) == (-r, r)
    # every lattice drawn over it is bounded (a 6 m square at 0.5 block sizes: 57600 poses,
    # whose pairs took 68 GiB in the re-insertion pass before)
    assert len(reinsert._lattice(ctx, 0.0)) <= 1.1 * reinsert.LATTICE_MAX
    assert len(exact.pose_set(ctx, [b.pose for b in SWAPPED], [])) <= 1.1 * exact.BUFFER_MAX + 3
    step = cell_geometry.LATTICE_STEP * BLOCK_SIZE
    assert len(ctx.workspace.lattice(BLOCK_SIZE, step, cell_geometry.LATTICE_MAX)) \
        <= 1.1 * cell_geometry.LATTICE_MAX
    out = plan_goal(scene, config)
    assert out.ok and validate_plan(out.plan).ok and len(out.plan.actions) == out.lower_bound


def test_a_workspace_in_reach_is_used_as_given():
    scene = instance("random", 9, 0.3, 0)
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    w = scene.workspace
    assert (ctx.workspace.x_min, ctx.workspace.x_max, ctx.workspace.y_min,
            ctx.workspace.y_max) == (w.x_min, w.x_max, w.y_min, w.y_max)


def test_a_lattice_keeps_its_step_until_it_would_exceed_its_cap():
    ctx = PlanContext.for_scene(instance("random", 9, 0.3, 0), PlannerConfig())
    fine = ctx.workspace.lattice(BLOCK_SIZE, 0.01, 10**6)
    assert len(fine) > 200 and abs(fine[1, 0] - fine[0, 0] - 0.01) < 1e-12
    capped = ctx.workspace.lattice(BLOCK_SIZE, 0.01, 100)
    assert 50 <= len(capped) <= 121


def test_too_many_blocks_are_refused_naming_the_field():
    n = MAX_SCENE_BLOCKS + 1
    cols = 15
    pitch = BLOCK_SIZE + 0.005
    blocks = tuple(BlockPose(k, 0.40 + (k % cols) * pitch, -0.55 + (k // cols) * pitch, 0.0)
                   for k in range(n))
    scene = Scene(Workspace(0.35, 1.25, -0.6, 0.3), BLOCK_SIZE, blocks,
                  Goal(grid=GridSpec(1, 2, (0.8, 0.2), 0.0, 0.003), labeled=False))
    with pytest.raises(MessageError) as err:
        check_goal(scene)
    assert err.value.field == "blocks" and f"at most {MAX_SCENE_BLOCKS}" in str(err.value)
    with pytest.raises(MessageError, match="blocks"):
        PlanContext.for_scene(scene, PlannerConfig())


@pytest.mark.parametrize("name", ["budget_s", "improve_max_s", "near_goal_budget_s",
                                  "frozen_budget_s"])
def test_an_endless_budget_is_refused_naming_the_field(name):
    with pytest.raises(ValueError, match=f"'{name}' must be at most {MAX_BUDGET_S:g} s"):
        PlannerConfig(**{name: 1e9})


def test_a_huge_sample_count_is_refused():
    with pytest.raises(ValueError, match=f"'n_samples' must be at most {MAX_SAMPLES}"):
        PlannerConfig(n_samples=10**8)


@pytest.mark.parametrize("size, what", [(0.2, "stroke"), (0.005, "rear face")])
def test_a_block_size_far_from_the_cells_is_refused(size, what):
    blocks = (BlockPose(0, 0.60, -0.2, 0.0), BlockPose(1, 0.80, 0.2, 0.0))
    scene = Scene(Workspace(0.3, 1.1, -0.5, 0.5), size, blocks,
                  Goal(grid=GridSpec(1, 2, (0.7, 0.0), 0.0, 0.003)))
    with pytest.raises(ValueError, match=what):
        plan_goal(scene, PlannerConfig())
