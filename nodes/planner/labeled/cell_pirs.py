"""The work cell as pIRS's space: roadmap routes, the goal layout's order, clearing poses.

``CellPirs`` answers ``pirs.PirsSpace`` for one labeled scene:

* ``route``: the single-block PRM (``roadmap.plan_route``); regions are footprint corners.
* ``order``: blocks by estimated actions: now (0 on its goal already, 1 for a pick-and-place,
  2 for pick-and-place + push) minus one for a block standing on another pending slot
  (placing it now saves clearing it), plus what the rest of the layout then costs: the
  certified bound's least relaxed completion where it was solved (up to 12 slots), else the
  pushes the greedy assembly order still needs (up to 64 slots); ties in that order, or, with
  ``jitter`` > 0 (the anytime improvement's restarts), each estimate raised by a random
  amount below ``jitter`` so that near ties go either way. A block
  whose placing would wall in another goal slot (``Assembly.feasible``) is left out. With
  ``assembly_order`` off: by id, every block (the paper). Candidates are yielded lazily.
* ``clearing_poses``: the block's own goal when it is out of the way and filling it next
  costs nothing extra; a pose on a push line into its own goal, out of the way, from which
  the push in is free of placed blocks (the clear is then the first half of its arrival);
  then sampled poses clear of every block where some grasp can set it down, outside the
  blocked path and off pending goals when those options are on (each dropped in turn if
  nothing fits).
* ``wedged``: movable blocks whose last free grasp a placement would take away.
* ``walls_in``: whether a placement leaves a goal slot unfillable (``Assembly.feasible``),
  counting blocks that stand on their goal unplaced as filling it, where before it did not.
* ``shuts_in``, ``freeing_nudges``: ``freeing``.
"""

from __future__ import annotations

import itertools
from collections.abc import Collection, Iterable, Iterator

import numpy as np

from msgs_py import Pose2D
from msgs_py.footprint import block_corners, face_normals, grasp_finger_corners
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import INF, Relaxation
from nodes.planner.geometry.context import PlanContext, State, at_pose, nearest_goal_yaw
from nodes.planner.geometry.obstacles import Obstacles, mask_to_int
from nodes.planner.geometry.transfer import grasp_checks, push_checks
from nodes.planner.labeled.freeing import freeing_nudges, shut_in
from nodes.planner.labeled.pirs import NoRoute, Route
from nodes.planner.labeled.roadmap import plan_route, uniform_draw
from nodes.planner.labeled.snug import snug_poses

#: Candidate clearing poses drawn per batch, and batches per relaxation level.
CLEAR_BATCH = 48
CLEAR_ROUNDS = 4
#: Distances (block sizes) from its goal at which a block is cleared onto its push line.
PUSH_START_STEPS = (1.1, 1.5, 2.0)
#: Largest layout for which the greedy order's future pushes are looked ahead (their cost
#: grows with the cube of the slot count).
LOOKAHEAD_MAX = 64


class CellPirs:
    """The geometry of one labeled scene for pIRS (see the module docstring)."""

    def __init__(self, ctx: PlanContext, goals: dict[int, Pose2D], yaw_exact: bool,
                 rng: np.random.Generator, assembly: Assembly | None = None,
                 relaxation: Relaxation | None = None, jitter: float = 0.0) -> None:
        self.ctx = ctx
        self.jitter = jitter
        self.goals = goals
        self.yaw_exact = yaw_exact
        self.rng = rng
        self.assembly = assembly or Assembly(ctx, goals)
        self.relax = relaxation
        cfg = ctx.config
        if relaxation is not None and cfg.assembly_order:
            ids = self.assembly.ids
            kept = sum(1 << k for k in range(len(ids)) if not relaxation.todo >> k & 1)
            order = [ids[k] for k in relaxation.best_order(kept)]
            order += [b for b in ids if b not in order]
        else:
            order = self.assembly.order() if cfg.assembly_order else sorted(goals)
        self.rank = {b: k for k, b in enumerate(order)}

    # --- goals and routes -------------------------------------------------------------------
    def at_goal(self, block: int, state: State) -> bool:
        cfg = self.ctx.config
        return at_pose(state[block], self.goals[block], cfg.goal_tolerance_xy,
                       cfg.goal_tolerance_yaw, self.yaw_exact)

    def goal_pose(self, block: int, state: State) -> Pose2D:
        return nearest_goal_yaw(self.goals[block], state[block].theta, self.yaw_exact)

    def route(self, block: int, state: State, target: Pose2D, movable: frozenset[int]
              ) -> Route | NoRoute:
        exact = self.yaw_exact and block in self.goals and target == self.goals[block]
        return plan_route(self.ctx, block, state, target, movable, self.rng, exact)

    def join(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.concatenate([a, b])

    # --- which block next -------------------------------------------------------------------
    def order(self, blocks: Collection[int], state: State, placed: frozenset[int]
              ) -> Iterator[int]:
        if not self.ctx.config.assembly_order:
            yield from sorted(blocks, key=lambda b: (not self.at_goal(b, state), b))
            return
        asm = self.assembly
        filled = asm.mask(placed)
        in_way = self.in_the_way(blocks, state, placed)

        def estimate(b: int) -> tuple[float, int]:
            now = 0 if self.at_goal(b, state) else (1 if asm.placeable(b, filled) else 2)
            saved = 1 if b in in_way else 0
            noise = self.rng.uniform(0.0, self.jitter) if self.jitter > 0.0 else 0.0
            return now - saved + self.ahead(filled | asm.bit[b]) + noise, self.rank[b]
        keys = {b: estimate(b) for b in sorted(blocks)}
        for b in sorted(keys, key=keys.__getitem__):  # feasibility tested as asked for
            if keys[b][0] < INF and asm.feasible(filled | asm.bit[b]):
                yield b

    def ahead(self, filled: int) -> float:
        """What the layout still costs once the slots ``filled`` are: the relaxation's least
        completion (``bound``) where it was solved, else the pushes the greedy assembly
        order still needs (up to ``LOOKAHEAD_MAX`` slots; beyond, the order's rank alone)."""
        if self.relax is not None:
            return self.relax.to_go[filled]
        if len(self.assembly.ids) <= LOOKAHEAD_MAX:
            return self.assembly.future_pushes(filled)
        return 0.0

    def in_the_way(self, blocks: Iterable[int], state: State, placed: frozenset[int]
                   ) -> set[int]:
        """Blocks of ``blocks`` (not on their goal) overlapping another pending goal slot."""
        pending = [b for b in sorted(self.goals) if b not in placed]
        cand = [b for b in sorted(blocks) if not self.at_goal(b, state)]
        if not cand or len(pending) < 2:
            return set()
        bits = {b: k for k, b in enumerate(pending)}
        tree = Obstacles(pending, _footprints(self.ctx, [self.goals[b] for b in pending]),
                         [True] * len(pending), bits)
        _, mask = tree.query(_footprints(self.ctx, [state[b] for b in cand])[:, None])
        return {b for b, m in zip(cand, mask, strict=True) if mask_to_int(m) & ~(1 << bits[b])}

    def wedged(self, block: int, end: Pose2D, state: State, movable: frozenset[int]
               ) -> list[int]:
        """Movable blocks whose last free grasp ``block`` standing at ``end`` would take away
        (every grasp's fingers would land on a block): two such blocks can hem each other in
        for good once their other neighbours are placed, so they are cleared first."""
        cand = sorted(movable)
        if not cand:
            return []
        ctx = self.ctx
        after = ctx.obstacles({**state, block: end}, exclude=(), movable=(block,))
        poses = np.array([[state[b].x, state[b].y, state[b].theta] for b in cand])
        grasps = grasp_checks(ctx, after, poses)
        on_block = grasps.fingers_hit.any(-1)  # the only movable block is ``block``
        free = (grasps.fingers_ok & ~on_block).any(-1)
        return [b for b, f, hit in zip(cand, free, on_block.any(-1), strict=True)
                if not f and hit]

    def standing(self, state: State, placed: Collection[int]) -> int:
        """The slots filled where ``state`` stands: the placed blocks' and those of blocks on
        their goal though not placed (cleared there), as an assembly bit mask."""
        on_goal = (b for b in self.goals if b not in placed and self.at_goal(b, state))
        return self.assembly.mask(itertools.chain(placed, on_goal))

    def walls_in(self, before: State, after: State, placed: frozenset[int]) -> bool:
        """Whether ``after`` leaves a slot no order can fill where ``before`` did not, with
        every block on its goal counted as filling it (a block cleared onto its own goal is
        not placed, but it stands there; once its neighbours are placed it may be neither
        graspable nor pushable, and the slots behind it then walled in for good)."""
        if not self.ctx.config.assembly_order:
            return False
        asm = self.assembly
        if asm.feasible(self.standing(after, placed)):
            return False
        return asm.feasible(self.standing(before, placed))

    def shuts_in(self, block: int, before: State, after: State, placed: frozenset[int]
                 ) -> list[int]:
        """Blocks still to move that ``block`` placed at its pose in ``after`` leaves with no
        grasp and no push free of the placed blocks (``freeing.shut_in``)."""
        off = [b for b in self.goals if b not in placed and not self.at_goal(b, after)]
        return shut_in(self.ctx, self.goals, block, before, after, placed, off)

    def freeing_nudges(self, block: int, state: State, held: frozenset[int],
                       movable: frozenset[int]) -> list[tuple[int, Route]]:
        """Short pushes of a held neighbour that free a grasp of ``block``
        (``freeing.freeing_nudges``)."""
        return freeing_nudges(self.ctx, block, state, held, movable)

    # --- where a blocking block goes ----------------------------------------------------------
    def clearing_poses(self, block: int, state: State, placed: frozenset[int],
                       region: np.ndarray) -> list[tuple[Pose2D, bool]]:
        tries: list[tuple[Pose2D, bool]] = []
        goal = self.clear_goal(block, state, placed, region)
        if goal is not None:
            tries.append((goal, False))
        tries += [(p, False) for p in self.push_starts(block, state, placed, region)]
        tries += [(p, True) for p in self.clear_poses(block, state, placed, region,
                                                      self.ctx.config.clear_attempts)]
        return tries

    def push_starts(self, o: int, state: State, placed: frozenset[int], region: np.ndarray
                    ) -> list[Pose2D]:
        """Poses on a push line into ``o``'s own goal, out of the way, from which the push
        in is free of the placed blocks: clearing ``o`` there makes the clear the first half
        of its arrival (a slot walled in by its neighbours is only entered by a push)."""
        if not self.ctx.config.clear_goal_first or o not in self.goals:
            return []
        ctx = self.ctx
        goal = self.goal_pose(o, state)
        d = np.repeat(face_normals(goal.theta), len(PUSH_START_STEPS), axis=0)
        length = np.tile(np.array(PUSH_START_STEPS) * ctx.geom.block_size, 4)
        q = np.column_stack([goal.x - d[:, 0] * length, goal.y - d[:, 1] * length,
                             np.full(len(d), goal.theta)])
        fixed = ctx.obstacles({b: state[b] for b in placed}, exclude=(o,), movable=())
        ok, _ = push_checks(ctx, fixed, q, d, length)
        poses = [Pose2D(*row) for row in q]
        free = self._free_for(o, poses, state, placed, region, with_goals=True)
        grasps = grasp_checks(ctx, ctx.obstacles(state, exclude=(o,), movable=()), q)
        ok &= free & grasps.block_ok & grasps.fingers_ok.any(-1)
        return [poses[k] for k in np.flatnonzero(ok)[:2]]

    def clear_goal(self, o: int, state: State, placed: frozenset[int], region: np.ndarray
                   ) -> Pose2D | None:
        """``o``'s own goal as a clearing pose, when that option is on and it is out of the way."""
        cfg = self.ctx.config
        if not cfg.clear_goal_first or o not in self.goals:
            return None
        if cfg.assembly_order:
            # only where fixing it next costs no extra pushes, else it is just in the way later
            asm = self.assembly
            filled = asm.mask(placed)
            with_o = filled | asm.bit[o]
            if not asm.feasible(with_o) or self.ahead(with_o) > self.ahead(filled):
                return None
        goal = self.goal_pose(o, state)
        if not self._free_for(o, [goal], state, placed, region, with_goals=False)[0]:
            return None
        if self.shuts_in(o, state, {**state, o: goal}, placed):
            return None  # it would stay there, and the block beside it could never leave
        return goal

    def _free_for(self, o: int, poses: list[Pose2D], state: State, placed: frozenset[int],
                  region: np.ndarray, with_goals: bool, margin: float = 0.0) -> np.ndarray:
        """Which ``poses`` of ``o`` overlap no other block and nothing ``forbidden``."""
        foot = _footprints(self.ctx, poses)[:, None]
        others = self.ctx.obstacles(state, exclude=(o,), movable=())
        ok = ~others.query(foot)[0]
        forbid = self.forbidden(o, placed, region, with_goals, margin)
        if forbid is not None:
            ok &= ~forbid.query(foot)[0]
        return ok

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
        usable = grasp_checks(ctx, others, np.array([[here.x, here.y, here.theta]])
                              ).fingers_ok[0]
        if not usable.any():
            usable[:] = True
        snug: list[np.ndarray] = []  # computed at the first level the draws leave empty
        spare = self.last_grasps(o, state, placed, others)
        for forbid, avoid in itertools.product(levels, (spare, None) if spare else (None,)):
            found: list[np.ndarray] = []
            for _ in range(CLEAR_ROUNDS):
                found.append(self._fit(draw(self.rng, CLEAR_BATCH), others, usable, forbid,
                                       avoid))
                if sum(len(f) for f in found) >= count and not cfg.distance_cost:
                    break
            good = np.concatenate(found)
            if not len(good):  # crowded: try the room beside the blocks and the edges
                if not snug:
                    yaws = (0.0, next(iter(self.goals.values())).theta) if self.goals else (0.0,)
                    snug.append(snug_poses(ctx, state, o, yaws))
                good = self._fit(snug[0], others, usable, forbid, avoid)
            if len(good):
                if cfg.distance_cost:
                    d = np.hypot(good[:, 0] - here.x, good[:, 1] - here.y)
                    good = good[np.argsort(d, kind="stable")]
                return [Pose2D(*row) for row in good[:count]]
        return []

    def last_grasps(self, o: int, state: State, placed: frozenset[int], others: Obstacles
                    ) -> Obstacles | None:
        """The fingers of the one free grasp of each block still to move that has only one
        (with ``o`` gone): a clearing pose on them would hem that block in (no grasp left),
        so clearing poses keep off them while others exist."""
        cand = [b for b in sorted(state) if b != o and b not in placed]
        if not cand:
            return None
        poses = np.array([[state[b].x, state[b].y, state[b].theta] for b in cand])
        ok = grasp_checks(self.ctx, others, poses).fingers_ok
        one = np.flatnonzero(ok.sum(-1) == 1)
        if not len(one):
            return None
        axis = np.argmax(ok[one], axis=-1)
        fingers = grasp_finger_corners(self.ctx.geom, poses[one, 0], poses[one, 1],
                                       poses[one, 2], axis).reshape(-1, 4, 2)
        return Obstacles(np.zeros(len(fingers), dtype=np.int64), fingers,
                         [False] * len(fingers), {})

    def _fit(self, cand: np.ndarray, others: Obstacles, usable: np.ndarray,
             forbid: Obstacles | None, avoid: Obstacles | None = None) -> np.ndarray:
        """The poses of ``cand`` where the block fits and one of the ``usable`` grasps can set
        it down, outside ``forbid`` and ``avoid``."""
        ctx = self.ctx
        foot = block_corners(cand[:, 0], cand[:, 1], cand[:, 2], ctx.geom.block_size)
        for keep_off in (forbid, avoid):  # first: most draws land there in a crowded scene
            if keep_off is not None and len(cand):
                outside = ~keep_off.query(foot[:, None])[0]
                cand, foot = cand[outside], foot[outside]
        if not len(cand):
            return cand
        grasps = grasp_checks(ctx, others, cand)
        return cand[grasps.block_ok & (grasps.fingers_ok & usable).any(-1)]


def _footprints(ctx: PlanContext, poses: list[Pose2D]) -> np.ndarray:
    return block_corners([p.x for p in poses], [p.y for p in poses], [p.theta for p in poses],
                         ctx.geom.block_size)

