"""The minimum feedback vertex set of "stands on the slot of", and the bound it serves: never
above a proven optimum (property tests)."""

from __future__ import annotations

import itertools

import networkx as nx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodes.bench.instances import instance
from nodes.bench.planner import exact_actions
from nodes.planner.bounds.bound import REFERENCE_DP_MAX, labeled_bound
from nodes.planner.bounds.feedback import disjoint_cycles, feedback_vertex_set
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext


def brute_force(clears: list[int], todo: int) -> int:
    g = nx.DiGraph()
    nodes = [c for c in range(len(clears)) if todo >> c & 1]
    g.add_nodes_from(nodes)
    g.add_edges_from((c, v) for c in nodes for v in nodes if clears[c] >> v & 1 and v != c)
    for size in range(len(nodes) + 1):
        for cut in itertools.combinations(nodes, size):
            if nx.is_directed_acyclic_graph(g.subgraph(set(nodes) - set(cut))):
                return size
    raise AssertionError("unreachable")


@settings(max_examples=150, deadline=None)
@given(st.integers(2, 7).flatmap(lambda n: st.tuples(
    st.lists(st.integers(0, 2**n - 1), min_size=n, max_size=n), st.integers(0, 2**n - 1))))
def test_the_feedback_vertex_set_is_the_minimum(case):
    clears, todo = case
    assert feedback_vertex_set(clears, todo) == brute_force(clears, todo)


def test_it_is_never_below_the_disjoint_cycles():
    # 4 blocks each standing on the 3 other slots: 3 must be cleared, 2 disjoint cycles
    clique = [0b1111 & ~(1 << k) for k in range(4)]
    g = nx.DiGraph((c, v) for c in range(4) for v in range(4) if c != v)
    assert feedback_vertex_set(clique, 0b1111) == 3 >= disjoint_cycles(g) == 2


SMALL = [(kind, n, d, seed) for kind in ("random", "rotated") for n in (3, 4)
         for d in (0.2, 0.3) for seed in range(4)]


@pytest.mark.parametrize(("kind", "n", "density", "seed"), SMALL)
def test_the_bounds_are_never_above_the_proven_optimum(kind, n, density, seed):
    scene = instance(kind, n, density, seed)
    config = PlannerConfig()
    optimum = exact_actions(scene, config)
    if optimum is None:
        pytest.skip("no optimum proven for this scene")
    ctx = PlanContext.for_scene(scene, config)
    start, goals = {b.id: b.pose for b in scene.blocks}, scene.goal_assignment()
    # dp_max=0: the cheap terms alone (last two arrivals, feedback vertex set, walls)
    for dp_max in (0, REFERENCE_DP_MAX):
        assert labeled_bound(ctx, start, goals, False, dp_max=dp_max).value <= optimum
