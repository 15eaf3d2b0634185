"""An assembly order for the goal layout: which block to place next so that none gets walled
in and as few as possible need a push.

A goal slot is *enterable* given a set of filled slots when its block can be set down on it
with some grasp (*pick-and-place-able*), or pushed into it along a face normal from a pose
where it can be set down, without fingers or swept block touching a filled slot. All the
footprint tests are done once, in bulk, against the other slots; afterwards a slot set is a
Python int bit mask and every test is integer arithmetic.

``feasible(filled)``: removing blocks only frees space, so peeling off enterable slots round
after round is a complete test (for this relaxation) of whether the empty slots can still all
be filled. ``order()``: greedily fill next a pick-and-place-able slot whose filling keeps the
rest feasible, else a push-only one, sweeping the layout from -y to +y so that lanes stay open
(a 3x3 grid needs 2 pushes this way, 4 ring by ring).
"""

from __future__ import annotations

import operator
from functools import cached_property, reduce

import numpy as np

from msgs_py import Pose2D
from msgs_py.footprint import block_corners, face_normals
from nodes.planner.geometry.obstacles import Obstacles, mask_to_int, words
from nodes.planner.geometry.transfer import MIN_PUSH, grasp_checks, push_checks

#: Push lengths (in block sizes) tried when testing whether a slot can be pushed into (those
#: up to the roadmap's push_max_distance).
PUSH_STEPS = (0.1, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0)
#: The shortest push (m) whose fingertips every push into a slot sweeps at its end.
TAIL = 10 * MIN_PUSH


def _ints(masks: np.ndarray) -> list[int]:
    """Per row of masks (K, W), the bit mask of slots as a Python int."""
    return [mask_to_int(row) for row in masks]


class Assembly:
    """Goal-layout reasoning over the slots ``slots`` (block id -> goal pose).

    Per slot: ``set_down`` the masks of the other slots the fingers of each usable grasp
    cover; ``push_in`` (sweep mask, grasp masks at the push start) for pushes into it from
    the lengths in ``PUSH_STEPS``; ``push_tail`` per usable direction the mask of the slots
    the fingertips of *every* push into it along that direction sweep (those of the
    shortest push), so a slot with none of those free cannot be entered at all.
    """

    def __init__(self, ctx, slots: dict[int, Pose2D]) -> None:
        self.ids = sorted(slots)
        self.bit = {b: 1 << k for k, b in enumerate(self.ids)}
        self.all = (1 << len(self.ids)) - 1
        n = len(self.ids)
        self.set_down: list[list[int]] = [[] for _ in range(n)]
        self.push_in: list[list[tuple[int, list[int]]]] = [[] for _ in range(n)]
        self.push_tail: list[list[int]] = [[] for _ in range(n)]
        self._y = {b: (round(slots[b].y, 4), round(slots[b].x, 4), b) for b in self.ids}
        self.index = {b: k for k, b in enumerate(self.ids)}
        self._enter: list[list[int]] = [[] for _ in range(n)]
        # Memos of feasible() and future_pushes() by filled mask, held by this instance: a
        # functools.cache on the methods would be one table per class, keyed by self, that
        # keeps every Assembly of every planning run alive for the life of the planner node.
        self._feasible_memo: dict[int, bool] = {}
        self._future_pushes_memo: dict[int, int] = {}
        if not n:
            return
        poses = np.array([[slots[b].x, slots[b].y, slots[b].theta] for b in self.ids])
        self._obstacles = Obstacles(list(range(n)), block_corners(
            poses[:, 0], poses[:, 1], poses[:, 2], ctx.geom.block_size), [True] * n,
            {k: k for k in range(n)}, words(n))
        grasps = grasp_checks(ctx, self._obstacles, poses)
        for c in range(n):
            own = ~(1 << c)
            self.set_down[c] = [mask_to_int(grasps.fingers_hit[c, g]) & own for g in range(2)
                                if grasps.fingers_ok[c, g]]
        self._add_pushes(ctx, poses)
        for c in range(n):
            ways = self.set_down[c] + [sweep | g for sweep, grasps in self.push_in[c]
                                       for g in grasps]
            self._enter[c] = _minimal(ways)

    def _add_pushes(self, ctx, poses: np.ndarray) -> None:
        n, s = len(poses), ctx.geom.block_size
        steps = np.array(PUSH_STEPS) * s
        steps = np.concatenate([[TAIL], steps[steps <= ctx.config.push_max_distance + 1e-9]])
        d = np.repeat(face_normals(poses[:, 2]), len(steps), axis=1).reshape(-1, 2)  # (n*P, 2)
        length = np.tile(np.tile(steps, 4), n)
        slot = np.repeat(np.arange(n), 4 * len(steps))
        q = np.column_stack([poses[slot, :2] - d * length[:, None], poses[slot, 2]])
        ok, sweep = push_checks(ctx, self._obstacles, q, d, length)
        grasps = grasp_checks(ctx, self._obstacles, q)
        sweep_masks, tail = _ints(sweep), length == TAIL
        for k in np.flatnonzero(ok):
            c = int(slot[k])
            own = ~(1 << c)
            if tail[k]:
                self.push_tail[c].append(sweep_masks[k] & own)
                continue
            at_q = [mask_to_int(grasps.fingers_hit[k, g]) & own for g in range(2)
                    if grasps.fingers_ok[k, g]]
            if at_q:
                self.push_in[c].append((sweep_masks[k] & own, at_q))

    # --- tests on bit masks of filled slots -------------------------------------------------
    def placeable(self, block: int, filled: int) -> bool:
        """Pick-and-place straight onto the slot with the slots ``filled``."""
        return any(m & filled == 0 for m in self.set_down[self.index[block]])

    def enterable(self, c: int, filled: int) -> bool:
        """Slot c can be set down on or pushed into with the slots ``filled``."""
        return any(m & filled == 0 for m in self._enter[c])

    @cached_property
    def slot_tables(self) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
        """Per slot c and every filled set S (bit mask): whether c is pick-and-place-able
        (some ``set_down`` mask misses S) and whether the shortest push's fingertips find a
        free lane (some ``push_tail`` mask misses S), as (n, 2^n) arrays; and the filled sets
        by how many slots they hold. Built once, in bulk, so that the relaxation's shortest
        path over subsets (``bound.completion_costs``) is a few array operations per level."""
        n = len(self.ids)
        subsets = np.arange(1 << n, dtype=np.int64)

        def table(masks: list[int]) -> np.ndarray:
            free = np.zeros(len(subsets), dtype=bool)
            for m in masks:
                free |= (subsets & m) == 0
            return free
        place = np.array([table(m) for m in self.set_down]).reshape(n, -1)
        tail = np.array([table(m) for m in self.push_tail]).reshape(n, -1)
        counts = np.bitwise_count(subsets)
        return place, tail, [subsets[counts == k] for k in range(n + 1)]

    @cached_property
    def level_tables(self) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """``slot_tables`` by level, from n-1 filled slots down to none, as the relaxation's
        shortest path walks them (``bound.completion_costs``): the filled sets S (L,); S with
        each slot c added (n, L); the cost of c arriving there (0 where it may: not filled,
        and placeable or its push lane free, else inf); whether c takes no pick-and-place."""
        n = len(self.ids)
        place, tail, levels = self.slot_tables
        bits = (1 << np.arange(n, dtype=np.int64))[:, None]
        out = []
        for k in range(n - 1, -1, -1):
            filled = levels[k]
            placeable, lane = place[:, filled], tail[:, filled]
            ok = ((filled[None, :] & bits) == 0) & (placeable | lane)
            out.append((filled, filled[None, :] | bits, np.where(ok, 0.0, np.inf), ~placeable))
        return out

    def mask(self, blocks) -> int:
        out = 0
        for b in blocks:
            out |= self.bit[b]
        return out

    def feasible(self, filled: int) -> bool:
        """The empty slots of ``filled`` can all still be filled (memoised)."""
        filled &= self.all
        known = self._feasible_memo.get(filled)
        if known is None:
            known = self._feasible_memo[filled] = not self.stuck(filled)
        return known

    @cached_property
    def _dependents(self) -> list[int]:
        """Per slot c, the mask of the slots whose ways in pass over c: peeling c can make
        only those enterable."""
        n = len(self.ids)
        dep = [0] * n
        for d, ways in enumerate(self._enter):
            over = reduce(operator.or_, ways, 0)
            for c in range(n):
                if over >> c & 1:
                    dep[c] |= 1 << d
        return dep

    def stuck(self, filled: int) -> list[int]:
        """Empty slots (block ids) that no peeling order of the empty ones can fill.

        Peeling (filling in reverse) only frees room, so its closure does not depend on the
        order: a worklist tests each empty slot once, and again only when a slot its ways in
        pass over has been peeled (the planner's order asks this thousands of times per
        plan; testing every slot each round was 40 % of a 49-block plan's time)."""
        empty = self.all & ~filled
        occupied = self.all
        todo = empty
        enter, dependents = self._enter, self._dependents  # (inlined ``enterable``: hot)
        while todo:
            c = (todo & -todo).bit_length() - 1
            todo &= todo - 1
            if not empty >> c & 1:
                continue
            others = occupied & ~(1 << c)
            for way in enter[c]:
                if not way & others:
                    empty &= ~(1 << c)
                    occupied = others
                    todo |= dependents[c] & empty
                    break
        return [self.ids[c] for c in range(len(self.ids)) if empty >> c & 1]

    def keepable(self, kept: int) -> int:
        """The slots of ``kept`` (filled at the start) that can stay filled while every
        other slot is filled around them: while some slot is walled in, one of its kept
        neighbours whose leaving opens it goes (preferring one that can come back once it is
        filled, then the lowest slot)."""
        kept &= self.all
        while True:
            stuck = [self.index[b] for b in self.stuck(kept)]
            if not stuck:
                return kept
            c = stuck[0]
            openers = [k for k in range(len(self.ids))
                       if kept >> k & 1 and self.enterable(c, kept & ~(1 << k))]
            if not openers:
                return 0
            back = [k for k in openers if self.enterable(k, self.all & ~(1 << k))]
            kept &= ~(1 << (back or openers)[0])

    def order(self, filled: int = 0) -> list[int]:
        """A greedy assembly order (block ids) of the slots not in ``filled``: a
        pick-and-place-able slot that keeps the rest feasible first, else a push-only one."""
        out = []
        for _ in range(len(self.ids) - (filled & self.all).bit_count()):
            pick = self._next(filled)
            out.append(pick)
            filled |= self.bit[pick]
        return out

    def _next(self, filled: int) -> int:
        """The greedy order's next block from ``filled`` (not full)."""
        rest = [b for b in self.ids if not filled & self.bit[b]]
        rest.sort(key=lambda b: (not self.placeable(b, filled), self._y[b]))
        return next((b for b in rest if self.feasible(filled | self.bit[b])), rest[0])

    def future_pushes(self, filled: int) -> int:
        """Push-only placements the greedy order still needs from ``filled`` (a lookahead)."""
        filled &= self.all
        known = self._future_pushes_memo.get(filled)
        if known is None:
            known = self._future_pushes_memo[filled] = self._count_future_pushes(filled)
        return known

    def _count_future_pushes(self, filled: int) -> int:
        if filled == self.all:
            return 0
        if not self.feasible(filled):
            return len(self.ids)
        nxt = self._next(filled)
        push = 0 if self.placeable(nxt, filled) else 1
        return push + self.future_pushes(filled | self.bit[nxt])


def _minimal(masks: list[int]) -> list[int]:
    """``masks`` without duplicates and without any that contains another (a way blocked
    by the slots of a smaller one is never the only one open)."""
    unique = sorted(set(masks), key=lambda m: (m.bit_count(), m))
    out: list[int] = []
    for m in unique:
        if not any(k & ~m == 0 for k in out):
            out.append(m)
    return out
