"""pIRS for labeled goals: a scene in, a validated plan out.

``plan_scene`` builds the work cell's space (``cell_pirs.CellPirs``), runs pIRS (``pirs``)
within the budget, merges two moves of a block where the plan allows (``shortcut``), drops
what the plan does without and replays the result through the independent validator
(``outcome.finish_plan``). It returns a plan with every parameter, or a failure naming the
block and the reason, and the certified lower bound either way (``bound``); it raises
``ValueError``/``MessageError`` only for input it cannot accept.
"""

from __future__ import annotations

import numpy as np

from msgs_py import MessageError, Scene
from nodes.planner.assembly import Assembly
from nodes.planner.bound import LowerBound, labeled_bound
from nodes.planner.budget import Budget
from nodes.planner.cell_pirs import CellPirs
from nodes.planner.config import PlannerConfig
from nodes.planner.context import PlanContext, at_pose
from nodes.planner.outcome import PlanOutcome, failed, finish_plan
from nodes.planner.pirs import Pirs, PirsOptions, PlanningFailure
from nodes.planner.shortcut import shortcut

PLANNER_NAME = "pirs"


def misplaced(scene: Scene, config: PlannerConfig) -> int:
    """Blocks not already on their goal (labeled goals)."""
    yaw_exact = scene.goal is not None and scene.goal.yaw_exact
    return sum(not at_pose(scene.block(b).pose, goal, config.goal_tolerance_xy,
                           config.goal_tolerance_yaw, yaw_exact)
               for b, goal in scene.goal_assignment().items())


def check_scene(scene: Scene) -> None:
    """Refuse what this planner does not handle, naming the field."""
    if scene.goal is None:
        raise MessageError("goal", None, "the scene has no goal to plan for")
    if not scene.goal.labeled:
        raise MessageError("labeled", False, "pIRS plans labeled goals; unlabeled ones go to "
                           "the pebble-graph planner")


def plan_scene(scene: Scene, config: PlannerConfig, budget: Budget | None = None,
               plan_id: str | None = None) -> PlanOutcome:
    """Plan ``scene`` (start blocks + labeled goal) within ``budget`` (default: ``budget_s``
    from now).

    Raises:
        MessageError: no goal, or an unlabeled goal.
        ValueError: a gripper/block combination the geometry cannot use.
    """
    check_scene(scene)
    budget = budget or Budget.of(config.budget_s)
    ctx = PlanContext.for_scene(scene, config)
    goals = scene.goal_assignment()
    start = {b.id: b.pose for b in scene.blocks}
    yaw_exact = scene.goal.yaw_exact
    assembly = Assembly(ctx, goals)
    bound = labeled_bound(ctx, start, goals, yaw_exact, assembly)
    metrics = {"lower_bound": float(bound.value), "misplaced": float(bound.misplaced),
               "n_blocks": float(len(start))}
    walled = assembly.stuck(0)
    if walled:
        return failed(budget, bound.value, f"block {walled[0]}: the goal layout walls in the "
                      f"slots of blocks {walled}: in no order can they be set down or pushed "
                      "in", walled[0], metrics)
    space = CellPirs(ctx, goals, yaw_exact, np.random.default_rng(config.seed), assembly,
                     bound.relaxation)
    search = Pirs(space, frozenset(goals), frozenset(start) - frozenset(goals), budget,
                  PirsOptions(config.probe, config.max_depth))
    keep = _kept(space, assembly, bound, start)
    try:
        actions, _ = search.run(start, keep)
    except PlanningFailure as failure:
        metrics.update(search.stats.as_metrics())
        return failed(budget, bound.value, str(failure), failure.block, metrics)
    metrics.update(search.stats.as_metrics())
    if config.shortcut:
        before = len(actions)
        actions = shortcut(ctx, start, actions)
        metrics["shortcut_saved"] = float(before - len(actions))
    return finish_plan(scene, config, actions, PLANNER_NAME, budget, bound.value, metrics,
                       plan_id)


def _kept(space: CellPirs, assembly: Assembly, bound: LowerBound, start) -> frozenset[int]:
    """Blocks on their goal that the search first tries to leave there: those the bound's
    best relaxed plan keeps, else as many as leave every other slot enterable."""
    done = frozenset(b for b in space.goals if space.at_goal(b, start))
    if bound.exact:
        return done & bound.keep
    kept = assembly.keepable(assembly.mask(done))
    return frozenset(b for b in done if kept & assembly.bit[b])
