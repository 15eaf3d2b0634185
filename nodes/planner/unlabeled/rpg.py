"""Rearrangement pebble graphs (RPGs): poses as nodes, feasible transfers as edges.

An RPG over a set V of mutually compatible poses (no two footprints overlap) has an edge
u - v when a block can be transferred from u to v *and* back **whichever other nodes of V hold
a block**, i.e. with every other node occupied (collisions only grow with occupancy). That is
the paper's condition for the discrete solver: inside a connected component, every
arrangement with the same number of blocks is then reachable, so a component's content is
described by a count, and an arrangement class by the *signature* (count per component).

Some transfers only go one way (a push into a dense slot cannot be reversed when the fingers
have no room behind the block). They are kept as *arcs*; an arc between two components moves
one block from one to the other, so it changes the signature: the signature transitions of
one graph. Which poses exist and which transfers are feasible is the business of a
``TransferSpace`` (the work cell's geometry, or toy geometry in tests).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import networkx as nx

from nodes.planner.unlabeled import pebble_motion
from nodes.planner.unlabeled.pebble_motion import Infeasible

Site = int


@dataclass(frozen=True)
class Transfer:
    """Moving one block from site ``source`` to site ``target``.

    ``n_actions`` is how many robot actions it takes (1: one pick-and-place or push; 2: a
    pick-and-place onto a transient pose and a push from there); ``cost`` orders transfers
    with the same number of actions (e.g. by distance); ``recipe`` is the geometry's own
    description of the actions, opaque to the search.
    """

    source: Site
    target: Site
    n_actions: int = 1
    cost: float = 1.0
    recipe: Any = field(default=None, compare=False)


class TransferSpace(Protocol):
    """The geometry an RPG needs: which sites cannot coexist, and which transfers are
    feasible among a set of sites when each of the others holds a block."""

    def conflicts(self, a: Site, b: Site) -> bool:
        """True when blocks at ``a`` and ``b`` would overlap."""
        ...

    def transfers(self, nodes: Sequence[Site]) -> Iterable[Transfer]:
        """Feasible transfers between two of ``nodes`` with all the other nodes occupied."""
        ...


TransferFn = Callable[[Site, Site, frozenset[Site]], Transfer | None]


def pairwise_transfers(nodes: Sequence[Site], feasible: TransferFn) -> list[Transfer]:
    """``TransferSpace.transfers`` from a per-pair test ``feasible(u, v, occupied)``: can a
    block go from u to v while the sites ``occupied`` hold blocks? Called with every other
    node occupied, as the RPG's edges require."""
    everyone = frozenset(nodes)
    out = []
    for u in nodes:
        for v in nodes:
            if u != v:
                t = feasible(u, v, everyone - {u, v})
                if t is not None:
                    out.append(t)
    return out


@dataclass
class RearrangementPebbleGraph:
    """One RPG: its nodes, the two-way transfer graph, one-way arcs and components."""

    nodes: frozenset[Site]
    graph: nx.Graph
    best: dict[tuple[Site, Site], Transfer]
    arcs: dict[tuple[Site, Site], Transfer]
    components: tuple[frozenset[Site], ...]
    comp_of: dict[Site, int]

    # --- signatures ------------------------------------------------------------------------
    def signature(self, occupied: Collection[Site]) -> tuple[int, ...]:
        return pebble_motion.signature(self.components, occupied)

    def satisfiable(self, sig: Sequence[int], required: Collection[Site],
                    forbidden: Collection[Site]) -> bool:
        """Whether the class ``sig`` holds an arrangement with every required site occupied
        and every forbidden site empty (required sites outside the graph make it False)."""
        req, forb = set(required), set(forbidden)
        if not req <= self.nodes:
            return False
        return all(len(c & req) <= n <= len(c - forb)
                   for c, n in zip(self.components, sig, strict=True))

    def arc_transitions(self, sig: Sequence[int]) -> list[tuple[Transfer, tuple[int, ...]]]:
        """One-way transfers usable from class ``sig`` (a block in the source's component, a
        hole in the target's) and the signature each leads to; cheapest per result."""
        best: dict[tuple[int, ...], Transfer] = {}
        for (u, v), t in sorted(self.arcs.items()):
            a, b = self.comp_of[u], self.comp_of[v]
            if sig[a] < 1 or sig[b] >= len(self.components[b]):
                continue
            new = list(sig)
            new[a] -= 1
            new[b] += 1
            key = tuple(new)
            if key not in best or (t.n_actions, t.cost) < (best[key].n_actions, best[key].cost):
                best[key] = t
        return [(t, s) for s, t in best.items()]

    # --- moves -----------------------------------------------------------------------------
    def moves_to(self, occupied: Collection[Site], target: Collection[Site]) -> list[Transfer]:
        """Transfers realising arrangement ``target`` from ``occupied`` (same signature)."""
        return self.solve(occupied, required=target,
                          forbidden=self.nodes - frozenset(target))

    def solve(self, occupied: Collection[Site], required: Collection[Site] = (),
              forbidden: Collection[Site] = ()) -> list[Transfer]:
        """Unlabeled pebble motion on this graph's two-way edges, as transfers.

        Raises:
            Infeasible: the class of ``occupied`` holds no such arrangement.
        """
        moves = pebble_motion.solve(self.graph, occupied, required, forbidden,
                                    cost=lambda u, v: self.best[(u, v)].cost)
        return [self.best[m] for m in moves]


def build_rpg(space: TransferSpace, nodes: Iterable[Site]) -> RearrangementPebbleGraph:
    """The RPG of ``nodes`` (mutually compatible sites) under ``space``'s transfers.

    Raises:
        ValueError: two of the nodes conflict (their blocks would overlap).
    """
    node_list = sorted(set(nodes))
    for i, a in enumerate(node_list):
        for b in node_list[i + 1:]:
            if space.conflicts(a, b):
                raise ValueError(f"sites {a} and {b} overlap: they cannot be nodes of one RPG")
    best: dict[tuple[Site, Site], Transfer] = {}
    for t in space.transfers(node_list):
        key = (t.source, t.target)
        if key not in best or (t.n_actions, t.cost) < (best[key].n_actions, best[key].cost):
            best[key] = t
    graph = nx.Graph()
    graph.add_nodes_from(node_list)
    graph.add_edges_from((u, v) for (u, v) in best if u < v and (v, u) in best)
    comps = tuple(pebble_motion.components(graph))
    comp_of = {n: k for k, c in enumerate(comps) for n in c}
    arcs = {(u, v): t for (u, v), t in best.items()
            if (v, u) not in best and comp_of[u] != comp_of[v]}
    return RearrangementPebbleGraph(frozenset(node_list), graph, best, arcs, comps, comp_of)


def best_arrangement(rpg: RearrangementPebbleGraph, occupied: Collection[Site],
                     rank: Callable[[Site], Any]) -> frozenset[Site]:
    """The arrangement of ``occupied``'s class that fills, in each component, the nodes of
    lowest ``rank`` (ties: nodes already occupied, so fewer moves)."""
    occ = set(occupied)
    chosen: set[Site] = set()
    for comp, n in zip(rpg.components, rpg.signature(occ), strict=True):
        order = sorted(comp, key=lambda s: (rank(s), s not in occ, s))
        chosen.update(order[:n])
    return frozenset(chosen)


__all__ = ["Infeasible", "RearrangementPebbleGraph", "Site", "Transfer", "TransferSpace",
           "best_arrangement", "build_rpg", "pairwise_transfers"]
