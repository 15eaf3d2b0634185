"""pIRS for labeled goals: a scene in, a validated plan out.

``plan_scene`` builds the work cell's space (``cell_pirs.CellPirs``), runs pIRS (``pirs``)
within the budget, merges two moves of a block where the plan allows (``shortcut``, then
``rebuffer`` with buffers chosen in hindsight) and drops what the plan does without
(``necessity``); then restarts pIRS within the improvement
budget and keeps the shortest validated plan (``improve``), and replays the result through
the independent validator (``outcome.finish_plan``). It returns a plan with every
parameter, or a failure naming the block and the reason, and the certified lower bound
either way (``bound``); it raises ``ValueError``/``MessageError`` only for input it cannot
accept. A start that leaves a block off its goal that no grasp or push can ever free
(``frozen``) gets only ``frozen_budget_s``, and the failure names those blocks.
"""

from __future__ import annotations

import copy
import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from msgs_py import MessageError, Plan, Pose2D, Scene
from msgs_py.actions import Action
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import INF, LowerBound, labeled_bound
from nodes.planner.bounds.exact import ExactLimit, ExactResult, NoShorterPlan, exact_plan
from nodes.planner.bounds.frozen import FROZEN_WHY, LOCKED_WHY, frozen_off_goal, locked_blocks
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext, at_pose
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.labeled.cell_pirs import CellPirs
from nodes.planner.labeled.pirs import Pirs, PirsOptions, PlanningFailure
from nodes.planner.outcome import PlanOutcome, failed, finish_plan
from nodes.planner.passes.improve import ImproveSettings, improve
from nodes.planner.passes.necessity import necessary_actions
from nodes.planner.passes.rebuffer import rebuffer
from nodes.planner.passes.reinsert import reinsert
from nodes.planner.passes.shortcut import shortcut

PLANNER_NAME = "pirs"
#: The plan's planner when the exact search's plan (over its pose set) is kept.
EXACT_NAME = "pirs_exact"


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
    frozen = frozen_off_goal(ctx, start, goals, yaw_exact)
    if frozen:  # almost surely no plan: fail soon, saying why
        budget = replace(budget, deadline=min(budget.deadline, time.monotonic()
                                              + config.frozen_budget_s))
        metrics["frozen"] = float(len(frozen))
    attempt = _Attempt(scene, config, ctx, assembly, bound, start)
    exact = attempt.exact(budget, metrics) if not frozen else None
    if exact is not None and len(exact) <= bound.value:  # no plan at all is shorter
        return finish_plan(scene, config, exact, EXACT_NAME, budget, bound.value, metrics,
                           plan_id, pruned=True)
    pirs_budget = budget if exact is None else budget.capped(config.exact_pirs_s)
    try:
        actions = attempt.solve(np.random.default_rng(config.seed), 0.0, pirs_budget, metrics)
    except PlanningFailure as failure:
        if exact is not None:
            metrics["pirs_failed"] = 1.0
            return finish_plan(scene, config, exact, EXACT_NAME, budget, bound.value, metrics,
                               plan_id, pruned=True)
        return failed(budget, bound.value, _why(failure, frozen, config, ctx, start),
                      failure.block, metrics)
    return _improved(attempt, actions, exact, pirs_budget, budget, metrics, plan_id)


def _why(failure: PlanningFailure, frozen: list[int], config: PlannerConfig,
         ctx: PlanContext, start: dict[int, Pose2D]) -> str:
    """The search's failure, with the real cause first where the start has one: frozen
    blocks (the short budget was this scene's own), else locked ones."""
    why = str(failure)
    if frozen:
        return (f"blocks {frozen} are off their goal and {FROZEN_WHY}, so the search got "
                f"only frozen_budget_s = {config.frozen_budget_s:g} s; it ended with {why}")
    locked = locked_blocks(ctx, start)
    if locked:
        return f"blocks {locked} {LOCKED_WHY}; the search ended with {why}"
    return why


def _improved(attempt: _Attempt, actions: list[Action], exact: list[Action] | None,
              pirs_budget: Budget, budget: Budget, metrics: dict[str, float],
              plan_id: str | None) -> PlanOutcome:
    """pIRS's first plan pruned, then its restarts (``improve``) against the shorter of it
    and the exact search's plan; the best, validated."""
    scene, config = attempt.scene, attempt.config
    before = len(actions)
    actions = necessary_actions(scene, attempt.params, actions)
    metrics["unneeded_dropped"] = float(before - len(actions))
    metrics["pirs_actions"] = float(len(actions))
    first_s = pirs_budget.elapsed()  # what one restart is expected to take
    use_exact = exact is not None and len(exact) <= len(actions)
    best = exact if use_exact else actions
    settings = ImproveSettings(config.improve_factor, config.improve_min_s, config.improve_max_s)
    better = improve(best, attempt.restart, attempt.valid,
                     pirs_budget.capped(settings.seconds(first_s)), attempt.bound.value,
                     first_s)
    metrics.update(better.metrics(len(best)))
    metrics["first_solve_s"] = first_s
    name = EXACT_NAME if use_exact and not better.better else PLANNER_NAME
    shorter = attempt.exact_below(better.best, budget, metrics)
    return finish_plan(scene, config, shorter or better.best,
                       EXACT_NAME if shorter else name, budget, attempt.bound.value,
                       metrics, plan_id, pruned=True)


@dataclass
class _Attempt:
    """One pIRS run on a scene: the first with the configured seed, restarts with their own
    generator stream and order jitter (``improve``)."""

    scene: Scene
    config: PlannerConfig
    ctx: PlanContext
    assembly: Assembly
    bound: LowerBound
    start: dict[int, Pose2D]

    @property
    def params(self) -> dict[str, Any]:
        return self.config.to_params(self.scene.block_size)

    def solve(self, rng: np.random.Generator, jitter: float, budget: Budget,
              metrics: dict[str, float]) -> list[Action]:
        """pIRS and the shortcut and rebuffer passes; raises PlanningFailure (search figures in
        ``metrics`` either way)."""
        # scenes the exact pose-set search plans first keep the paper's CLEAR: there pIRS
        # only tries to beat that plan, and routing round a failed blocker (for crowded
        # large scenes, where a failed chain costs seconds) made random 4 at 0.3 seed 5 longer.
        # Routing round thrashes in a few crowded scenes (49 at 0.4 seed 7: 512 backtracks in
        # 60 s) where the paper's CLEAR plans in 14 s: past max_backtracks the search starts
        # again that way, from the same generator state.
        route_round = len(self.start) > self.config.exact_max_blocks
        fallback = copy.deepcopy(rng) if route_round else None
        try:
            actions = self._search(rng, jitter, budget, metrics, route_round)
        except PlanningFailure as failure:
            if not failure.thrashed or fallback is None:
                raise
            metrics["thrashed"] = 1.0
            actions = self._search(fallback, jitter, budget, metrics, False)
        if self.config.shortcut:
            before = len(actions)
            actions = shortcut(self.ctx, self.start, actions)
            metrics["shortcut_saved"] = float(before - len(actions))
        if self.config.rebuffer:
            before = len(actions)
            actions = rebuffer(self.ctx, self.start, actions)
            metrics["rebuffer_saved"] = float(before - len(actions))
        if self.config.reinsert and not self.scene.goal.yaw_exact:
            before = len(actions)
            actions = reinsert(self.ctx, self.start, actions, self.valid,
                               set(self.scene.goal_assignment()))
            metrics["reinsert_saved"] = float(before - len(actions))
        return actions

    def _search(self, rng: np.random.Generator, jitter: float, budget: Budget,
                metrics: dict[str, float], route_round: bool) -> list[Action]:
        """pIRS's actions (search figures in ``metrics`` either way); routing round a failed
        blocker stops at ``max_backtracks``."""
        goals = self.scene.goal_assignment()
        space = CellPirs(self.ctx, goals, self.scene.goal.yaw_exact, rng, self.assembly,
                         self.bound.relaxation, jitter)
        options = PirsOptions(self.config.probe, self.config.max_depth, route_round,
                              self.config.max_backtracks if route_round else None)
        search = Pirs(space, frozenset(goals), frozenset(self.start) - frozenset(goals),
                      budget, options)
        try:
            actions, _ = search.run(self.start, _kept(space, self.assembly, self.bound,
                                                       self.start))
        finally:
            metrics.update(search.stats.as_metrics())
        return actions

    def exact(self, budget: Budget, metrics: dict[str, float]) -> list[Action] | None:
        """The exact search's plan (``exact``: fewest actions over its pose set), validated
        and pruned, for scenes of at most ``exact_max_blocks`` blocks, within
        ``exact_budget_s``; None where it does not apply or does not close."""
        cfg = self.config
        if (len(self.start) > cfg.exact_max_blocks or self.scene.goal.yaw_exact
                or not self.bound.misplaced):
            return None
        part = budget.capped(cfg.exact_budget_s)
        try:
            found = self._pose_set_search(part, cfg.exact_max_blocks)
        except ExactLimit:
            metrics["exact_closed"] = 0.0
            metrics["exact_s"] = part.elapsed()
            return None
        metrics["exact_closed"] = 1.0
        metrics["exact_s"] = part.elapsed()
        metrics["exact_actions"] = float(len(found.actions))
        actions = necessary_actions(self.scene, self.params, found.actions)
        return actions if self.valid(actions) else None

    def exact_below(self, best: list[Action], budget: Budget, metrics: dict[str, float]
                    ) -> list[Action] | None:
        """A plan shorter than ``best`` from the exact search over the pose set, pruned at
        ``best``'s length, for scenes of more than ``exact_max_blocks`` and at most
        ``exact_after_max_blocks`` blocks whose ``best`` is above the lower bound, within
        ``exact_after_s``; validated and pruned. None where it does not apply, finds none
        (``exact_after_proved``: none exists over the pose set) or does not close."""
        cfg = self.config
        if (not cfg.exact_max_blocks < len(self.start) <= cfg.exact_after_max_blocks
                or self.scene.goal.yaw_exact or len(best) <= self.bound.value):
            return None
        part = budget.capped(cfg.exact_after_s)
        try:
            found = self._pose_set_search(part, cfg.exact_after_max_blocks, len(best))
        except NoShorterPlan:
            metrics["exact_after_proved"] = 1.0
            return None
        except ExactLimit:
            return None
        finally:
            metrics["exact_after_s"] = part.elapsed()
        actions = necessary_actions(self.scene, self.params, found.actions)
        if len(actions) >= len(best) or not self.valid(actions):
            return None
        metrics["exact_after_saved"] = float(len(best) - len(actions))
        return actions

    def _pose_set_search(self, part: Budget, max_blocks: int, upper: float = INF
                         ) -> ExactResult:
        """``exact_plan`` for this scene within ``part`` (raises as it does)."""
        goals = self.scene.goal_assignment()
        ids = sorted(goals)
        return exact_plan(self.ctx, self.start, [goals[b] for b in ids],
                          {b: k for k, b in enumerate(ids)}, max_expansions=10**9,
                          max_blocks=max_blocks, seconds=max(part.remaining(), 0.0),
                          stop=part.stopped, upper=upper)

    def restart(self, k: int, jitter: float, budget: Budget) -> list[Action] | None:
        """Restart ``k``: pruned actions, or None if it found no plan."""
        rng = np.random.default_rng([self.config.seed, k])
        try:
            actions = self.solve(rng, jitter, budget, {})
        except PlanningFailure:
            return None
        return necessary_actions(self.scene, self.params, actions)

    def valid(self, actions: list[Action]) -> bool:
        return validate_plan(Plan(actions=tuple(actions), planner=PLANNER_NAME,
                                  params=self.params, seed=self.config.seed,
                                  scene=self.scene)).ok


def _kept(space: CellPirs, assembly: Assembly, bound: LowerBound, start) -> frozenset[int]:
    """Blocks on their goal that the search first tries to leave there: those the bound's
    best relaxed plan keeps, else as many as leave every other slot enterable."""
    done = frozenset(b for b in space.goals if space.at_goal(b, start))
    if bound.exact:
        return done & bound.keep
    kept = assembly.keepable(assembly.mask(done))
    return frozenset(b for b in done if kept & assembly.bit[b])
