"""Small scenes: the exact search over the pose set runs beside pIRS, the shorter plan wins.

In cramped small scenes (4 blocks in a workspace at density 0.3) no pose lies clear of every
slot, so pIRS finds no clearing pose; the exact search does, and the planner keeps its plan.
"""

from __future__ import annotations

import dataclasses

import pytest

from msgs_py import Plan
from nodes.bench.instances import instance
from nodes.planner.bounds.exact import exact_plan
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.labeled.plan_labeled import EXACT_NAME, PLANNER_NAME, plan_scene

CONFIG = PlannerConfig(budget_s=20.0, exact_pirs_s=2.0)


def pose_set_optimum(scene) -> int:
    ctx = PlanContext.for_scene(scene, CONFIG)
    goals = scene.goal_assignment()
    ids = sorted(goals)
    found = exact_plan(ctx, {b.id: b.pose for b in scene.blocks}, [goals[b] for b in ids],
                       {b: k for k, b in enumerate(ids)}, max_expansions=10**6)
    return len(found.actions)


@pytest.mark.parametrize("seed", [0, 3])
def test_a_cramped_small_scene_gets_a_plan_no_longer_than_the_pose_set_optimum(seed):
    scene = instance("random", 4, 0.3, seed)
    out = plan_scene(scene, dataclasses.replace(CONFIG, seed=seed))
    assert out.ok, out.error
    assert validate_plan(Plan.from_dict(out.plan.to_dict())).ok
    assert out.lower_bound <= len(out.plan.actions) <= pose_set_optimum(scene)
    assert out.plan.planner in (EXACT_NAME, PLANNER_NAME)
    assert out.metrics["exact_closed"] == 1.0


def test_switched_off_the_planner_is_pirs_alone():
    scene = instance("random", 4, 0.3, 1)
    out = plan_scene(scene, dataclasses.replace(CONFIG, exact_max_blocks=0))
    assert "exact_closed" not in out.metrics
    assert not out.ok or out.plan.planner == PLANNER_NAME


@pytest.mark.parametrize("seed", [8, 14])
def test_pirs_runs_only_when_the_exact_plan_is_above_the_lower_bound(seed):
    out = plan_scene(instance("random", 6, 0.3, seed), CONFIG)
    assert out.ok, out.error
    at_bound = out.metrics["exact_actions"] <= out.lower_bound
    # pIRS ran whether or not it found a plan within exact_pirs_s (a loaded machine may not)
    pirs_ran = "pirs_actions" in out.metrics or "pirs_failed" in out.metrics
    assert pirs_ran != at_bound
    if at_bound:
        assert out.plan.planner == EXACT_NAME


@pytest.mark.parametrize("name", ["exact_max_blocks", "exact_after_max_blocks"])
@pytest.mark.parametrize("value", [-1, 13])
def test_exact_block_counts_are_bounded(name, value):
    with pytest.raises(ValueError, match=name):
        PlannerConfig(**{name: value})
