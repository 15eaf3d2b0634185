"""Unlabeled goals by a portfolio: the pebble-graph planner, then the assignment baseline,
the shorter validated plan kept.

Neither method dominates in cramped scenes: the pebble graphs choose order and assignment
together (a block in the way goes straight into a free slot), while assignment + pIRS
searches the labeled problem with pIRS's clears, passes and restarts, which in a cramped
workspace can find room the graphs' conservative edges (every other site occupied) do not (9
interchangeable blocks in a 0.30 m square: 15 actions from the graphs, 13 from assignment).
The graphs get half the budget; the baseline what is left, unless the graphs' plan already
meets the certified lower bound (nothing is shorter).
"""

from __future__ import annotations

import dataclasses

from msgs_py import Scene
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.outcome import PlanOutcome
from nodes.planner.unlabeled.baseline import plan_assignment
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.plan_unlabeled import check_unlabeled, plan_unlabeled

#: Share of the budget the pebble graphs may use before the baseline runs.
GRAPHS_SHARE = 0.5


def plan_portfolio(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig,
                   budget: Budget | None = None, plan_id: str | None = None) -> PlanOutcome:
    """Both unlabeled planners on ``scene``; the outcome with fewer actions (the pebble
    graphs' on a tie), its metrics those of every run (the kept one's where both have a key)
    and what each found (``portfolio_<planner>``: actions, -1 for no plan).

    Raises:
        MessageError: no goal, a labeled goal, or ``yaw_exact``.
    """
    check_unlabeled(scene)
    budget = budget or Budget.of(config.budget_s)
    graphs = plan_unlabeled(scene, config, ucfg, budget.share(GRAPHS_SHARE), plan_id)
    tried = [graphs]
    if not (graphs.ok and len(graphs.plan.actions) <= graphs.lower_bound) \
            and not budget.expired():
        tried.append(plan_assignment(scene, config, ucfg, budget, plan_id))
    found = [o for o in tried if o.ok]
    best = min(found, key=lambda o: len(o.plan.actions)) if found else tried[-1]
    metrics: dict[str, float] = {}
    for outcome in [*tried, best]:  # every run's search figures; the kept one's last
        metrics.update(outcome.metrics)
    for name, outcome in zip(("pebble_graphs", "assignment"), tried, strict=False):
        metrics[f"portfolio_{name}"] = float(len(outcome.plan.actions)) if outcome.ok else -1.0
    error = "; ".join(o.error for o in tried if o.error) if not found else ""
    return dataclasses.replace(best, metrics=metrics, error=error,
                               planning_time_s=budget.elapsed(),
                               lower_bound=max(o.lower_bound for o in tried))
