"""A* over a pose set (``exact.PoseSet``): the fewest actions, or the fewest below a plan
already in hand.

A state is the pose index of every block (unlabeled: the sorted tuple); its heuristic is the
certified slot relaxation (``bound.Relaxation``) for the inputs the state gives it (which
slots are still to fill, which blocks stand on a push line into their slot, which slots each
block stands on). Most of a search's time went there: a 9-block state has about 120
successors, each of whose heuristic was worked out on its own (the inputs in Python, the
relaxation's dynamic programme over the 2^n filled sets per distinct input), most of them
never expanded. Now a state queues only the children whose cost bound equals its own and
goes back on the queue at the next bound among the rest (partial expansion); a child's
inputs are its parent's with one block's entry changed, which depends only on the class of
the pose it moves to, and the distinct inputs an expansion meets for the first time are
solved together, one array programme with a batch axis (``bound.best_starts``). Likewise
the moves (``PoseSet.moves``): the other blocks' conflicts are counted once per expansion,
not once per block.

``solve(upper=U)`` looks only for plans of fewer than ``U`` actions (a plan of ``U`` is in
hand): a child whose cost so far plus heuristic reaches ``U`` is dropped, and a queue that
runs dry proves that no plan over the pose set is shorter than ``U``.
"""

from __future__ import annotations

import heapq
import itertools
import time
from collections.abc import Callable

import numpy as np

from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import INF, Inputs, best_starts
from nodes.planner.geometry.transfer import FOOTPRINT_PERIOD, push_line

#: How often (expansions) the clock and the stop flag are read.
CHECK_EVERY = 32


class ExactLimit(Exception):
    """The search stopped (its expansions, its time, or its stop flag) without an answer, or
    the pose set holds no plan."""


class NoShorterPlan(ExactLimit):
    """No plan over the pose set has fewer actions than the ``upper`` bound given."""


class PoseSearch:
    """A* over states (tuples of pose indices, one per block; see the module)."""

    def __init__(self, poses, start: tuple[int, ...], slots: list[int], labeled: bool,
                 assembly: Assembly) -> None:
        self.ps = poses
        self.start = start
        self.slots = slots  # pose index of each slot (labeled: block k's goal)
        self.labeled = labeled
        self.moved_cost = 2.0 if labeled else 1.0
        p, n = len(poses.poses), len(slots)
        slot_arr = poses.arr[slots]
        self.on_line = np.zeros((p, n), dtype=bool)  # pose on a push line into slot k
        for k in range(n):
            target = np.repeat(slot_arr[k:k + 1], p, axis=0)
            self.on_line[:, k] = push_line(poses.arr, target, FOOTPRINT_PERIOD)[0]
        covers = poses.conflict[:, slots]  # (P, n): pose overlaps slot k
        self.cover_bits = [sum(1 << int(c) for c in np.flatnonzero(row)) for row in covers]
        self.on_any = covers.any(-1).astype(int)  # pose overlaps some slot
        # per slot k's block, per pose: on its slot (bit 0), on a push line into it (bit 1),
        # the other slots it overlaps (bits 2..): all a child's inputs need of its pose
        index = np.arange(p)
        cover = np.array(self.cover_bits, dtype=np.int64)
        self.codes = np.array([(index == slots[k]).astype(np.int64) | self.on_line[:, k] << 1
                               | (cover & ~(1 << k)) << 2 for k in range(n)]).reshape(n, p)
        self.code_span = (1 << (n + 2)) + 1  # codes lie below code_span - 1: a block's
        # without a goal (only whether it stands on a slot counts)
        self._relaxed: dict[Inputs, float] = {}
        self.asm = assembly

    # --- the heuristic ----------------------------------------------------------------
    def inputs(self, state: tuple[int, ...]) -> tuple[Inputs, int]:
        """The relaxation's inputs for ``state``, and the blocks without a goal that stand on
        a slot (each must leave it: one action each, on top)."""
        n = len(self.slots)
        if self.labeled:
            todo = sum(1 << k for k in range(n) if state[k] != self.slots[k])
            exempt = tuple(bool(self.on_line[state[k], k]) for k in range(n))
            clears = tuple(self.cover_bits[state[k]] & ~(1 << k) for k in range(n))
            return (todo, exempt, clears), int(self.on_any[list(state[n:])].sum())
        filled = set(state)
        todo = sum(1 << k for k in range(n) if self.slots[k] not in filled)
        off = [u for u in state if u not in self.slots]
        exempt = tuple(bool(self.on_line[off, k].any()) for k in range(n))
        return (todo, exempt, (0,) * n), 0

    def value(self, inputs: Inputs, extra: int) -> float:
        """The heuristic for a state with these inputs (solved already: ``solve_all``)."""
        if not inputs[0]:
            return float(extra)
        return self._relaxed[inputs] + extra

    def solve_all(self, inputs: list[Inputs]) -> None:
        """Solve the relaxation for each of ``inputs`` not solved yet, in one batch."""
        new = list(dict.fromkeys(x for x in inputs if x[0] and x not in self._relaxed))
        if new:
            values = best_starts(self.asm, new, self.moved_cost)
            self._relaxed.update(zip(new, values.tolist(), strict=True))

    # --- the search --------------------------------------------------------------------
    def key(self, state: tuple[int, ...]) -> tuple[int, ...]:
        return state if self.labeled else tuple(sorted(state))

    def done(self, state: tuple[int, ...]) -> bool:
        if self.labeled:
            return all(state[k] == self.slots[k] for k in range(len(self.slots)))
        return set(self.slots) <= set(state)

    def successors(self, state: tuple[int, ...]):
        """(block index, pose, kind, next state) for every one-action move."""
        blocks, poses, pushed = self.ps.moves(state)
        for i, v, push in zip(blocks.tolist(), poses.tolist(), pushed.tolist(), strict=True):
            yield i, v, "push" if push else "pick_place", (*state[:i], v, *state[i + 1:])

    def solve(self, max_expansions: int, seconds: float | None = None,
              stop: Callable[[], bool] | None = None, upper: float = INF
              ) -> tuple[list[tuple[int, int, str]], int]:
        """The fewest moves (block index, pose, kind) to the goal, if fewer than ``upper``;
        and the states expanded.

        Raises:
            NoShorterPlan: none has fewer than ``upper`` (finite) actions over the pose set.
            ExactLimit: ``max_expansions``, ``seconds`` or ``stop()`` came first, or no plan.
        """
        deadline = None if seconds is None else time.monotonic() + seconds
        root_inputs, root_extra = self.inputs(self.start)
        self.solve_all([root_inputs])
        h0 = self.value(root_inputs, root_extra)
        if h0 == INF:
            raise ExactLimit("the goal layout cannot be filled from this pose set")
        if h0 >= upper:
            raise NoShorterPlan(f"the relaxation already needs {h0:g} actions")
        front = _Frontier(upper)
        front.add(self.start, self.key(self.start), 0, h0, (root_inputs, root_extra), None)
        expansions = 0
        while front.heap:
            f, neg_g, _, state, below = heapq.heappop(front.heap)
            g = -neg_g
            if front.best.get(self.key(state), INF) < g:
                continue
            if self.done(state):
                return self._path(front.parent, state), expansions
            expansions += below == -INF
            if expansions > max_expansions:
                raise ExactLimit(f"no optimum proven within {max_expansions} expansions")
            if expansions % CHECK_EVERY == 0 and (
                    (deadline is not None and time.monotonic() > deadline)
                    or (stop is not None and stop())):
                raise ExactLimit(f"no optimum proven within {seconds:g} s"
                                 if seconds is not None else "stopped")
            later = (self._expand(state, g, f, below, front) if self.labeled
                     else self._expand_each(state, g, front))
            if later < upper:  # the children left for later, when the queue reaches them
                heapq.heappush(front.heap, (later, neg_g, next(front.tie), state, f))
        if upper < INF:
            raise NoShorterPlan(f"no plan of fewer than {upper:g} actions over this pose set")
        raise ExactLimit("no plan over this pose set")

    def _expand(self, state, g: int, f: float, below: float, front: _Frontier) -> float:
        """Queue ``state``'s children whose cost bound lies in (``below``, ``f``] and that are
        new or reached sooner; return the least bound above ``f`` among the rest (partial
        expansion: the children a search never reaches are never built). A child's inputs
        are the parent's with its block's entry replaced, which depends only on the pose's
        class (``codes``), so the children share the few inputs their classes give (solved
        as one batch for the state)."""
        inputs, extra = front.known[state]
        n = len(self.slots)
        blocks, poses, pushed = self.ps.moves(state)
        if not len(blocks):
            return INF
        goal_block = blocks < n
        no_goal = self.code_span - 1
        codes = np.where(goal_block, self.codes[np.minimum(blocks, n - 1), poses], no_goal)
        classes, which = np.unique(blocks * self.code_span + codes, return_inverse=True)
        child = [inputs if c % self.code_span == no_goal
                 else self._replaced(inputs, c // self.code_span, c % self.code_span)
                 for c in classes.tolist()]
        self.solve_all(child)
        extras = np.full(len(blocks), extra)
        if not goal_block.all():  # blocks without a goal: their slot count changes
            here = np.array(state)
            extras += np.where(goal_block, 0, self.on_any[poses] - self.on_any[here[blocks]])
        bound = g + 1 + np.array([self.value(x, 0) for x in child])[which] + extras
        above = bound[bound > f]
        for k in np.flatnonzero((bound > below) & (bound <= f)).tolist():
            i, v = int(blocks[k]), int(poses[k])
            front.add((*state[:i], v, *state[i + 1:]), None, g + 1, float(bound[k]),
                      (child[which[k]], int(extras[k])),
                      (state, i, v, "push" if pushed[k] else "pick_place"))
        return float(above.min()) if len(above) else INF

    def _expand_each(self, state, g: int, front: _Frontier) -> float:
        """Every child of ``state`` queued, one by one (unlabeled goals: a state's inputs
        are its set's); nothing left for later."""
        children = []
        for i, v, kind, nxt in self.successors(state):
            if front.best.get(self.key(nxt), INF) <= g + 1:
                continue
            children.append((i, v, kind, nxt, *self.inputs(nxt)))
        self.solve_all([c[4] for c in children])
        for i, v, kind, nxt, child_inputs, child_extra in children:
            h = self.value(child_inputs, child_extra)
            front.add(nxt, self.key(nxt), g + 1, g + 1 + h, (child_inputs, child_extra),
                      (state, i, v, kind))
        return INF

    def _replaced(self, inputs: Inputs, i: int, code: int) -> Inputs:
        """``inputs`` with slot i's block moved to a pose of class ``code``."""
        todo, exempt, clears = inputs
        bit = 1 << i
        todo = todo & ~bit if code & 1 else todo | bit
        return (todo, (*exempt[:i], bool(code >> 1 & 1), *exempt[i + 1:]),
                (*clears[:i], code >> 2, *clears[i + 1:]))

    def _path(self, parent, state) -> list[tuple[int, int, str]]:
        moves = []
        while state in parent:
            prev, i, v, kind = parent[state]
            moves.append((i, v, kind))
            state = prev
        return moves[::-1]


class _Frontier:
    """The A*'s queue (cost bound, -g, tie, state, the bound its children were queued up to)
    and what it knows per state: the fewest actions reaching it, its relaxation inputs and
    the move that reached it."""

    def __init__(self, upper: float) -> None:
        self.upper = upper
        self.heap: list[tuple[float, int, int, tuple[int, ...], float]] = []
        self.tie = itertools.count()
        self.best: dict[tuple[int, ...], int] = {}
        self.known: dict[tuple[int, ...], tuple[Inputs, int]] = {}
        self.parent: dict[tuple[int, ...], tuple[tuple[int, ...], int, int, str]] = {}

    def add(self, state: tuple[int, ...], key: tuple[int, ...] | None, g: int, bound: float,
            inputs: tuple[Inputs, int], move: tuple | None) -> None:
        """Queue ``state`` (``key``: its duplicate key, None: itself) reached in ``g``
        actions, unless it was reached as soon before or ``bound`` rules it out."""
        key = state if key is None else key
        if bound >= self.upper or bound == INF or self.best.get(key, INF) <= g:
            return
        self.best[key] = g
        self.known[state] = inputs
        if move is not None:
            self.parent[state] = move
        heapq.heappush(self.heap, (bound, -g, next(self.tie), state, -INF))
