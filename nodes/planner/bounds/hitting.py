"""The blocks that must take an extra action, counted together: a bound for any number of
slots, where the exact relaxation (``bound.Relaxation``, 2^n subsets) stops.

Two reasons force a block to move more than once, and a block that moves twice pays for both:

* **Cycles.** Of the blocks to move standing on each other's slots in a cycle, the one whose
  slot fills first had to leave its own start before, and arrive later (TORO's n + minimum
  feedback vertex set for pick-only plans).
* **Enclosures.** A set of slots none of which any grasp can set a block down on while the
  others are filled (a 2 x 2 square of a grid with 3 mm gaps) is entered last by a push,
  whenever one of its slots is to fill: the others are filled then. The pushed block had to
  be set down on the push line first, an extra action, unless it starts on one (``exempt``).
  A push arrives along one direction, and it is the last arrival only of the enclosures its
  fingertips' lane misses (``Assembly.push_tail``): in a grid the 2 squares of its slot away
  from the lane, not all 4. That is why a 7 x 7 grid needs 18 pushes, not 9.

The fewest blocks meeting every cycle and closing every enclosure is a small integer program
(HiGHS through SciPy): ``x_c`` block c moves twice (cost 1, or ``moved_cost`` for a block on
its goal, which then moves away and back); ``y_(c,d)`` slot c's last arrival is a push along
d, at most one per slot and only with ``x_c`` (exempt blocks push for free). The cycles are
added as the solution leaves them unbroken; any optimum with fewer of them is still a lower
bound, so a search cut short (``MAX_ROUNDS``, ``TOTAL_S``) stays certified.
"""

from __future__ import annotations

import itertools
import math
import operator
import time
from collections.abc import Sequence
from dataclasses import dataclass
from functools import reduce

import networkx as nx
import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

from nodes.planner.bounds.assembly import Assembly

#: Largest enclosure searched (a grid's are 2 x 2 squares).
ENCLOSURE_MAX = 4
#: Rounds of adding the cycles a solution leaves unbroken, and the time (s) all of them may
#: take (the planner computes the bound once per plan; 100 blocks at 0.4 take up to 0.9 s).
MAX_ROUNDS = 30
TOTAL_S = 2.0
#: The least time a round is given (HiGHS returns its dual bound when it runs out).
MIN_ROUND_S = 0.05


@dataclass(frozen=True)
class Enclosure:
    """Slots (bit mask) none of which can be set down on while the others are filled, and
    the pushes (slot, ``push_tail`` index) that could be the last arrival into them."""

    mask: int
    arrivals: tuple[tuple[int, int], ...]


def enclosures(asm: Assembly) -> list[Enclosure]:
    """Every enclosure of up to ``ENCLOSURE_MAX`` slots reachable from its first slot through
    the slots the fingers of its members' grasps cover (two steps: a square's diagonal)."""
    n = len(asm.ids)
    touches = [_bits(reduce(operator.or_, asm.set_down[c], 0)) for c in range(n)]
    found: dict[int, Enclosure] = {}
    for c in range(n):
        near = set(touches[c]).union(*(touches[u] for u in touches[c]))
        near = sorted(u for u in near if u > c)
        for size in range(ENCLOSURE_MAX):
            for rest in itertools.combinations(near, size):
                mask = 1 << c | sum(1 << u for u in rest)
                if mask not in found and _encloses(asm, mask):
                    found[mask] = Enclosure(mask, _last_arrivals(asm, mask))
    return _minimal(found)


def _bits(mask: int) -> list[int]:
    return [k for k in range(mask.bit_length()) if mask >> k & 1]


def _encloses(asm: Assembly, mask: int) -> bool:
    """No slot of ``mask`` can be set down on with the others filled."""
    return all(all(m & mask & ~(1 << c) for m in asm.set_down[c]) for c in _bits(mask))


def _last_arrivals(asm: Assembly, mask: int) -> tuple[tuple[int, int], ...]:
    return tuple((c, d) for c in _bits(mask)
                 for d, tail in enumerate(asm.push_tail[c]) if not tail & mask & ~(1 << c))


def _minimal(found: dict[int, Enclosure]) -> list[Enclosure]:
    """The enclosures no smaller one is inside: a larger one's constraint adds nothing then
    only if its arrivals are the smaller one's, so keep those that differ."""
    masks = sorted(found, key=int.bit_count)
    out = []
    for k, m in enumerate(masks):
        inner = [s for s in masks[:k] if s & m == s]
        if not any(set(found[m].arrivals) >= set(found[s].arrivals) for s in inner):
            out.append(found[m])
    return out


def forced_extra(groups: Sequence[Enclosure], todo: int, exempt: Sequence[bool],
                 clears: Sequence[int], moved_cost: float) -> int:
    """Least extra actions of any plan by the reasons above (``todo``: slots to fill, bits;
    ``exempt[c]``: slot c's block may arrive by one push; ``clears[c]``: the slots block c
    stands on)."""
    n = len(clears)
    graph = _stands_on(clears, todo)
    groups = [g for g in groups if g.mask & todo
              and not any(exempt[c] and todo >> c & 1 for c, _ in g.arrivals)]
    if any(not g.arrivals for g in groups):  # a layout no plan fills: left to the other terms
        return 0
    if not groups and graph.number_of_edges() == 0:
        return 0
    return _Program(n, todo, groups, moved_cost).solve(graph)


def _stands_on(clears: Sequence[int], todo: int) -> nx.DiGraph:
    """Edges c -> v: block c (to move) stands on slot v (to fill)."""
    g = nx.DiGraph()
    for c, mask in enumerate(clears):
        if todo >> c & 1:
            g.add_edges_from((c, v) for v in _bits(mask & todo) if v != c)
    return g


class _Program:
    """The integer program over ``x`` (n) then ``y`` (one per distinct last arrival)."""

    def __init__(self, n: int, todo: int, groups: Sequence[Enclosure], moved_cost: float):
        self.n = n
        pairs = sorted({p for g in groups for p in g.arrivals})
        col = {p: n + k for k, p in enumerate(pairs)}
        self.width = n + len(pairs)
        self.cost = np.zeros(self.width)
        self.cost[:n] = [1.0 if todo >> c & 1 else moved_cost for c in range(n)]
        self.rows: list[np.ndarray] = []
        self.low: list[float] = []
        self.high: list[float] = []
        for c in range(n):  # sum_d y_(c,d) - x_c <= 0
            row = np.zeros(self.width)
            row[[col[p] for p in pairs if p[0] == c]] = 1.0
            if row.any():
                row[c] = -1.0
                self._add(row, -np.inf, 0.0)
        for g in groups:  # some push closes the enclosure
            row = np.zeros(self.width)
            row[[col[p] for p in g.arrivals]] = 1.0
            self._add(row, 1.0, np.inf)

    def _add(self, row: np.ndarray, low: float, high: float) -> None:
        self.rows.append(row)
        self.low.append(low)
        self.high.append(high)

    def _cycle(self, cycle: Sequence[int]) -> None:
        row = np.zeros(self.width)
        row[list(cycle)] = 1.0
        self._add(row, 1.0, np.inf)

    def solve(self, graph: nx.DiGraph) -> int:
        """The optimum, adding per round one cycle of each strongly connected part the
        solution leaves (starting from the 2-cycles)."""
        for u, v in graph.edges:
            if u < v and graph.has_edge(v, u):
                self._cycle((u, v))
        best = 0
        deadline = time.monotonic() + TOTAL_S
        for _ in range(MAX_ROUNDS):
            left = deadline - time.monotonic()
            if left <= 0.0:
                return best
            value, chosen = self._optimum(max(left, MIN_ROUND_S))
            best = max(best, value)
            if chosen is None:
                return best
            rest = graph.subgraph(set(graph) - chosen)
            cycles = [nx.find_cycle(rest.subgraph(part)) for part in
                      nx.strongly_connected_components(rest) if len(part) > 1]
            if not cycles:
                return best
            for edges in cycles:
                self._cycle([u for u, _ in edges])
        return best

    def _optimum(self, seconds: float) -> tuple[int, set[int] | None]:
        """(the optimum rounded up, the blocks it moves twice), or (its certified dual
        bound, None) when the solver stops short."""
        rows = [LinearConstraint(np.array(self.rows), self.low, self.high)] if self.rows else []
        res = milp(self.cost, integrality=np.ones(self.width), bounds=Bounds(0.0, 1.0),
                   constraints=rows, options={"time_limit": seconds})
        if res.status == 0 and res.x is not None:
            value = math.ceil(res.fun - 1e-6)
            return value, {c for c in range(self.n) if res.x[c] > 0.5}
        dual = getattr(res, "mip_dual_bound", None)
        return (math.ceil(dual - 1e-6) if dual is not None and math.isfinite(dual) else 0), None
