"""Unlabeled goals: a scene whose slots any block may fill in, a validated plan out.

The blocks' poses and the goal slots become sites of a ``CellSites``; the slots are ordered
by the planner's assembly order (which slot can still be entered once its neighbours are
there); the hypergraph search connects the start arrangement to one that fills every slot;
smoothing shortens the transfer sequence; each transfer becomes pick-and-place / push actions
for the block that stands on its source; the replay validator checks the plan.
Never raises for a scene it cannot solve: the outcome names the reason.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence

import numpy as np
import shapely

from msgs_py import MessageError, Pose2D, Scene
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import unlabeled_bound
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.outcome import PlanOutcome, failed, finish_plan
from nodes.planner.unlabeled.cell_geometry import CellSites
from nodes.planner.unlabeled.cell_transfers import realize_all
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.goal_check import on_slot, unfilled_slots
from nodes.planner.unlabeled.hypergraph import (
    ArrangementGoal,
    HypergraphSearch,
    SearchConfig,
    SearchFailure,
)
from nodes.planner.unlabeled.rpg import Site
from nodes.planner.unlabeled.smoothing import n_actions, smooth

PLANNER_NAME = "pebble_graphs"


def check_unlabeled(scene: Scene) -> None:
    """Refuse what this planner does not handle, naming the field."""
    if scene.goal is None:
        raise MessageError("goal", None, "the scene has no goal to plan for")
    if scene.goal.labeled:
        raise MessageError("labeled", True, "this planner is for unlabeled goals")
    if scene.goal.yaw_exact:
        raise MessageError("yaw_exact", True, "unlabeled goals are met with yaw modulo 90 "
                           "degrees; yaw_exact is not supported for them")


def unfilled(scene: Scene, config: PlannerConfig) -> int:
    """Slots that no block stands on yet (each needs an action)."""
    return len(unfilled_slots(scene, (b.pose for b in scene.blocks), config.goal_tolerance_xy,
                              config.goal_tolerance_yaw))


def certified_bound(ctx: PlanContext, scene: Scene, assembly: Assembly) -> int:
    """``bound.unlabeled_bound`` for ``scene``."""
    slots = scene.goal.slot_poses(scene.block_size)
    empty = set(unfilled_slots(scene, (b.pose for b in scene.blocks),
                               ctx.config.goal_tolerance_xy, ctx.config.goal_tolerance_yaw))
    return unlabeled_bound(ctx, [b.pose for b in scene.blocks], slots,
                           [k not in empty for k in range(len(slots))], assembly).value


def make_space(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig,
               fixed: Sequence[Pose2D] = (), buffer_yaw: float = 0.0
               ) -> tuple[PlanContext, CellSites]:
    ctx = PlanContext.for_scene(scene, config)
    return ctx, CellSites(ctx, fixed, ucfg.push_lengths, buffer_yaw)


def goal_zone(space: CellSites, poses: Iterable[Pose2D]
              ) -> tuple[shapely.Geometry, shapely.Geometry]:
    """The slots' footprints (core) and the core grown by the fingers' reach (zone): blocks
    parked in the zone are in the way."""
    core = shapely.union_all(space.footprints_of(list(poses)))
    return shapely.buffer(core, space.buffer_clearance, join_style="mitre"), core


def slot_sites(space: CellSites, scene: Scene, block_sites: Mapping[int, Site],
               config: PlannerConfig) -> list[Site]:
    """A site per goal slot; a block already on a slot lends its own site (it may stay)."""
    out, used = [], set()
    for slot in scene.goal.slot_poses(scene.block_size):
        there = next((s for s in block_sites.values() if s not in used and on_slot(
            space.pose(s), slot, config.goal_tolerance_xy, config.goal_tolerance_yaw, False)),
            None)
        if there is not None:
            used.add(there)
            out.append(there)
        else:
            out.append(space.add_site(slot))
    return out


def plan_unlabeled(scene: Scene, config: PlannerConfig, ucfg: UnlabeledConfig,
                   budget: Budget | None = None, plan_id: str | None = None) -> PlanOutcome:
    """Plan ``scene`` (start blocks + unlabeled goal) with rearrangement pebble graphs
    within ``budget`` (default: ``budget_s`` from now; its stop request is polled between
    hypernode expansions).

    Raises:
        MessageError: no goal, a labeled goal, or ``yaw_exact``.
        ValueError: a gripper/block combination the geometry cannot use.
    """
    check_unlabeled(scene)
    budget = budget or Budget.of(config.budget_s)
    slots = scene.goal.slot_poses(scene.block_size)
    ctx, space = make_space(scene, config, ucfg, buffer_yaw=slots[0].theta if slots else 0.0)
    assembly = Assembly(ctx, dict(enumerate(slots)))
    bound = certified_bound(ctx, scene, assembly)
    metrics: dict[str, float] = {"lower_bound": float(bound), "n_blocks": float(len(scene.blocks)),
                                 "b": float(ucfg.b)}
    block_sites = {b.id: space.add_site(b.pose) for b in scene.blocks}
    sites = slot_sites(space, scene, block_sites, config)
    walled = assembly.stuck(0)
    if walled:
        return failed(budget, bound, f"the goal layout walls in slots {walled}: no order lets "
                      "blocks be set down or pushed into them", None, metrics)
    search = _search(space, assembly, sites, block_sites.values(), ucfg, budget,
                     np.random.default_rng(config.seed), slots)
    try:
        transfers = search.run()
    except SearchFailure as failure:
        metrics.update(failure.stats.as_metrics())
        return failed(budget, bound, f"no plan: {failure.reason}", None, metrics)
    metrics.update(search.stats.as_metrics())
    metrics["actions_raw"] = float(n_actions(transfers))
    if ucfg.smoothing:
        transfers, _ = smooth(space, block_sites.values(), transfers)
    block_at = {site: block for block, site in block_sites.items()}
    poses = {b.id: b.pose for b in scene.blocks}
    actions = realize_all(block_at, poses, transfers)
    return finish_plan(scene, config, actions, PLANNER_NAME, budget, bound, metrics, plan_id,
                       ucfg.to_params())


def _search(space: CellSites, assembly: Assembly, sites: list[Site], start: Iterable[Site],
            ucfg: UnlabeledConfig, budget: Budget, rng: np.random.Generator,
            slots: list[Pose2D]) -> HypergraphSearch:
    """The hypergraph search filling the slot ``sites`` in assembly order."""
    required = tuple(sites[k] for k in assembly.order())
    bit = {site: 1 << k for k, site in enumerate(sites)}

    def filled(arrangement: frozenset[Site]) -> int:
        return sum(bit[s] for s in arrangement if s in bit)

    def pushes_ahead(arrangement: frozenset[Site]) -> int:
        return assembly.future_pushes(filled(arrangement))

    def order(arrangement: frozenset[Site]) -> list[Site]:
        return [sites[k] for k in assembly.order(filled(arrangement))]

    zone, core = goal_zone(space, slots)
    space.set_zone(zone, sites, core)
    return HypergraphSearch(
        space, start, ArrangementGoal(required, extra=pushes_ahead, order=order),
        SearchConfig(b=ucfg.b, weight=ucfg.weight, budget=budget,
                     max_expansions=ucfg.max_expansions, max_proposals=ucfg.max_proposals),
        rng)
