"""A certified lower bound that also knows where the blocks start (labeled goals).

``bound.Relaxation`` reasons about filled goal slots only: a block arriving early is assumed
to find its slot's surroundings free of every block that has not arrived yet. In a cramped
workspace the blocks that have not moved yet still stand where they started, often right
beside the grid, under the fingers of the grasps (and behind the pushes) that would fill an
edge slot. This relaxation keeps, besides the slots filled (``A``), the blocks that have
already moved at least once (``M``, A within M), and counts every action of a plan:

* **leave** y (y not in M, cost 1): the first move of a block that moves again later (a
  clear, or the first half of a push arrival). It needs one way out of y's start (one of
  the two grasps, or a push along one of its four face normals by the shortest length)
  whose fingers (or swept area) cover no filled slot and no start of a block not in M.
* **arrive** c (cost 1; a block on its goal at the start that the plan moves: 2, away and
  back, as in ``bound``): one way in (a grasp at c, or the end of any push into c: the
  shortest push's swept area, which every push into c along that normal covers) whose
  fingers cover no filled slot and no start of a block not in M; no block not in M may
  start on slot c itself; a push needs c's block in M (it was put on the push line before)
  unless it starts on a push line into c; a block arriving by its first move needs a way
  out of its start as for **leave**.

Why every plan maps onto a path of this search no longer than itself: take each block's
last arrival on its goal (after which it stays) as its **arrive**, and, for a block moved
more than once, its first action as its **leave** (another action; the plan's further
moves are not counted). At the moment of any of these actions, the blocks whose last arrival
came before stand on their slots (``A``), and a block whose first move comes later still
stands on its start (not in ``M``), so the fingers, the swept area and the slot must avoid
both. Each condition above is one the plan's action meets, so the path exists and costs at
most the plan's length. Blocks the goal does not name are left out (a relaxation: they could
only take room away). The fewest actions over these paths (A* on (A, M), whose heuristic,
the arrivals still to come, never overestimates) is therefore a lower bound on any plan with
these actions, for the planner's footprints (``transfer``), as ``bound`` is.
"""

from __future__ import annotations

import heapq
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from msgs_py import Pose2D
from msgs_py.footprint import block_corners, face_normals
from nodes.planner.bounds.assembly import TAIL
from nodes.planner.geometry.obstacles import Obstacles, mask_to_int, words
from nodes.planner.geometry.transfer import grasp_checks, push_checks

#: Search states expanded at most; beyond, no bound from this relaxation (``None``).
MAX_EXPANSIONS = 200_000
#: Push length (m) for the ways out of a start: the shortest push, as ``first_movers``.
LEAVE_PUSH = 1e-6

Way = tuple[int, int]  # (filled slots it may not cover, starts it may not cover)


@dataclass(frozen=True)
class StartWays:
    """Per position k of the goal ids (slot k, block k): ways into slot k (``grasp_in``,
    ``push_in``), ways out of block k's start (``out``), and the starts on slot k
    (``on_slot``); masks are over positions. Only blocks to move have starts (bits)."""

    grasp_in: list[list[Way]]
    push_in: list[list[Way]]
    out: list[list[Way]]
    on_slot: list[int]


def start_ways(ctx, start: Mapping[int, Pose2D], goals: Mapping[int, Pose2D], ids: list[int],
               todo: int) -> StartWays:
    """The ways in and out, tested once against every slot and every start to move."""
    n = len(ids)
    movers = [k for k in range(n) if todo >> k & 1]
    slots = np.array([[goals[b].x, goals[b].y, goals[b].theta] for b in ids])
    starts = np.array([[start[ids[k]].x, start[ids[k]].y, start[ids[k]].theta]
                       for k in movers]).reshape(-1, 3)
    both = np.concatenate([slots, starts])
    s = ctx.geom.block_size
    obstacles = Obstacles(list(range(len(both))), block_corners(
        both[:, 0], both[:, 1], both[:, 2], s), [True] * len(both),
        {k: k for k in range(len(both))}, words(len(both)))

    def split(mask: np.ndarray, own: int) -> Way:
        """An obstacle mask as (slot mask, start mask), block ``own``'s slot and start out."""
        value = mask_to_int(mask)
        slot_mask = value & ((1 << n) - 1) & ~(1 << own)
        start_mask = sum(1 << k for i, k in enumerate(movers) if value >> (n + i) & 1)
        return slot_mask, start_mask & ~(1 << own)

    grasps = grasp_checks(ctx, obstacles, slots)
    grasp_in = [[split(grasps.fingers_hit[c, g], c) for g in range(2)
                 if grasps.fingers_ok[c, g]] for c in range(n)]
    on_slot = [split(grasps.block_hit[c], c)[1] for c in range(n)]
    d = face_normals(slots[:, 2]).reshape(-1, 2)  # (4n, 2), slot c's at 4c..4c+3
    tail_starts = np.column_stack([np.repeat(slots[:, :2], 4, axis=0) - d * TAIL,
                                   np.repeat(slots[:, 2], 4)])
    ok, hit = push_checks(ctx, obstacles, tail_starts, d, np.full(len(d), TAIL))
    push_in = [[split(hit[k], c) for k in range(4 * c, 4 * c + 4) if ok[k]] for c in range(n)]
    out: list[list[Way]] = [[] for _ in range(n)]
    if movers:
        g_out = grasp_checks(ctx, obstacles, starts)
        d_out = face_normals(starts[:, 2]).reshape(-1, 2)
        p_ok, p_hit = push_checks(ctx, obstacles, np.repeat(starts, 4, axis=0), d_out,
                                  np.full(len(d_out), LEAVE_PUSH))
        for i, k in enumerate(movers):
            out[k] = [split(g_out.fingers_hit[i, g], k) for g in range(2)
                      if g_out.fingers_ok[i, g]]
            out[k] += [split(p_hit[4 * i + j], k) for j in range(4) if p_ok[4 * i + j]]
    return StartWays(grasp_in, push_in, out, on_slot)


class StartSearch:
    """A* over (filled slots A, blocks moved M) as the module docstring describes."""

    def __init__(self, ways: StartWays, todo: int, exempt: list[bool], moved_cost: int = 2
                 ) -> None:
        self.w = ways
        self.n = len(exempt)
        self.todo = todo
        self.exempt = exempt
        self.moved_cost = moved_cost

    @staticmethod
    def _free(ways: list[Way], filled: int, moved: int) -> bool:
        return any(s & filled == 0 and m & ~moved == 0 for s, m in ways)

    def can_leave(self, k: int, filled: int, moved: int) -> bool:
        return self._free(self.w.out[k], filled, moved)

    def can_arrive(self, c: int, filled: int, moved: int) -> bool:
        if self.w.on_slot[c] & ~moved:
            return False
        if self.todo >> c & 1 and not moved >> c & 1 and not self.can_leave(c, filled, moved):
            return False
        if self._free(self.w.grasp_in[c], filled, moved):
            return True
        pushed_ok = (not self.todo >> c & 1) or moved >> c & 1 or self.exempt[c]
        return pushed_ok and self._free(self.w.push_in[c], filled, moved)

    def _h(self, filled: int) -> int:
        """Arrivals still to come, at their least cost: never more than what is left."""
        left = ~filled & ((1 << self.n) - 1)
        return (left & self.todo).bit_count() + self.moved_cost * (left & ~self.todo).bit_count()

    def solve(self, starts: list[int]) -> int | None:
        """Fewest actions from any filled set in ``starts`` (the slots kept at the start) to
        every slot filled, or None (no path, or more than ``MAX_EXPANSIONS`` states)."""
        full = (1 << self.n) - 1
        heap = [(self._h(a), 0, a, 0) for a in starts]
        heapq.heapify(heap)
        best: dict[tuple[int, int], int] = {(a, 0): 0 for a in starts}
        expansions = 0
        while heap:
            _, g, filled, moved = heapq.heappop(heap)
            if best.get((filled, moved), g) < g:
                continue
            if filled == full:
                return g
            expansions += 1
            if expansions > MAX_EXPANSIONS:
                return None
            for nxt, cost in self._successors(filled, moved):
                key, g2 = nxt, g + cost
                if best.get(key, g2 + 1) <= g2:
                    continue
                best[key] = g2
                heapq.heappush(heap, (g2 + self._h(nxt[0]), g2, *nxt))
        return None

    def _successors(self, filled: int, moved: int):
        for k in range(self.n):
            bit = 1 << k
            if filled & bit:
                continue
            if self.todo & bit:
                if not moved & bit and self.can_leave(k, filled, moved):
                    yield (filled, moved | bit), 1
                if self.can_arrive(k, filled, moved):
                    yield (filled | bit, moved | bit), 1
            elif self.can_arrive(k, filled, moved):
                yield (filled | bit, moved), self.moved_cost
