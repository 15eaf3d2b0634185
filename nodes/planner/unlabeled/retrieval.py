"""Retrieval: a labeled goal that names only some blocks; the others are free.

The paper's shelf example: to reach the can at the back, move the similar cans in front out
of the way, wherever they fit. For each named block in turn (assembly order of their
targets): list the ways it could get to its target ignoring the free blocks (``CellSites.
options``: grasps, pushes, place-and-push, push-and-place) with the area each needs; take the
one the fewest free blocks stand in; clear that area with the unlabeled hypergraph search
(the named blocks are fixed obstacles, any free block may go anywhere out of the area);
then move the named block. A named block, once on its target, stays fixed.
"""

from __future__ import annotations

import numpy as np
import shapely

from msgs_py import MessageError, Scene
from msgs_py.actions import Action
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import labeled_bound
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import at_pose, nearest_goal_yaw
from nodes.planner.outcome import PlanOutcome, failed, finish_plan
from nodes.planner.unlabeled.cell_transfers import realize, realize_all
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.hypergraph import (
    ArrangementGoal,
    HypergraphSearch,
    SearchConfig,
    SearchFailure,
)
from nodes.planner.unlabeled.plan_unlabeled import make_space
from nodes.planner.unlabeled.rpg import Site
from nodes.planner.unlabeled.smoothing import n_actions, smooth

PLANNER_NAME = "pebble_graphs_retrieval"
#: Ways to the target tried per named block (fewest blockers first).
OPTIONS_TRIED = 6


def is_retrieval(scene: Scene) -> bool:
    """A labeled goal with explicit poses that leaves some of the scene's blocks free."""
    goal = scene.goal
    return (goal is not None and goal.labeled and goal.grid is None
            and len(goal.slots) < len(scene.blocks))


class _Retrieval:
    def __init__(self, scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig,
                 budget: Budget) -> None:
        self.scene, self.config, self.ucfg = scene, config, ucfg
        self.budget = budget
        self.ctx, self.space = make_space(scene, config, ucfg)
        self.targets = scene.goal_assignment()
        self.pose = {b.id: b.pose for b in scene.blocks}
        self.site = {b.id: self.space.add_site(b.pose) for b in scene.blocks}
        self.free = sorted(set(self.pose) - set(self.targets))
        self.rng = np.random.default_rng(config.seed)
        self.actions: list[Action] = []
        self.raw = 0
        self.stats = {"expansions": 0.0, "rpgs": 0.0, "hypernodes": 0.0}

    def order(self) -> list[int]:
        return Assembly(self.ctx, dict(self.targets)).order()

    def run(self) -> None:
        cfg = self.config
        for block in self.order():
            goal = nearest_goal_yaw(self.targets[block], self.pose[block].theta, False)
            if at_pose(self.pose[block], goal, cfg.goal_tolerance_xy, cfg.goal_tolerance_yaw,
                       False):
                continue
            self.retrieve(block, self.space.add_site(goal))

    def retrieve(self, block: int, target: Site) -> None:
        space = self.space
        named = [self.pose[b] for b in self.targets if b != block]
        space.set_fixed(named)
        options = space.options(self.site[block], target)
        if not options:
            raise _Failed(block, "no grasp or push gets it to its target even with every "
                          "free block gone (fixed blocks, workspace or table edge in the way)")
        free_sites = {self.site[b] for b in self.free}

        def blockers(region: shapely.Geometry) -> int:
            return sum(space.overlaps(s, region) for s in free_sites)
        ranked = sorted(options, key=lambda o: (blockers(o[1]), o[0].n_actions, o[0].cost))
        space.set_fixed([*named, self.pose[block]])
        last = "no way to its target could be cleared"
        for transfer, region in ranked[:OPTIONS_TRIED]:
            try:
                self.clear(region)
            except SearchFailure as failure:
                last = f"could not clear its way: {failure.reason}"
                continue
            space.set_fixed(named)
            acts, self.pose[block] = realize(transfer, block, self.pose[block])
            self.actions += acts
            self.raw += transfer.n_actions
            self.site[block] = target
            return
        raise _Failed(block, last)

    def clear(self, region: shapely.Geometry) -> None:
        """Move the free blocks out of ``region`` (the named blocks are fixed)."""
        space = self.space
        start = {self.site[b]: b for b in self.free}
        if not any(space.overlaps(s, region) for s in start):
            return
        space.set_zone(shapely.buffer(region, space.buffer_clearance, join_style="mitre"),
                       (), region)
        goal = ArrangementGoal((), forbidden=lambda s: space.overlaps(s, region))
        search = HypergraphSearch(
            space, start, goal,
            SearchConfig(b=max(self.ucfg.b, 1), weight=self.ucfg.weight,
                         budget=self.budget, max_expansions=self.ucfg.max_expansions,
                         max_proposals=self.ucfg.max_proposals), self.rng)
        try:
            transfers = search.run()
        finally:
            for k, v in search.stats.as_metrics().items():
                if k in self.stats:
                    self.stats[k] += v
        self.raw += n_actions(transfers)
        if self.ucfg.smoothing:
            transfers, _ = smooth(space, start, transfers)
        acts = realize_all(start, self.pose, transfers)
        self.actions += acts
        for a in acts:
            self.pose[a.block] = a.to
        at = dict(start)
        for t in transfers:
            at[t.target] = at.pop(t.source)
        for s, b in at.items():
            self.site[b] = s


class _Failed(Exception):
    def __init__(self, block: int, reason: str) -> None:
        super().__init__(reason)
        self.block = block
        self.reason = reason


def plan_retrieval(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig,
                   budget: Budget | None = None, plan_id: str | None = None) -> PlanOutcome:
    """Plan a labeled goal that names only some blocks (see the module docstring).

    Raises:
        MessageError: the goal is not such a goal, or asks for ``yaw_exact``.
    """
    if not is_retrieval(scene):
        raise MessageError("goal", None, "retrieval needs a labeled goal with explicit poses "
                           "that leaves some blocks free")
    if scene.goal.yaw_exact:
        raise MessageError("yaw_exact", True, "retrieval meets yaw modulo 90 degrees; use "
                           "the pirs method for yaw_exact goals")
    budget = budget or Budget.of(config.budget_s)
    run = _Retrieval(scene, config, ucfg, budget)
    bound = labeled_bound(run.ctx, run.pose, run.targets, False).value
    metrics: dict[str, float] = {"lower_bound": float(bound),
                                 "n_blocks": float(len(scene.blocks))}
    try:
        run.run()
    except _Failed as failure:
        metrics.update(run.stats)
        return failed(budget, bound, f"block {failure.block}: {failure.reason}", failure.block,
                      metrics)
    metrics.update(run.stats)
    metrics["actions_raw"] = float(run.raw)
    return finish_plan(scene, config, run.actions, PLANNER_NAME, budget, bound, metrics,
                       plan_id, ucfg.to_params())
