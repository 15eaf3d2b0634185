"""The planner's one entry point: a scene with a labeled goal in, a validated plan out.

``plan_scene`` runs pIRS within the configured time budget, replays the result through the
independent validator, and returns either a ``Plan`` (with every parameter, the scene and a
unique id) or a failure naming the block and the reason. It never raises for a scene it
cannot solve; it raises ``ValueError``/``MessageError`` only for input it cannot accept.
"""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from msgs_py import MessageError, Plan, Scene
from nodes.planner.config import PlannerConfig
from nodes.planner.context import PlanContext, at_pose
from nodes.planner.search import PlanningFailure, Search
from nodes.planner.shortcut import shortcut
from nodes.planner.validator import validate_plan

PLANNER_NAME = "pirs"


@dataclass(frozen=True)
class PlanOutcome:
    plan: Plan | None
    planning_time_s: float
    lower_bound: int
    error: str = ""
    failed_block: int | None = None
    metrics: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.plan is not None


def lower_bound(scene: Scene, config: PlannerConfig) -> int:
    """Actions at least needed: blocks not already on their goal (labeled goals)."""
    yaw_exact = scene.goal is not None and scene.goal.yaw_exact
    return sum(not at_pose(scene.block(b).pose, goal, config.goal_tolerance_xy,
                           config.goal_tolerance_yaw, yaw_exact)
               for b, goal in scene.goal_assignment().items())


def check_scene(scene: Scene) -> None:
    """Refuse what this planner does not handle, naming the field."""
    if scene.goal is None:
        raise MessageError("goal", None, "the scene has no goal to plan for")
    if not scene.goal.labeled:
        raise MessageError("labeled", False, "unlabeled goals (any block in any slot) are not "
                           "supported by this planner yet (issue 7)")


def plan_scene(scene: Scene, config: PlannerConfig, plan_id: str | None = None,
               should_stop: Callable[[], bool] | None = None) -> PlanOutcome:
    """Plan ``scene`` (start blocks + labeled goal) with ``config``; ``should_stop`` (polled
    between roadmap queries) ends the search early as a failure.

    Raises:
        MessageError: no goal, or an unlabeled goal.
        ValueError: a gripper/block combination the geometry cannot use.
    """
    check_scene(scene)
    ctx = PlanContext.for_scene(scene, config)
    t0 = time.monotonic()
    bound = lower_bound(scene, config)
    goals = scene.goal_assignment()
    start = {b.id: b.pose for b in scene.blocks}
    metrics: dict[str, float] = {"lower_bound": float(bound), "n_blocks": float(len(start))}
    try:
        search = Search(ctx, start, goals, scene.goal.yaw_exact,
                        np.random.default_rng(config.seed), t0 + config.budget_s)
        if should_stop is not None:
            search.should_stop = should_stop
        actions, _ = search.run()
        metrics.update(search.stats.as_metrics())
        if config.shortcut:
            before = len(actions)
            actions = shortcut(ctx, start, actions)
            metrics["shortcut_saved"] = float(before - len(actions))
    except PlanningFailure as failure:
        elapsed = time.monotonic() - t0
        if "search" in locals():
            metrics.update(search.stats.as_metrics())
        return PlanOutcome(None, elapsed, bound, str(failure), failure.block, metrics)
    elapsed = time.monotonic() - t0
    plan = Plan(
        actions=tuple(actions),
        planner=PLANNER_NAME,
        params=config.to_params(scene.block_size),
        seed=config.seed,
        planning_time_s=elapsed,
        cost=ctx.cost.plan(actions),
        plan_id=plan_id or uuid.uuid4().hex[:12],
        scene=scene,
    )
    report = validate_plan(plan)
    if not report.ok:
        return PlanOutcome(None, elapsed, bound, "internal error: the plan failed replay "
                           f"validation ({'; '.join(report.errors[:3])})", None, metrics)
    metrics["actions"] = float(len(actions))
    return PlanOutcome(plan, elapsed, bound, metrics=metrics)
