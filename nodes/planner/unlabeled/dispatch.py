"""One entry point for every goal kind: labeled, unlabeled, retrieval (labeled, some free).

The planner node and ``densepack-plan`` call ``plan_goal``; which planner runs is the goal's
kind and the ``unlabeled.method`` / ``unlabeled.retrieval_method`` parameters (an
apriltag_ros-style name -> function map).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

from msgs_py import MessageError, Scene
from nodes.planner.config import PlannerConfig
from nodes.planner.planner import PlanOutcome, lower_bound, plan_scene
from nodes.planner.unlabeled.baseline import plan_assignment
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.planner import plan_unlabeled, unlabeled_lower_bound
from nodes.planner.unlabeled.retrieval import is_retrieval, plan_retrieval

Planner = Callable[..., PlanOutcome]

UNLABELED: dict[str, Planner] = {"pebble_graphs": plan_unlabeled, "assignment": plan_assignment}


def check_goal(scene: Scene) -> None:
    """Refuse a goal no planner handles, naming the field (for the node, on arrival)."""
    kind = goal_kind(scene)
    if kind == "unlabeled" and scene.goal.yaw_exact:
        raise MessageError("yaw_exact", True, "unlabeled goals are met with yaw modulo 90 "
                           "degrees; yaw_exact is not supported for them")


def goal_kind(scene: Scene) -> str:
    """'unlabeled', 'retrieval' (labeled, some blocks left free) or 'labeled'."""
    if scene.goal is None:
        raise MessageError("goal", None, "the scene has no goal to plan for")
    if not scene.goal.labeled:
        return "unlabeled"
    return "retrieval" if is_retrieval(scene) else "labeled"


def plan_goal(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig | None = None,
              plan_id: str | None = None,
              should_stop: Callable[[], bool] | None = None) -> PlanOutcome:
    """Plan ``scene`` whatever its goal kind, near-goal blocks first corrected if that can be
    done within ``near_goal_budget_s``, else left where they stand (``metrics['near_goal_left']``
    counts them). Raises as ``plan_kind``."""
    relaxed = dataclasses.replace(
        config,
        goal_tolerance_xy=max(config.goal_tolerance_xy, config.near_goal_tolerance_xy),
        goal_tolerance_yaw=max(config.goal_tolerance_yaw, config.near_goal_tolerance_yaw))
    near = _blocks_to_place(scene, config) - _blocks_to_place(scene, relaxed)
    if near <= 0:
        return plan_kind(scene, config, ucfg, plan_id, should_stop)
    t0 = time.monotonic()
    strict = plan_kind(scene, dataclasses.replace(
        config, budget_s=min(config.budget_s, config.near_goal_budget_s)),
        ucfg, plan_id, should_stop)
    if strict.ok:
        return strict
    leaving = _in_rest_of_budget(strict, t0, config, should_stop, lambda cfg: plan_kind(
        scene, dataclasses.replace(relaxed, budget_s=cfg.budget_s), ucfg, plan_id,
        should_stop))
    if leaving is None:
        return strict
    return dataclasses.replace(leaving, metrics={**leaving.metrics, "near_goal_left": float(near)})


def _blocks_to_place(scene: Scene, config: PlannerConfig) -> int:
    if goal_kind(scene) == "unlabeled":
        return unlabeled_lower_bound(scene, config)
    return lower_bound(scene, config)


def plan_kind(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig | None = None,
              plan_id: str | None = None,
              should_stop: Callable[[], bool] | None = None) -> PlanOutcome:
    """Plan ``scene`` with the planner of its goal kind.

    When the pebble-graph planner fails an unlabeled goal, the baseline (assignment + pIRS)
    gets what is left of the time budget; a retrieval it cannot do (or one asking for
    ``yaw_exact``) goes to pIRS the same way; ``metrics['fallback']`` says so.

    Raises:
        MessageError: no goal, or a goal the chosen planner refuses (named field).
        ValueError: a gripper/block combination the geometry cannot use.
    """
    ucfg = ucfg or UnlabeledConfig()
    kind = goal_kind(scene)
    if kind == "unlabeled":
        t0 = time.monotonic()
        outcome = UNLABELED[ucfg.method](scene, config, ucfg, plan_id, should_stop)
        if ucfg.method == "pebble_graphs" and not outcome.ok:
            return _fall_back(outcome, t0, config, should_stop, lambda cfg: plan_assignment(
                scene, cfg, ucfg, plan_id, should_stop), "pebble-graph planner")
        return outcome
    if kind == "labeled":
        return plan_scene(scene, config, plan_id, should_stop)
    if ucfg.retrieval_method == "pirs" or scene.goal.yaw_exact:
        return plan_scene(scene, config, plan_id, should_stop)
    t0 = time.monotonic()
    outcome = plan_retrieval(scene, config, ucfg, plan_id, should_stop)
    if outcome.ok:
        return outcome
    return _fall_back(outcome, t0, config, should_stop,
                      lambda cfg: plan_scene(scene, cfg, plan_id, should_stop),
                      "pebble-graph retrieval")


def _fall_back(outcome: PlanOutcome, t0: float, config: PlannerConfig,
               should_stop: Callable[[], bool] | None,
               other: Callable[[PlannerConfig], PlanOutcome], what: str) -> PlanOutcome:
    """``other`` within what is left of the budget after ``outcome`` failed."""
    fallback = _in_rest_of_budget(outcome, t0, config, should_stop, other)
    if fallback is None:
        return outcome
    metrics = {**fallback.metrics, "fallback": 1.0}
    error = fallback.error and f"{fallback.error} ({what}: {outcome.error})"
    return dataclasses.replace(fallback, metrics=metrics, error=error)


def _in_rest_of_budget(outcome: PlanOutcome, t0: float, config: PlannerConfig,
                       should_stop: Callable[[], bool] | None,
                       other: Callable[[PlannerConfig], PlanOutcome]) -> PlanOutcome | None:
    """``other``'s outcome (timed from ``t0``) within what is left of the budget since
    ``t0``; None when nothing is left or the caller asked to stop."""
    remaining = config.budget_s - (time.monotonic() - t0)
    if remaining <= 0.0 or (should_stop is not None and should_stop()):
        return None
    second = other(dataclasses.replace(config, budget_s=remaining))
    return dataclasses.replace(second, planning_time_s=time.monotonic() - t0)
