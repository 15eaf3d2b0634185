"""What every planner returns, and the last steps they share: prune, wrap, validate.

``finish_plan`` takes a planner's actions and makes the published plan of them: every action
that does nothing is dropped, then each action in turn is tried without (``necessity``), the
plan carries every parameter it was made with (so it can be replayed on its own) and passes
the independent replay validator, or the outcome is an internal error. Planners never raise
for a scene they cannot solve: the outcome names the reason (and the block, if one).
"""

from __future__ import annotations

import uuid
from dataclasses import dataclass, field
from typing import Any

from msgs_py import Plan, Scene
from msgs_py.actions import Action
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.transfer import CostModel
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.passes.necessity import necessary_actions


@dataclass(frozen=True)
class PlanOutcome:
    plan: Plan | None
    planning_time_s: float
    lower_bound: int  # certified: no plan for this scene has fewer actions
    error: str = ""
    failed_block: int | None = None
    metrics: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.plan is not None


def failed(budget: Budget, bound: int, error: str, block: int | None = None,
           metrics: dict[str, float] | None = None) -> PlanOutcome:
    return PlanOutcome(None, budget.elapsed(), bound, error, block, dict(metrics or {}))


def finish_plan(scene: Scene, config: PlannerConfig, actions: list[Action], planner: str,
                budget: Budget, bound: int, metrics: dict[str, float],
                plan_id: str | None = None, extra_params: dict[str, Any] | None = None,
                pruned: bool = False) -> PlanOutcome:
    """The validated plan of ``actions`` (unneeded ones dropped unless the caller already
    did, ``pruned``: the pass replays the plan once per action), or an internal error."""
    params = config.to_params(scene.block_size)
    params.update(extra_params or {})
    if not pruned:
        before = len(actions)
        actions = necessary_actions(scene, params, actions)
        metrics = {**metrics, "unneeded_dropped": float(before - len(actions))}
    plan = Plan(actions=tuple(actions), planner=planner, params=params, seed=config.seed,
                planning_time_s=budget.elapsed(), cost=CostModel.of(config).plan(actions),
                plan_id=plan_id or uuid.uuid4().hex[:12], scene=scene)
    report = validate_plan(plan)
    if not report.ok:
        return failed(budget, bound, "internal error: the plan failed replay validation "
                      f"({'; '.join(report.errors[:3])})", None, metrics)
    metrics["actions"] = float(len(actions))
    metrics["pushes"] = float(sum(a.type == "push" for a in actions))
    return PlanOutcome(plan, budget.elapsed(), bound, metrics=metrics)
