"""A certified lower bound on the actions of any plan, and the order that attains it.

Every block not on its goal needs an action (``misplaced``). On top of that, think of the
moment each block arrives on its goal for the last time. The slots filled then are at least
those whose blocks arrived before (extra blocks only get in the way more), so:

* a block whose slot no grasp can reach past them arrives by a push, and unless it starts on
  a push line into its slot an earlier action must have put it on one: 2 actions (**push**);
* a block standing on the slot of a block that arrives before it must have left earlier:
  2 actions (**clear**);
* a slot that neither a grasp nor any push can reach past them (the fingertips of every push
  into a slot sweep at least those of the shortest one) cannot be filled then at all;
* a block already on its goal that the plan moves costs 2 (away and back), and until it is
  back its slot is free: that is how an enclosed slot opens (unlabeled: 1, the slot's new
  arrival; the leaving may be another slot's arrival);
* a block the goal does not name that stands on a slot must leave it: 1 each;
* a block to move that can be neither grasped nor pushed where it starts (every grasp's
  fingers and every push's fingertips land on other blocks, ``first_movers``) moves only
  after every block on one of those options' way has moved: if each option has a block on
  its goal in the way, one of them at least is moved off it and back (2: not all can be
  kept; **walls**).

Minimising the sum over every arrival order and every choice of blocks moved off their goal
is a shortest path over the subsets of slots (``Relaxation``): exact below ``DP_MAX`` slots.
Above, two cheaper certified bounds, the larger counts: the last two arrivals (when they
arrive every other slot is filled), and the fewest blocks that meet every cycle of "stands
on the slot of" and close every set of slots that wall each other in (``hitting``: each
such block moves twice). Unlabeled goals: any block may fill any
slot, so slots arrive (not blocks), a push is forced unless some block starts on a push line
into the slot, and no clears are forced.

The slot tests are ``Assembly``'s masks (``set_down``, ``push_tail``), built by ``transfer``
from the planner's own footprints; the bound is certified for that model.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from msgs_py import Pose2D
from msgs_py.footprint import block_corners, face_normals
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound_starts import StartSearch, start_ways
from nodes.planner.bounds.hitting import enclosures, forced_extra
from nodes.planner.geometry.context import at_pose
from nodes.planner.geometry.obstacles import Obstacles, mask_to_int, words
from nodes.planner.geometry.transfer import FOOTPRINT_PERIOD, grasp_checks, push_checks, push_line

#: Largest slot count for which the planner solves the exact relaxation (2^n subsets, about
#: 0.01 s at 12 slots) and the start-aware one (pairs of subsets).
DP_MAX = 12
STARTS_MAX = DP_MAX
#: The same for the benchmarks' reference bound (``reference_bound``): 16 slots take
#: seconds, too long for a planner that replans in the executor's loop.
REFERENCE_DP_MAX = 16
INF = math.inf


@dataclass(frozen=True)
class LowerBound:
    value: int
    misplaced: int  # blocks that must move at least once
    extra: int  # forced pushes, clears and moves of placed blocks on top
    exact: bool  # from the exact relaxation (else the cheaper bounds)
    keep: frozenset[int] = frozenset()  # blocks on their goal the relaxation's best plan keeps
    relaxation: Relaxation | None = field(default=None, compare=False)  # when exact


class Relaxation:
    """Arrival costs per slot (bit c) given the filled slots, and the shortest path over
    subsets. ``base[c]``: 1 for a slot to fill, 2 for a filled one whose block moves;
    ``exempt[c]``: its block may arrive by one push (it starts on a push line into it);
    ``clears[c]``: slots its block stands on (it must leave before they fill); ``walls``: per
    walled-in block, the filled slots in the way of each of its options (one option's must
    all be emptied, so a kept set may not meet every one of them; ``first_movers``)."""

    def __init__(self, assembly: Assembly, todo: int, exempt: list[bool],
                 clears: list[int], moved_cost: float,
                 walls: tuple[tuple[int, ...], ...] = ()) -> None:
        self.asm = assembly
        self.n = len(assembly.ids)
        self.todo = todo  # slots to fill; the others are filled at the start
        self.exempt = exempt
        self.clears = clears
        self.moved_cost = moved_cost  # a filled slot emptied and filled again
        self.walls = walls

    def keepable(self, kept: int) -> bool:
        """Whether the blocks of ``kept`` may all stay on their goal: every walled-in block
        keeps one option whose filled slots are all emptied."""
        return all(any(m & kept == 0 for m in wall) for wall in self.walls)

    def placeable(self, c: int, filled: int) -> bool:
        return any(m & filled == 0 for m in self.asm.set_down[c])

    def cost(self, c: int, filled: int) -> float:
        """Actions the block arriving on slot c while ``filled`` needs at least."""
        placeable = self.placeable(c, filled)
        if not placeable and not any(m & filled == 0 for m in self.asm.push_tail[c]):
            return INF
        if not self.todo >> c & 1:
            return self.moved_cost
        extra = (not placeable and not self.exempt[c]) or self.clears[c] & filled
        return 1.0 + bool(extra)

    @cached_property
    def to_go(self) -> list[float]:
        """Least cost from each filled set (bit mask) to the full layout: ``cost`` summed
        along the best completion (``completion_costs``; the exact search solves this once
        per distinct input)."""
        return completion_costs(self.asm, [(self.todo, self.exempt, self.clears)],
                                self.moved_cost)[0].tolist()

    def best_start(self) -> tuple[float, int]:
        """(cost, filled set) of the best start: any subset of the slots filled at the start
        may be kept."""
        kept_all = ((1 << self.n) - 1) & ~self.todo
        best = (INF, 0)
        sub = kept_all
        while True:
            if self.keepable(sub):
                best = min(best, (self.to_go[sub], -sub))
            if sub == 0:
                break
            sub = (sub - 1) & kept_all
        return best[0], -best[1]

    def best_order(self, filled: int) -> list[int]:
        """The slots in the order the relaxation's best completion from ``filled`` fills
        them."""
        out = []
        full = (1 << self.n) - 1
        while filled != full and self.to_go[filled] < INF:
            c = min((c for c in range(self.n) if not filled >> c & 1),
                    key=lambda c: (self.cost(c, filled) + self.to_go[filled | 1 << c], c))
            out.append(c)
            filled |= 1 << c
        return out

    def extra(self, c: int, filled: int) -> float:
        """``cost`` beyond the one action a slot to fill is counted anyway."""
        return self.cost(c, filled) - (self.todo >> c & 1)

    def tail(self) -> float:
        """Least extra cost of the last two arrivals (every other slot is filled by then):
        a bound for any size."""
        n, full = self.n, (1 << self.n) - 1
        best = INF
        for y in range(n):
            last = self.extra(y, full & ~(1 << y))
            if last == INF:
                continue
            if self.todo == 1 << y:  # the only slot to fill, maybe the only arrival
                best = min(best, last)
            for x in range(n):
                if x != y:
                    best = min(best, last + self.extra(x, full & ~(1 << x) & ~(1 << y)))
        return best


#: A relaxation's inputs: (slots to fill as a bit mask, per slot whether its block may arrive
#: by one push, per slot the slots its block stands on).
Inputs = tuple[int, Sequence[bool], Sequence[int]]


def completion_costs(asm: Assembly, inputs: Sequence[Inputs], moved_cost: float
                     ) -> np.ndarray:
    """Per input, the least cost from each filled set to the full layout (count, 2^n): the
    same values as ``Relaxation.cost`` summed along the best completion, solved level by level
    (sets of n-1 slots, then n-2, ...) in a few array operations over ``Assembly.level_tables``,
    for all the inputs at once."""
    n, count = len(asm.ids), len(inputs)
    todo = np.array([[t >> c & 1 for c in range(n)] for t, _, _ in inputs],
                    dtype=bool).reshape(count, n, 1)
    exempt = np.array([e for _, e, _ in inputs], dtype=bool).reshape(count, n, 1)
    clears = np.array([c for _, _, c in inputs], dtype=np.int64).reshape(count, n, 1)
    g = np.full((count, 1 << n), INF)
    g[:, -1] = 0.0
    for filled, nxt, forbid, unplaceable in asm.level_tables:
        extra = (unplaceable & ~exempt) | ((clears & filled) != 0)
        step = np.where(todo, 1.0 + extra, moved_cost)
        g[:, filled] = (step + forbid + g[:, nxt]).min(axis=1)
    return g


def best_starts(asm: Assembly, inputs: Sequence[Inputs], moved_cost: float) -> np.ndarray:
    """``Relaxation.best_start``'s cost for each of ``inputs`` (no walled-in blocks): the
    least completion cost over the filled sets it may keep, for all the inputs at once."""
    n = len(asm.ids)
    g = completion_costs(asm, inputs, moved_cost)
    kept_all = np.array([((1 << n) - 1) & ~t for t, _, _ in inputs], dtype=np.int64)
    may_keep = (np.arange(1 << n, dtype=np.int64)[None, :] & ~kept_all[:, None]) == 0
    return np.where(may_keep, g, INF).min(axis=1)


def _overlaps(ctx, poses: list[Pose2D], slots: list[Pose2D]) -> list[int]:
    """Per pose, the mask of the slots its footprint overlaps."""
    s = ctx.geom.block_size
    if not poses or not slots:
        return [0] * len(poses)
    arr = np.array([[p.x, p.y, p.theta] for p in slots])
    n = len(slots)
    obstacles = Obstacles(list(range(n)), block_corners(arr[:, 0], arr[:, 1], arr[:, 2], s),
                          [True] * n, {k: k for k in range(n)}, words(n))
    q = np.array([[p.x, p.y, p.theta] for p in poses])
    _, hit = obstacles.query(block_corners(q[:, 0], q[:, 1], q[:, 2], s)[:, None])
    return [mask_to_int(row) for row in hit]


def _on_push_line(starts: list[Pose2D], slot: Pose2D, period: float) -> np.ndarray:
    """Which starts lie on a push line into ``slot`` (same yaw modulo ``period``)."""
    if not starts:
        return np.zeros(0, dtype=bool)
    a = np.array([[p.x, p.y, p.theta] for p in starts])
    b = np.repeat([[slot.x, slot.y, slot.theta]], len(starts), axis=0)
    b[:, 2] = a[:, 2] + np.remainder(b[:, 2] - a[:, 2] + 0.5 * period, period) - 0.5 * period
    return push_line(a, b)[0]


def _solve(relax: Relaxation, misplaced: int, extra_fixed: int, ids: list[int],
           dp_max: int = DP_MAX) -> LowerBound:
    if relax.todo == 0:
        return LowerBound(extra_fixed, 0, extra_fixed, True, frozenset(ids))
    if relax.n <= dp_max:
        cost, kept = relax.best_start()
        if cost < INF:
            extra = round(cost) - misplaced + extra_fixed
            keep = frozenset(b for k, b in enumerate(ids) if kept >> k & 1)
            return LowerBound(misplaced + extra, misplaced, extra, True, keep, relax)
    tail = relax.tail()
    forced = forced_extra(enclosures(relax.asm), relax.todo, relax.exempt, relax.clears,
                          relax.moved_cost)
    walled = 2 if relax.walls else 0  # one placed block at least away and back
    extra = max(int(tail) if tail < INF else 0, forced, walled) + extra_fixed
    return LowerBound(misplaced + extra, misplaced, extra, False)


def labeled_bound(ctx, start: Mapping[int, Pose2D], goals: Mapping[int, Pose2D],
                  yaw_exact: bool, assembly: Assembly | None = None, dp_max: int = DP_MAX
                  ) -> LowerBound:
    """The bound for moving the blocks ``start`` to their ``goals`` (blocks without a goal
    are free); the slot relaxation solved exactly up to ``dp_max`` slots (the planner's
    ``DP_MAX``; the benchmarks' reference bound ``REFERENCE_DP_MAX``)."""
    cfg = ctx.config
    ids = sorted(goals)
    asm = assembly or Assembly(ctx, dict(goals))
    todo = sum(1 << k for k, b in enumerate(ids) if not at_pose(
        start[b], goals[b], cfg.goal_tolerance_xy, cfg.goal_tolerance_yaw, yaw_exact))
    period = 2.0 * math.pi if yaw_exact else FOOTPRINT_PERIOD
    exempt = [bool(_on_push_line([start[b]], goals[b], period)[0]) for b in ids]
    slots = [goals[b] for b in ids]
    clears = [m & ~(1 << k) for k, m in enumerate(_overlaps(ctx, [start[b] for b in ids],
                                                            slots))]
    free = [start[b] for b in sorted(set(start) - set(goals))]
    on_slots = sum(1 for m in _overlaps(ctx, free, slots) if m)
    walls = tuple(tuple(m & ~todo for m in options)
                  for k, options in enumerate(first_movers(ctx, start, ids))
                  if todo >> k & 1 and options and all(m & ~todo for m in options))
    relax = Relaxation(asm, todo, exempt, clears, 2.0, walls)
    bound = _solve(relax, todo.bit_count(), on_slots, ids, dp_max)
    return _with_starts(ctx, bound, relax, start, goals, ids, on_slots)


def _with_starts(ctx, bound: LowerBound, relax: Relaxation, start: Mapping[int, Pose2D],
                 goals: Mapping[int, Pose2D], ids: list[int], fixed: int) -> LowerBound:
    """``bound`` raised to the start-aware relaxation's value (``bound_starts``) where that
    is larger: both are lower bounds, so their maximum is one. Only up to ``STARTS_MAX`` slots
    (the search is over pairs of subsets); the order and kept set stay the slot
    relaxation's (the planner's order uses them)."""
    if relax.todo == 0 or relax.n > STARTS_MAX:
        return bound
    kept_all = ((1 << relax.n) - 1) & ~relax.todo
    starts = [sub for sub in _subsets(kept_all) if relax.keepable(sub)]
    ways = start_ways(ctx, start, goals, ids, relax.todo)
    value = StartSearch(ways, relax.todo, relax.exempt, round(relax.moved_cost)).solve(starts)
    if value is None or value + fixed <= bound.value:
        return bound
    return replace(bound, value=value + fixed, extra=value + fixed - bound.misplaced)


def _subsets(mask: int) -> list[int]:
    out, sub = [], mask
    while True:
        out.append(sub)
        if sub == 0:
            return out
        sub = (sub - 1) & mask


def first_movers(ctx, start: Mapping[int, Pose2D], ids: list[int]) -> list[list[int]]:
    """Per block of ``ids``, for each way of moving it from its start (two grasps, four
    pushes), the mask (bits: positions in ``ids``) of the blocks of ``ids`` on that way: all
    of one option's must move before the block can. The fingers' footprints do not depend on
    where the block goes, nor, for the shortest push, does its sweep. Options that the table
    edge or the arm's reach rule out whatever moves are left out; a block with an option
    free of ``ids`` gets an empty list (it is not walled in)."""
    everyone = sorted(start)
    where = {b: k for k, b in enumerate(ids)}
    bit_to_pos = {bit: where[b] for b, bit in ctx.bit_of.items() if b in where}
    out = []
    for b in ids:
        p = start[b]
        obstacles = ctx.obstacles(start, exclude=(b,), movable=everyone)
        pose = np.array([[p.x, p.y, p.theta]])
        grasps = grasp_checks(ctx, obstacles, pose)
        ok, push_hit = push_checks(ctx, obstacles, np.repeat(pose, 4, axis=0),
                                   face_normals(p.theta)[0], np.full(4, 1e-6))
        hits = [h for h, usable in zip(grasps.fingers_hit[0], grasps.fingers_ok[0],
                                       strict=True) if usable]
        hits += [h for h, usable in zip(push_hit, ok, strict=True) if usable]
        masks = [_positions(mask_to_int(h), bit_to_pos) for h in hits]
        out.append(masks if masks and all(masks) else [])
    return out


def _positions(mask: int, bit_to_pos: Mapping[int, int]) -> int:
    """An obstacle mask (bits: ``ctx.bit_of``) as a mask over positions in the goal ids."""
    return sum(1 << pos for bit, pos in bit_to_pos.items() if mask >> bit & 1)


def unlabeled_bound(ctx, blocks: list[Pose2D], slots: list[Pose2D], filled: list[bool],
                    assembly: Assembly | None = None, dp_max: int = DP_MAX) -> LowerBound:
    """The bound for filling ``slots`` (``filled``: a block stands on it) with ``blocks``."""
    n = len(slots)
    asm = assembly or Assembly(ctx, dict(enumerate(slots)))
    todo = sum(1 << k for k in range(n) if not filled[k])
    off_slot = [p for p in blocks if not any(
        math.hypot(p.x - q.x, p.y - q.y) <= ctx.config.goal_tolerance_xy for q in slots)]
    exempt = [bool(_on_push_line(off_slot, slots[k], FOOTPRINT_PERIOD).any()) for k in range(n)]
    must_move = sum(1 for m in _overlaps(ctx, off_slot, slots) if m)
    # a slot's block moved off it counts 1: its leaving may be another slot's arrival
    relax = Relaxation(asm, todo, exempt, [0] * n, moved_cost=1.0)
    excess = max(0, must_move - n)
    return _solve(relax, todo.bit_count(), excess, list(range(n)), dp_max)
