"""pIRS and CLEAR (Algorithms 1-2 of the paper) over the single-block roadmap.

``Search.run`` tries each block first, as the paper's top level does, and returns the
concatenated actions and final state, or raises ``PlanningFailure`` naming the block and the
reason of the failure that got furthest (most blocks placed). Differences from the pseudocode,
all deliberate:

* Algorithm 1 line 7 recurses on ``O_R \\ o_r`` (the paper's typo ``o_b``, DESIGN §6).
* A block already on its goal succeeds with an empty action list (the paper's test
  ``pi != {}`` would reject it).
* Blocks the goal does not name stay movable obstacles for the whole search.
* CLEAR tries up to ``clear_attempts`` clearing poses before giving up, and after clearing
  its own way retries the *same* pose (the path to it was just cleared) rather than a new one.
* Options (PlannerConfig): clearing poses outside the blocked path and off the goals of
  blocks not yet placed, clearing straight to the block's own goal first, and trying blocks
  in an assembly order of the goal layout (``assembly``) before falling back to the others.

The search is deterministic for a seed: one numpy Generator drawn in a fixed order, every
iteration over sorted ids. It stops with a failure when ``deadline`` passes or a block's
clearing recursion exceeds ``max_depth``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field

import numpy as np

from msgs_py import Pose2D
from msgs_py.actions import Action
from msgs_py.footprint import block_corners, grasp_finger_corners
from nodes.planner.assembly import Assembly
from nodes.planner.context import PlanContext, State, at_pose, nearest_goal_yaw
from nodes.planner.geometry import Obstacles, mask_to_int
from nodes.planner.roadmap import NoRoute, Route, plan_route, uniform_draw

#: Candidate clearing poses drawn per batch, and batches per relaxation level.
CLEAR_BATCH = 48
CLEAR_ROUNDS = 4


class PlanningFailure(Exception):
    """No plan: ``block`` is the block the search could not get further with."""

    def __init__(self, block: int | None, reason: str) -> None:
        super().__init__(f"block {block}: {reason}" if block is not None else reason)
        self.block = block
        self.reason = reason


class _Timeout(Exception):
    pass


@dataclass
class PirsStats:
    roadmaps: int = 0
    clears: int = 0
    backtracks: int = 0
    placed_max: int = 0
    failure: tuple[int, int | None, str] = (-1, None, "")  # (progress, block, reason)

    def as_metrics(self) -> dict[str, float]:
        return {"roadmaps": float(self.roadmaps), "clears": float(self.clears),
                "backtracks": float(self.backtracks), "placed_max": float(self.placed_max)}


@dataclass
class _Result:
    actions: list[Action]
    state: dict[int, Pose2D]


@dataclass
class Search:
    ctx: PlanContext
    start: dict[int, Pose2D]
    goals: dict[int, Pose2D]
    yaw_exact: bool
    rng: np.random.Generator
    deadline: float
    stats: PirsStats = field(default_factory=PirsStats)
    should_stop: Callable[[], bool] = lambda: False  # external cancel request (node shutdown)

    def __post_init__(self) -> None:
        self.free = frozenset(self.start) - frozenset(self.goals)
        cfg = self.ctx.config
        self.assembly = Assembly(self.ctx, self.goals)
        walled = self.assembly.stuck(0)
        if walled:
            raise PlanningFailure(walled[0], f"the goal layout walls in the slots of blocks "
                                  f"{walled}: in no order can they be set down or pushed in")
        order = self.assembly.order() if cfg.assembly_order else sorted(self.goals)
        self.rank = {b: k for k, b in enumerate(order)}

    # --- top level --------------------------------------------------------------------------
    def run(self) -> tuple[list[Action], dict[int, Pose2D]]:
        """First with the blocks already on their goal kept there (a replan late in a run:
        the missing few go in around them), within half the budget; then, non-monotone,
        with every block movable (the paper's search)."""
        done = frozenset(b for b in self.goals if self.at_goal(b, self.start))
        targets = frozenset(self.goals)
        if done and done != targets and self.assembly.feasible(self.assembly.mask(done)):
            deadline = self.deadline
            self.deadline = time.monotonic() + 0.5 * (deadline - time.monotonic())
            try:
                result = self._search(targets - done, done)
            except _Timeout:
                result = None
            self.deadline = deadline
            if result is not None:
                return result
        try:
            result = self._search(targets, frozenset())
        except _Timeout:
            _, block, reason = self.stats.failure
            raise PlanningFailure(
                block, f"time budget of {self.ctx.config.budget_s:g} s exhausted after placing "
                f"at most {self.stats.placed_max} of {len(self.goals)} blocks"
                + (f"; last failure: {reason}" if reason else "")) from None
        if result is not None:
            return result
        _, block, reason = self.stats.failure
        raise PlanningFailure(block, reason or "no plan found")

    def _search(self, targets: frozenset[int], placed: frozenset[int]
                ) -> tuple[list[Action], dict[int, Pose2D]] | None:
        for o in self.ordered(targets, self.start, placed):
            result = self.pirs(o, targets - {o}, self.start, placed, 0)
            if result is not None:
                return result.actions, result.state
        return None

    def ordered(self, blocks: Iterable[int], state: State, placed: frozenset[int]
                ) -> Iterator[int]:
        """Blocks to place next, by estimated actions: now (0 on its goal already, 1 for a
        pick-and-place, 2 for pick-and-place + push) minus one for a block standing on another
        pending slot (placing it now saves clearing it), plus the pushes the rest of the layout
        then needs; ties in assembly order. A block whose placing would wall in another goal
        slot (``Assembly.feasible``) is not tried at all. With ``assembly_order`` off: by id,
        every block (the paper)."""
        if not self.ctx.config.assembly_order:
            yield from sorted(blocks, key=lambda b: (not self.at_goal(b, state), b))
            return
        filled = self.assembly.mask(placed)

        in_way = self.in_the_way(blocks, state, placed)

        def estimate(b: int) -> tuple[int, int]:
            now = 0 if self.at_goal(b, state) else (1 if self.assembly.placeable(b, filled)
                                                    else 2)
            # a block standing on another pending slot must move anyway: placing it now
            # saves the action that would clear it
            saved = 1 if b in in_way else 0
            return (now - saved + self.assembly.future_pushes(filled | self.assembly.bit[b]),
                    self.rank[b])
        blocks = sorted(blocks, key=estimate)
        for b in blocks:
            if self.assembly.feasible(filled | self.assembly.bit[b]):
                yield b

    def wedged(self, o: int, end: Pose2D, state: State, placed: frozenset[int],
               movable: frozenset[int]) -> list[int]:
        """Movable blocks whose last free grasp ``o`` standing at ``end`` would take away
        (every grasp's fingers would land on a block): two such blocks can hem each other in
        for good once their other neighbours are placed, so they are cleared first."""
        cand = sorted(movable)
        if not cand:
            return []
        geom = self.ctx.geom
        after = {**state, o: end}
        mine = self.ctx.obstacles({o: end}, exclude=(), movable=())
        out = []
        for b in cand:
            p = state[b]
            fingers = grasp_finger_corners(geom, p.x, p.y, p.theta, np.arange(2))
            others = self.ctx.obstacles(after, exclude=(b,), movable=())
            hit = others.query(fingers)[0] | ~self.ctx.table.contains(fingers).all(-1)
            if hit.all() and mine.query(fingers)[0].any():
                out.append(b)
        return out

    def in_the_way(self, blocks: Iterable[int], state: State, placed: frozenset[int]
                   ) -> set[int]:
        """Blocks of ``blocks`` (not on their goal) overlapping another pending goal slot."""
        pending = [b for b in sorted(self.goals) if b not in placed]
        cand = [b for b in sorted(blocks) if not self.at_goal(b, state)]
        if not cand or len(pending) < 2:
            return set()
        geom = self.ctx.geom
        slots = [self.goals[b] for b in pending]
        corners = block_corners([p.x for p in slots], [p.y for p in slots],
                                [p.theta for p in slots], geom.block_size)
        bits = {b: k for k, b in enumerate(pending)}
        tree = Obstacles(pending, corners, [True] * len(pending), bits)
        poses = [state[b] for b in cand]
        foot = block_corners([p.x for p in poses], [p.y for p in poses],
                             [p.theta for p in poses], geom.block_size)
        _, mask = tree.query(foot[:, None])
        return {b for b, m in zip(cand, mask, strict=True) if mask_to_int(m) & ~(1 << bits[b])}

    # --- helpers ----------------------------------------------------------------------------
    def check_time(self) -> None:
        if time.monotonic() > self.deadline or self.should_stop():
            raise _Timeout

    def fail(self, block: int, placed: frozenset[int], reason: str) -> None:
        if len(placed) > self.stats.failure[0]:
            self.stats.failure = (len(placed), block, reason)

    def route(self, block: int, state: State, target: Pose2D, movable: frozenset[int]
              ) -> Route | NoRoute:
        self.check_time()
        self.stats.roadmaps += 1
        exact = self.yaw_exact and block in self.goals and target == self.goals[block]
        return plan_route(self.ctx, block, state, target, movable, self.rng, exact)

    def goal_for(self, block: int, state: State) -> Pose2D:
        return nearest_goal_yaw(self.goals[block], state[block].theta, self.yaw_exact)

    def at_goal(self, block: int, state: State) -> bool:
        cfg = self.ctx.config
        return at_pose(state[block], self.goals[block], cfg.goal_tolerance_xy,
                       cfg.goal_tolerance_yaw, self.yaw_exact)

    # --- Algorithm 1 ------------------------------------------------------------------------
    def probed(self, remaining: frozenset[int], state: dict[int, Pose2D],
               placed: frozenset[int]) -> Iterator[tuple[int, Route | NoRoute | None]]:
        """``ordered`` candidates, but among the first ``probe`` of them one whose roadmap
        route is already free of movable blocks goes first (it needs no clearing); the
        routes found are handed on so they are not planned twice."""
        order = list(self.ordered(remaining, state, placed))
        k = min(self.ctx.config.probe, len(order))
        known: dict[int, Route | NoRoute] = {}
        for b in order[:k]:
            if self.at_goal(b, state):
                break
            route = self.route(b, state, self.goal_for(b, state), remaining - {b} | self.free)
            known[b] = route
            if isinstance(route, Route) and not route.blocked:
                order.remove(b)
                order.insert(0, b)
                break
        for b in order:
            yield b, known.pop(b, None)

    def pirs(self, o: int, remaining: frozenset[int], state: dict[int, Pose2D],
             placed: frozenset[int], depth: int, known: Route | NoRoute | None = None
             ) -> _Result | None:
        """Place ``o`` on its goal, then the ``remaining`` goal blocks; None on failure."""
        self.check_time()
        if depth > self.ctx.config.max_depth:
            self.fail(o, placed, f"clearing its way needed more than max_depth="
                      f"{self.ctx.config.max_depth} nested clears")
            return None
        movable = remaining | self.free
        if self.at_goal(o, state):
            route: Route | NoRoute = Route((), (), 0.0, state[o])
        elif known is not None:
            route = known
        else:
            route = self.route(o, state, self.goal_for(o, state), movable)
        if isinstance(route, NoRoute):
            self.fail(o, placed, f"no way to its goal: {route.reason}")
            return None
        if not route.blocked:
            wedged = self.wedged(o, route.end, state, placed, movable)
            if wedged:  # clear it while it can still be grasped
                route = Route(route.actions, (wedged[0],), route.cost, route.end, route.region)
        if not route.blocked:
            state2 = {**state, o: route.end}
            placed2 = placed | {o}
            self.stats.placed_max = max(self.stats.placed_max, len(placed2))
            if not remaining:
                return _Result(list(route.actions), state2)
            for o_r, known in self.probed(remaining, state2, placed2):
                sub = self.pirs(o_r, remaining - {o_r}, state2, placed2, 0, known)
                if sub is not None:
                    return _Result([*route.actions, *sub.actions], sub.state)
                self.stats.backtracks += 1
            return None
        o_b = route.blocked[0]
        cleared = self.clear(o_b, movable - {o_b}, state, placed, route.region, depth + 1)
        if cleared is None:
            self.fail(o, placed, f"block {o_b} stands in its way and could not be cleared")
            return None
        sub = self.pirs(o, remaining, cleared.state, placed, depth + 1)
        if sub is None:
            return None
        return _Result([*cleared.actions, *sub.actions], sub.state)

    # --- Algorithm 2 ------------------------------------------------------------------------
    def clear(self, o: int, movable: frozenset[int], state: dict[int, Pose2D],
              placed: frozenset[int], region: np.ndarray, depth: int,
              target: Pose2D | None = None) -> _Result | None:
        """Move ``o`` out of the way (of ``region``), clearing its own way recursively."""
        self.check_time()
        cfg = self.ctx.config
        if depth > cfg.max_depth:
            self.fail(o, placed, f"clearing it needed more than max_depth={cfg.max_depth} "
                      "nested clears")
            return None
        self.stats.clears += 1
        tries: list[tuple[Pose2D, bool]] = []
        if target is not None:
            tries = [(target, True)]
        else:
            goal = self.clear_goal(o, state, placed, region)
            if goal is not None:
                tries.append((goal, False))
            tries += [(p, True) for p in self.clear_poses(o, state, placed, region,
                                                          cfg.clear_attempts)]
        if not tries:
            self.fail(o, placed, "no free pose to clear it to")
        for pose, recurse in tries:
            route = self.route(o, state, pose, movable)
            if isinstance(route, NoRoute):
                self.fail(o, placed, f"cannot be cleared: {route.reason}")
                continue
            if not route.blocked:
                return _Result(list(route.actions), {**state, o: route.end})
            if not recurse:
                continue
            o_b = route.blocked[0]
            sub = self.clear(o_b, movable - {o_b}, state, placed,
                             np.concatenate([region, route.region]), depth + 1)
            if sub is None:
                continue
            again = self.clear(o, movable, sub.state, placed, region, depth + 1, target=pose)
            if again is not None:
                return _Result([*sub.actions, *again.actions], again.state)
        return None

    def clear_goal(self, o: int, state: State, placed: frozenset[int], region: np.ndarray
                   ) -> Pose2D | None:
        """``o``'s own goal as a clearing pose, when that option is on and it is out of the way."""
        if not self.ctx.config.clear_goal_first or o not in self.goals:
            return None
        if self.ctx.config.assembly_order:
            # only where fixing it next costs no extra pushes, else it is just in the way later
            asm = self.assembly
            filled = asm.mask(placed)
            with_o = filled | asm.bit[o]
            if not asm.feasible(with_o) or asm.future_pushes(with_o) > asm.future_pushes(filled):
                return None
        goal = self.goal_for(o, state)
        geom = self.ctx.geom
        foot = block_corners(goal.x, goal.y, goal.theta, geom.block_size)[None, None]
        others = self.ctx.obstacles(state, exclude=(o,), movable=())
        if others.query(foot)[0][0]:
            return None
        forbid = self.forbidden(o, placed, region, with_goals=False)
        if forbid is not None and forbid.query(foot)[0][0]:
            return None
        return goal

    def forbidden(self, o: int, placed: frozenset[int], region: np.ndarray, with_goals: bool,
                  margin: float = 0.0) -> Obstacles | None:
        """Where a clearing pose must not go: the blocked path, and pending goal slots grown
        by ``margin`` (room for the fingers and push lanes around them)."""
        cfg, geom = self.ctx.config, self.ctx.geom
        parts = []
        if cfg.clear_outside_path and len(region):
            parts.append(region)
        if with_goals and cfg.clear_off_goals:
            slots = [self.goals[b] for b in sorted(self.goals) if b not in placed and b != o]
            if slots:
                parts.append(block_corners([p.x for p in slots], [p.y for p in slots],
                                           [p.theta for p in slots],
                                           geom.block_size + 2.0 * margin))
        if not parts:
            return None
        corners = np.concatenate(parts).reshape(-1, 4, 2)
        return Obstacles(np.zeros(len(corners), dtype=np.int64), corners,
                         [False] * len(corners), {})

    def clear_poses(self, o: int, state: State, placed: frozenset[int], region: np.ndarray,
                    count: int) -> list[Pose2D]:
        """Up to ``count`` poses for ``o`` clear of every block, where some grasp can set it
        down; outside the blocked path / off pending goals when those options are on (each
        dropped in turn if nothing fits)."""
        ctx, cfg = self.ctx, self.ctx.config
        others = ctx.obstacles(state, exclude=(o,), movable=())
        levels = [self.forbidden(o, placed, region, True, cfg.clear_goal_margin),
                  self.forbidden(o, placed, region, True),
                  self.forbidden(o, placed, region, False), None]
        draw = uniform_draw(ctx)
        here = state[o]
        # grasps that can pick o where it stands without touching anything: a clearing pose
        # that one of them can set down is reached in one action (no regrasp)
        fingers_here = grasp_finger_corners(ctx.geom, here.x, here.y, here.theta, np.arange(2))
        hit_here = others.query(fingers_here)[0]
        usable = ~hit_here & ctx.table.contains(fingers_here).all(-1)
        if not usable.any():
            usable[:] = True
        for forbid in levels:
            found: list[np.ndarray] = []
            for _ in range(CLEAR_ROUNDS):
                cand = draw(self.rng, CLEAR_BATCH)
                foot = block_corners(cand[:, 0], cand[:, 1], cand[:, 2], ctx.geom.block_size)
                ok = ctx.workspace.contains(foot) & ~others.query(foot[:, None])[0]
                if forbid is not None:
                    ok &= ~forbid.query(foot[:, None])[0]
                fingers = grasp_finger_corners(ctx.geom, cand[:, 0, None], cand[:, 1, None],
                                               cand[:, 2, None], np.arange(2))
                f_hit = others.query(fingers.reshape(-1, 2, 4, 2))[0].reshape(-1, 2)
                ok &= (~f_hit & ctx.table.contains(fingers).all(-1) & usable).any(-1)
                found.append(cand[ok])
                if sum(len(f) for f in found) >= count and not cfg.distance_cost:
                    break
            good = np.concatenate(found)
            if len(good):
                if cfg.distance_cost:
                    d = np.hypot(good[:, 0] - here.x, good[:, 1] - here.y)
                    good = good[np.argsort(d, kind="stable")]
                return [Pose2D(*row) for row in good[:count]]
        return []
