"""The minimum feedback vertex set of "block a stands on the slot of block b".

In any plan, of the blocks standing on each other's slots in a cycle, the one whose slot fills
first had to leave its own start before, and arrive later: an extra action. The blocks that
take such an extra action meet every cycle, so their number is at least the size of the
smallest set of vertices meeting every cycle (TORO's n + MFVS bound for pick-only plans;
here one of the terms ``bound`` takes the larger of above 12 slots).

Exact per strongly connected component (``networkx``), by trying vertex subsets of growing
size; the components here are small (a block overlaps at most a few slots). A component
larger than ``EXACT_MAX`` vertices counts its greedy vertex-disjoint cycles instead, which
the minimum is never below (one vertex per disjoint cycle at least), so the result stays a
lower bound.
"""

from __future__ import annotations

import itertools

import networkx as nx

#: Largest strongly connected component whose minimum feedback vertex set is searched.
EXACT_MAX = 16


def _graph(clears: list[int], todo: int) -> nx.DiGraph:
    """Edges c -> v: block c (to move) stands on slot v (to fill)."""
    g = nx.DiGraph()
    for c, mask in enumerate(clears):
        if todo >> c & 1:
            g.add_edges_from((c, v) for v in range(len(clears))
                             if mask >> v & 1 and todo >> v & 1 and v != c)
    return g


def _component_minimum(g: nx.DiGraph) -> int:
    """Fewest vertices of the strongly connected ``g`` whose removal leaves no cycle."""
    nodes = list(g)
    for size in range(1, len(nodes)):
        for cut in itertools.combinations(nodes, size):
            rest = g.subgraph(set(nodes) - set(cut))
            if nx.is_directed_acyclic_graph(rest):
                return size
    return len(nodes) - 1


def disjoint_cycles(g: nx.DiGraph) -> int:
    """Vertex-disjoint cycles of ``g`` (greedy, shortest first): a cheaper lower bound."""
    g = g.copy()
    count = 0
    while True:
        try:
            cycle = min(nx.simple_cycles(g, length_bound=len(g)), key=len)
        except ValueError:  # no cycle left
            return count
        g.remove_nodes_from(cycle)
        count += 1


def feedback_vertex_set(clears: list[int], todo: int) -> int:
    """The minimum feedback vertex set's size of the "stands on" graph (``clears[c]``: the
    slots block c stands on; bits of ``todo``: the slots to fill, whose blocks move)."""
    g = _graph(clears, todo)
    total = 0
    for comp in nx.strongly_connected_components(g):
        if len(comp) < 2:
            continue
        sub = g.subgraph(comp)
        total += _component_minimum(sub) if len(comp) <= EXACT_MAX else disjoint_cycles(sub)
    return total
