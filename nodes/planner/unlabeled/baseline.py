"""Baseline for unlabeled goals: assign blocks to slots, then plan the labeled problem.

The assignment is a min-cost matching (``scipy.optimize.linear_sum_assignment``, the
Hungarian method) on the distance each block would travel to each slot; with more blocks
than slots the surplus blocks stay free. The labeled pIRS planner then plans the resulting
labeled goal, and the plan is checked again against the original unlabeled goal.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import linear_sum_assignment

from msgs_py import Goal, GoalSlot, Scene
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.labeled.plan_labeled import plan_scene
from nodes.planner.outcome import PlanOutcome, failed
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.plan_unlabeled import certified_bound, check_unlabeled

PLANNER_NAME = "assignment_pirs"


def assign_slots(scene: Scene) -> dict[int, int]:
    """Slot index -> block id minimising the total distance blocks travel."""
    slots = scene.goal.slot_poses(scene.block_size)
    blocks = list(scene.blocks)
    cost = np.array([[b.pose.distance_to(s) for b in blocks] for s in slots])
    rows, cols = linear_sum_assignment(cost)
    return {int(r): blocks[int(c)].id for r, c in zip(rows, cols, strict=True)}


def labeled_goal(scene: Scene, assignment: dict[int, int]) -> Goal:
    slots = scene.goal.slot_poses(scene.block_size)
    return Goal(slots=tuple(GoalSlot(slots[k].x, slots[k].y, slots[k].theta, block)
                            for k, block in sorted(assignment.items())), labeled=True)


def plan_assignment(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig,
                    budget: Budget | None = None, plan_id: str | None = None) -> PlanOutcome:
    """Min-cost assignment, then pIRS; the outcome's plan carries the unlabeled scene.

    Raises:
        MessageError: no goal, a labeled goal, or ``yaw_exact``.
    """
    check_unlabeled(scene)
    budget = budget or Budget.of(config.budget_s)
    labeled = scene.with_goal(labeled_goal(scene, assign_slots(scene)))
    outcome = plan_scene(labeled, config, budget, plan_id)
    ctx = PlanContext.for_scene(scene, config)
    slots = scene.goal.slot_poses(scene.block_size)
    bound = certified_bound(ctx, scene, Assembly(ctx, dict(enumerate(slots))))
    metrics = {**outcome.metrics, "lower_bound": float(bound)}
    if outcome.plan is None:
        return failed(budget, bound, outcome.error, outcome.failed_block, metrics)
    params = {**outcome.plan.params, **ucfg.to_params()}
    plan = dataclasses.replace(outcome.plan, planner=PLANNER_NAME, params=params, scene=scene,
                               planning_time_s=budget.elapsed())
    report = validate_plan(plan)
    if not report.ok:
        return failed(budget, bound, "internal error: the assigned plan fails the unlabeled "
                      f"goal ({'; '.join(report.errors[:3])})", None, metrics)
    return PlanOutcome(plan, budget.elapsed(), bound, metrics=metrics)
