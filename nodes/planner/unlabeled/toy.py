"""Toy transfer spaces for tests and examples: the search runs on them unchanged.

* ``GraphSpace``: transfers given outright as two-way edges and one-way arcs, whatever the
  occupancy; buffers come from a fixed pool.
* ``ShelfSpace``: a 1-D shelf reached from its front. Inside sites are depths 0, 1, ...
  (0 at the front); a block can be taken from or put on an inside site only when no block
  stands in front of it, so a shelf must be filled from the back and emptied from the front,
  as a dense grid must be filled from its centre out. Outside sites (a table beside the
  shelf) are always reachable and never overlap; ``buffers`` creates them on demand.
"""

from __future__ import annotations

from collections.abc import Collection, Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np

from nodes.planner.unlabeled.rpg import Site, Transfer, pairwise_transfers


@dataclass
class GraphSpace:
    edges: Iterable[tuple[Site, Site]] = ()
    arcs: Iterable[tuple[Site, Site]] = ()
    conflict_pairs: Iterable[tuple[Site, Site]] = ()
    spare: Sequence[Site] = ()
    obstructing: Collection[Site] = ()

    def __post_init__(self) -> None:
        self._one_way = {(u, v) for u, v in self.arcs}
        self._two_way = {(u, v) for u, v in self.edges} | {(v, u) for u, v in self.edges}
        self._conflicts = {frozenset(p) for p in self.conflict_pairs}

    def conflicts(self, a: Site, b: Site) -> bool:
        return frozenset((a, b)) in self._conflicts

    def transfer(self, u: Site, v: Site, occupied: frozenset[Site]) -> Transfer | None:
        return Transfer(u, v) if (u, v) in self._two_way | self._one_way else None

    def transfers(self, nodes: Sequence[Site]) -> list[Transfer]:
        present = set(nodes)
        return [Transfer(u, v) for u, v in sorted(self._two_way | self._one_way)
                if u in present and v in present]

    def buffers(self, nodes: Collection[Site], near: Sequence[Site], count: int,
                rng: np.random.Generator) -> list[Site]:
        out = []
        for s in self.spare:
            if len(out) == count:
                break
            if s not in nodes and not any(self.conflicts(s, n) for n in [*nodes, *out]):
                out.append(s)
        return out

    def obstructs(self, site: Site) -> bool:
        return site in self.obstructing


OUTSIDE = 1000  # outside sites are OUTSIDE, OUTSIDE + 1, ...


@dataclass
class ShelfSpace:
    """Inside sites 0..depth-1 (0 at the front), outside sites from ``OUTSIDE`` up.

    ``fixed`` sites always hold a block that is not a pebble (an obstacle).
    """

    depth: int
    fixed: frozenset[Site] = frozenset()
    _next_outside: int = field(default=OUTSIDE, init=False)

    @staticmethod
    def inside(site: Site) -> bool:
        return site < OUTSIDE

    def conflicts(self, a: Site, b: Site) -> bool:
        return a == b

    def reachable(self, site: Site, others: Collection[Site]) -> bool:
        """No other block stands in front of an inside site."""
        if not self.inside(site):
            return True
        return not any(self.inside(o) and o < site for o in others if o != site)

    def transfer(self, u: Site, v: Site, occupied: frozenset[Site]) -> Transfer | None:
        """Can a block go from u to v while ``occupied`` hold blocks (fixed ones always)?"""
        others = (occupied | self.fixed) - {u, v}
        if self.reachable(u, others) and self.reachable(v, others):
            return Transfer(u, v, 1, 1.0 + 0.01 * abs(u - v))
        return None

    def transfers(self, nodes: Sequence[Site]) -> list[Transfer]:
        return pairwise_transfers(nodes, self.transfer)

    def buffers(self, nodes: Collection[Site], near: Sequence[Site], count: int,
                rng: np.random.Generator) -> list[Site]:
        out = []
        for _ in range(count):
            out.append(self._next_outside)
            self._next_outside += 1
        return out

    def obstructs(self, site: Site) -> bool:
        return False

    def outside_sites(self, n: int) -> list[Site]:
        """``n`` fresh outside sites (e.g. start poses on the table)."""
        return self.buffers((), (), n, np.random.default_rng(0))
