"""Failures say their real cause: which blocks are held (not only placed ones), and a search
stopped by its clock names the budget it had."""

from __future__ import annotations

import numpy as np

from msgs_py import BlockPose, Goal, GoalSlot, Pose2D, Scene, Workspace
from nodes.bench.instances import instance
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.labeled.pirs import NoRoute
from nodes.planner.labeled.plan_labeled import plan_scene
from nodes.planner.labeled.roadmap import plan_route

S = 0.0508
GAP = 0.005


def test_a_block_hemmed_in_by_held_blocks_is_not_said_to_be_hemmed_by_placed_ones():
    c = (0.70, 0.0)
    ring = {1: (S + GAP, 0.0), 2: (-S - GAP, 0.0), 3: (0.0, S + GAP), 4: (0.0, -S - GAP)}
    blocks = [BlockPose(0, *c, 0.0)] + [BlockPose(b, c[0] + dx, c[1] + dy, 0.0)
                                        for b, (dx, dy) in ring.items()]
    scene = Scene(Workspace(0.45, 0.95, -0.25, 0.25), S, tuple(blocks),
                  Goal(slots=(GoalSlot(0.55, -0.15, 0.0, 0),)))
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    state = {b.id: b.pose for b in blocks}
    route = plan_route(ctx, 0, state, Pose2D(0.55, -0.15, 0.0), frozenset(),
                       np.random.default_rng(0))
    assert isinstance(route, NoRoute)
    assert "neither grasped nor pushed" in route.reason
    assert "placed block" not in route.reason and "stay where they are" in route.reason
    assert set(route.fixed_blockers) <= set(ring)


def test_a_search_out_of_time_names_the_budget_it_had():
    scene = instance("random", 9, 0.3, 1)
    out = plan_scene(scene, PlannerConfig(), Budget.of(0.0))
    assert not out.ok
    assert "its time budget (0.0 s) exhausted" in out.error
