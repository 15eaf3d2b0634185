"""One entry point for every goal kind: labeled, unlabeled, retrieval (labeled, some free).

The planner node and ``densepack-plan`` call ``check_goal`` (on a goal's arrival) and
``plan_goal``; which planner runs is the goal's kind and the ``unlabeled.method`` /
``unlabeled.retrieval_method`` parameters (an apriltag_ros-style name -> function map). Every
planner takes one ``Budget``: started here from ``budget_s`` and the caller's stop request,
shared out here (near-goal first attempt, fallbacks) and nowhere else.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

from msgs_py import BlockPose, MessageError, Scene
from msgs_py.scene import square_half_extent
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import check_scene_size
from nodes.planner.labeled.plan_labeled import misplaced, plan_scene
from nodes.planner.outcome import PlanOutcome
from nodes.planner.unlabeled.baseline import plan_assignment
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.plan_unlabeled import plan_unlabeled, unfilled
from nodes.planner.unlabeled.portfolio import plan_portfolio
from nodes.planner.unlabeled.retrieval import is_retrieval, plan_retrieval
from nodes.robot.reach import check_scene_reach

#: A planner: (scene, config, unlabeled config, budget, plan id) -> outcome.
Planner = Callable[[Scene, PlannerConfig, UnlabeledConfig, Budget, "str | None"], PlanOutcome]


def _pirs(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig, budget: Budget,
          plan_id: str | None) -> PlanOutcome:
    return plan_scene(scene, config, budget, plan_id)


UNLABELED: dict[str, Planner] = {"portfolio": plan_portfolio, "pebble_graphs": plan_unlabeled,
                                 "assignment": plan_assignment}
RETRIEVAL: dict[str, Planner] = {"pebble_graphs": plan_retrieval, "pirs": _pirs}
#: Per goal kind, the planner that takes over (within the rest of the budget) when the
#: pebble-graph planner fails.
FALLBACK = {"unlabeled": "assignment", "retrieval": "pirs"}


def goal_kind(scene: Scene) -> str:
    """'unlabeled', 'retrieval' (labeled, some blocks left free) or 'labeled'."""
    if scene.goal is None:
        raise MessageError("goal", None, "the scene has no goal to plan for")
    if not scene.goal.labeled:
        return "unlabeled"
    return "retrieval" if is_retrieval(scene) else "labeled"


def check_goal(scene: Scene) -> None:
    """Refuse a goal no planner handles, naming the field: no goal, more blocks or slots than
    the planner takes, an unlabeled goal asking for ``yaw_exact``, a block or a slot out of
    the arm's reach."""
    check_scene_size(scene)
    kind = goal_kind(scene)
    if kind == "unlabeled" and scene.goal.yaw_exact:
        raise MessageError("yaw_exact", True, "unlabeled goals are met with yaw modulo 90 "
                           "degrees; yaw_exact is not supported for them")
    check_scene_reach(scene)


def planners_for(scene: Scene, ucfg: UnlabeledConfig) -> list[tuple[str, Planner]]:
    """(name, planner) to try in turn for ``scene``'s goal kind: the configured one, then its
    fallback."""
    kind = goal_kind(scene)
    if kind == "labeled" or (kind == "retrieval" and scene.goal.yaw_exact):
        return [("pirs", _pirs)]
    table = UNLABELED if kind == "unlabeled" else RETRIEVAL
    first = ucfg.method if kind == "unlabeled" else ucfg.retrieval_method
    names = [first, *([FALLBACK[kind]] if first == "pebble_graphs" else [])]
    return [(f"{kind} {name}", table[name]) for name in names]


def plan_goal(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig | None = None,
              plan_id: str | None = None,
              should_stop: Callable[[], bool] | None = None) -> PlanOutcome:
    """Plan ``scene`` whatever its goal kind within ``config.budget_s`` (``should_stop``,
    polled by every search, ends it early as a failure). Blocks near their goal are first
    corrected if that can be done within ``near_goal_budget_s``, else left where they stand
    (``metrics['near_goal_left']`` counts them).

    Raises:
        MessageError: no goal, a goal the chosen planner refuses, or a block or slot out of
            the arm's reach (named field).
        ValueError: a gripper/block combination the geometry cannot use.
    """
    check_goal(scene)
    ucfg = ucfg or UnlabeledConfig()
    budget = Budget.of(config.budget_s, should_stop)
    relaxed = dataclasses.replace(
        config,
        goal_tolerance_xy=max(config.goal_tolerance_xy, config.near_goal_tolerance_xy),
        goal_tolerance_yaw=max(config.goal_tolerance_yaw, config.near_goal_tolerance_yaw))
    near = _blocks_to_place(scene, config) - _blocks_to_place(scene, relaxed)
    if near <= 0:
        return plan_kind(scene, config, ucfg, budget, plan_id)
    strict = plan_kind(scene, config, ucfg, budget.capped(config.near_goal_budget_s), plan_id)
    if strict.ok or budget.expired():
        return _timed(strict, budget)
    leaving = plan_kind(scene, relaxed, ucfg, budget, plan_id)
    return _timed(dataclasses.replace(
        leaving, metrics={**leaving.metrics, "near_goal_left": float(near)}), budget)


def _blocks_to_place(scene: Scene, config: PlannerConfig) -> int:
    if goal_kind(scene) == "unlabeled":
        return unfilled(scene, config)
    return misplaced(scene, config)


def plan_kind(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig, budget: Budget,
              plan_id: str | None = None) -> PlanOutcome:
    """Plan ``scene`` with the planner of its goal kind; when that planner fails and has a
    fallback (the pebble-graph planners: assignment + pIRS, pIRS), the fallback gets what is
    left of ``budget`` and ``metrics['fallback']`` says so.

    Raises:
        MessageError: no goal, or a goal the chosen planner refuses (named field).
        ValueError: a gripper/block combination the geometry cannot use.
    """
    (name, planner), *rest = planners_for(scene, ucfg)
    outcome = planner(scene, config, ucfg, budget, plan_id)
    if outcome.ok or not rest or budget.expired():
        return _timed(outcome, budget)
    fallback = rest[0][1](scene, config, ucfg, budget, plan_id)
    error = fallback.error and f"{fallback.error} ({name}: {outcome.error})"
    return _timed(dataclasses.replace(fallback, metrics={**fallback.metrics, "fallback": 1.0},
                                      error=error), budget)


def _timed(outcome: PlanOutcome, budget: Budget) -> PlanOutcome:
    """``outcome`` with the planning time counted from the start of ``budget``."""
    return dataclasses.replace(outcome, planning_time_s=budget.elapsed())


def pulled_inside(blocks: Sequence[BlockPose], layout: Scene, margin: float
                  ) -> tuple[BlockPose, ...]:
    """The blocks, those seen on the workspace's table margin (within ``margin`` of its edge:
    knocked there, or seen there by a camera a centimetre off) moved straight in until their
    footprint is inside. The plan starts from there; the executor brings such a block in
    before it runs the plan, and replans if it then stands elsewhere. Blocks further out are
    left as they are (the scene refuses them, naming the block)."""
    ws, size = layout.workspace, layout.block_size
    table = ws.grown(margin)
    out = []
    for b in blocks:
        if ws.contains_square(b, size) or not table.contains_square(b, size):
            out.append(b)
            continue
        half = square_half_extent(size, b.theta) + 1e-6
        out.append(BlockPose(b.id, min(max(b.x, ws.x_min + half), ws.x_max - half),
                             min(max(b.y, ws.y_min + half), ws.y_max - half), b.theta))
    return tuple(out)
