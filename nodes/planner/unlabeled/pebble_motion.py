"""Unlabeled pebble motion on a graph: decide feasibility and extract the moves.

Pebbles sit on distinct nodes of an undirected graph; a move slides one pebble along an edge
to an empty node. With interchangeable pebbles, an arrangement is reachable from another iff
every connected component holds the same number of pebbles in both (Kornhauser et al. 1984;
Auletta et al. 1999 for the linear-time test on trees). Here a goal is more general than one
arrangement: ``required`` nodes must end occupied, ``forbidden`` nodes empty, the others
(neutral) either way, which covers full unlabeled goals (required = the goal nodes), goals
with more pebbles than slots, and "clear this area" (forbidden).

Feasible iff, in every component C, ``|C ∩ required| <= pebbles(C) <= |C \\ forbidden|``.

Moves come from peeling leaves off a spanning tree of each component: a leaf's fate is
decided (fill it from the nearest pebble, empty it by shifting a chain of pebbles towards
the nearest hole, or leave it), then the leaf is removed, which keeps the rest connected
and the counting condition true. Paths are searched in the whole remaining graph, not only
the tree, so they are shortest there. O(n^2) moves at worst, one move per goal node on
dense (near complete) graphs, which is what rearrangement pebble graphs of scattered blocks
usually are.
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Callable, Collection, Hashable, Iterable
from dataclasses import dataclass

import networkx as nx

Node = Hashable
Move = tuple[Node, Node]


class Infeasible(ValueError):
    """The goal cannot be reached on this graph; the message says which component fails."""


@dataclass(frozen=True)
class ComponentCount:
    """Counts of one component, for the feasibility test and its explanation."""

    nodes: frozenset[Node]
    pebbles: int
    required: int
    allowed: int

    @property
    def feasible(self) -> bool:
        return self.required <= self.pebbles <= self.allowed


def components(graph: nx.Graph) -> list[frozenset[Node]]:
    """Connected components, in a fixed order (by their smallest node) so signatures compare."""
    comps = [frozenset(c) for c in nx.connected_components(graph)]
    return sorted(comps, key=lambda c: min(c, key=_order_key))


def signature(comps: Iterable[frozenset[Node]], occupied: Collection[Node]) -> tuple[int, ...]:
    """How many pebbles each component holds: the paper's signature of an arrangement."""
    occ = set(occupied)
    return tuple(len(c & occ) for c in comps)


def component_counts(graph: nx.Graph, occupied: Collection[Node],
                     required: Collection[Node] = (),
                     forbidden: Collection[Node] = ()) -> list[ComponentCount]:
    occ, req, forb = set(occupied), set(required), set(forbidden)
    return [ComponentCount(c, len(c & occ), len(c & req), len(c - forb))
            for c in components(graph)]


def check_goal(graph: nx.Graph, occupied: Collection[Node], required: Collection[Node] = (),
               forbidden: Collection[Node] = ()) -> str | None:
    """None when the goal is reachable, else the reason (which component, which counts)."""
    nodes = set(graph.nodes)
    for name, group in (("occupied", occupied), ("required", required),
                        ("forbidden", forbidden)):
        stray = set(group) - nodes
        if stray:
            return f"{name} nodes {sorted(stray, key=_order_key)} are not in the graph"
    both = set(required) & set(forbidden)
    if both:
        return f"nodes {sorted(both, key=_order_key)} are both required and forbidden"
    for count in component_counts(graph, occupied, required, forbidden):
        if not count.feasible:
            some = sorted(count.nodes, key=_order_key)[:6]
            return (f"component {some}{'...' if len(count.nodes) > 6 else ''} holds "
                    f"{count.pebbles} pebbles but needs between {count.required} (required "
                    f"nodes) and {count.allowed} (nodes not forbidden)")
    return None


def is_feasible(graph: nx.Graph, occupied: Collection[Node], required: Collection[Node] = (),
                forbidden: Collection[Node] = ()) -> bool:
    return check_goal(graph, occupied, required, forbidden) is None


def solve(graph: nx.Graph, occupied: Collection[Node], required: Collection[Node] = (),
          forbidden: Collection[Node] = (), cost: Callable[[Node, Node], float] | None = None,
          ) -> list[Move]:
    """Moves (u, v), in order, that bring the pebbles on ``occupied`` to a goal arrangement.

    Args:
        graph: undirected; a move along an edge needs its target empty.
        occupied: nodes holding a pebble now.
        required: nodes that must hold a pebble at the end.
        forbidden: nodes that must be empty at the end.
        cost: optional cost of moving along an edge, to break ties between equally near
            pebbles or holes (e.g. the transfer's length).

    Raises:
        Infeasible: some component cannot meet the goal (see ``check_goal``).
    """
    reason = check_goal(graph, occupied, required, forbidden)
    if reason is not None:
        raise Infeasible(reason)
    state = _Peeler(graph, set(occupied), set(required), set(forbidden), cost)
    for comp in components(graph):
        state.peel(comp)
    return state.moves


def apply_moves(occupied: Iterable[Node], moves: Iterable[Move]) -> set[Node]:
    """The arrangement after ``moves``; raises ValueError on a move from empty or onto full."""
    occ = set(occupied)
    for k, (u, v) in enumerate(moves):
        if u not in occ or v in occ:
            raise ValueError(f"move {k} ({u} -> {v}) needs {u} occupied and {v} empty")
        occ.remove(u)
        occ.add(v)
    return occ


def _order_key(node: Node) -> tuple[int, int, str]:
    """Sort heterogeneous node labels deterministically (integers numerically first)."""
    if isinstance(node, int):
        return (0, node, "")
    return (1, 0, f"{type(node).__name__}:{node!r}")


class _Peeler:
    """Leaf-peeling solver state for one graph (see the module docstring)."""

    def __init__(self, graph: nx.Graph, occupied: set[Node], required: set[Node],
                 forbidden: set[Node], cost: Callable[[Node, Node], float] | None) -> None:
        self.graph = graph
        self.occ = occupied
        self.required = required
        self.forbidden = forbidden
        self.cost = cost
        self.moves: list[Move] = []
        self.alive: set[Node] = set()

    def peel(self, comp: frozenset[Node]) -> None:
        root = min(comp, key=_order_key)
        tree = nx.bfs_tree(self.graph.subgraph(comp), root).to_undirected()
        self.alive = set(comp)
        while self.alive:
            leaf = self._next_leaf(tree)
            self._settle(leaf)
            tree.remove_node(leaf)
            self.alive.discard(leaf)

    # --- counting --------------------------------------------------------------------------
    def _counts(self) -> tuple[int, int, int]:
        pebbles = sum(1 for n in self.alive if n in self.occ)
        required = sum(1 for n in self.alive if n in self.required)
        allowed = sum(1 for n in self.alive if n not in self.forbidden)
        return pebbles, required, allowed

    def _wants(self, leaf: Node) -> bool | None:
        """True: the leaf must end occupied; False: empty; None: either is fine."""
        if leaf in self.required:
            return True
        if leaf in self.forbidden:
            return False
        pebbles, required, allowed = self._counts()
        if pebbles == allowed:
            return True  # every node not forbidden must hold a pebble
        if pebbles == required:
            return False  # every pebble is needed on a required node
        return None

    def _next_leaf(self, tree: nx.Graph) -> Node:
        """A leaf of the remaining tree, preferring one already as the goal wants it."""
        leaves = sorted((n for n in tree.nodes if tree.degree(n) <= 1), key=_order_key)
        for leaf in leaves:
            want = self._wants(leaf)
            if want is None or want == (leaf in self.occ):
                return leaf
        return leaves[0]

    # --- moves -----------------------------------------------------------------------------
    def _settle(self, leaf: Node) -> None:
        want = self._wants(leaf)
        if want is True and leaf not in self.occ:
            self._fill(leaf)
        elif want is False and leaf in self.occ:
            self._empty(leaf)

    def _rank(self, node: Node, for_source: bool) -> int:
        """Which pebble to take (source) or hole to fill (sink) among equally near ones."""
        if for_source:  # take pebbles that must leave anyway, keep those on required nodes
            return 0 if node in self.forbidden else 2 if node in self.required else 1
        return 0 if node in self.required else 2 if node in self.forbidden else 1

    def _search(self, start: Node, through_occupied: bool) -> list[Node]:
        """Shortest path from ``start`` to the nearest node of the other kind (occupied when
        filling, empty when emptying), passing only nodes of ``start``'s kind."""
        parent: dict[Node, Node | None] = {start: None}
        dist: dict[Node, float] = {start: 0.0}
        frontier = deque([start])
        found: list[Node] = []
        found_depth = None
        depth = {start: 0}
        while frontier:
            u = frontier.popleft()
            if found_depth is not None and depth[u] >= found_depth:
                break
            for v in sorted(self.graph.neighbors(u), key=_order_key):
                if v not in self.alive or v in parent:
                    continue
                parent[v] = u
                depth[v] = depth[u] + 1
                step = self.cost(u, v) if self.cost is not None else 1.0
                dist[v] = dist[u] + step
                if (v in self.occ) != through_occupied:
                    found.append(v)
                    found_depth = depth[v]
                else:
                    frontier.append(v)
        if not found:
            raise Infeasible(f"no {'hole' if through_occupied else 'pebble'} reachable from "
                             f"{start} (internal error: counts said there was one)")
        best = min(found, key=lambda n: (self._rank(n, not through_occupied), dist[n],
                                          _order_key(n)))
        path = [best]
        while parent[path[-1]] is not None:
            path.append(parent[path[-1]])
        return path  # from the found node back to start

    def _move(self, u: Node, v: Node) -> None:
        self.occ.remove(u)
        self.occ.add(v)
        self.moves.append((u, v))

    def _fill(self, leaf: Node) -> None:
        path = self._search(leaf, through_occupied=False)  # pebble, empty..., leaf
        for u, v in itertools.pairwise(path):
            self._move(u, v)

    def _empty(self, leaf: Node) -> None:
        path = self._search(leaf, through_occupied=True)  # hole, occupied..., leaf
        for v, u in itertools.pairwise(path):
            self._move(u, v)
