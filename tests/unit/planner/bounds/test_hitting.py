"""The blocks forced to move twice (``hitting``): the minimum feedback vertex set of "stands
on the slot of", the pushes that close a grid's 2 x 2 squares, and the bound they serve: never
above a proven optimum nor above the exact relaxation (property tests)."""

from __future__ import annotations

import itertools

import networkx as nx
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from nodes.bench.instances import instance
from nodes.bench.planner import exact_actions
from nodes.planner.bounds import hitting
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import DP_MAX, REFERENCE_DP_MAX, labeled_bound
from nodes.planner.bounds.hitting import enclosures, forced_extra
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
def test_without_enclosures_it_is_the_minimum_feedback_vertex_set(case):
    clears, todo = case
    assert forced_extra([], todo, [False] * len(clears), clears, 2.0) == brute_force(clears, todo)


def test_it_is_above_the_disjoint_cycles():
    # 4 blocks each standing on the 3 other slots: 3 must be cleared, 2 disjoint cycles
    clique = [0b1111 & ~(1 << k) for k in range(4)]
    assert forced_extra([], 0b1111, [False] * 4, clique, 2.0) == 3


def grid_assembly(n: int) -> Assembly:
    scene = instance("random", n, 0.3, 0)
    return Assembly(PlanContext.for_scene(scene, PlannerConfig()), scene.goal_assignment())


@pytest.mark.parametrize(("n", "squares", "pushes"), [(9, 4, 2), (16, 9, 5), (49, 36, 18)])
def test_a_grid_with_3mm_gaps_needs_a_push_per_two_squares(n, squares, pushes):
    """Every 2 x 2 square of the goal grid is an enclosure, and a push closes at most the two
    squares away from its lane: half the squares, rounded up, as the exhaustive search over
    orders finds up to 4 x 5 (``test_assembly_order``) and the greedy order makes at 7 x 7."""
    asm = grid_assembly(n)
    groups = enclosures(asm)
    assert len(groups) == squares and all(g.mask.bit_count() == 4 for g in groups)
    assert forced_extra(groups, asm.all, [False] * n, [0] * n, 2.0) == pushes
    # a block that starts on its push line is pushed in with one action: none forced for it
    exempt = [True] + [False] * (n - 1)
    assert forced_extra(groups, asm.all, exempt, [0] * n, 2.0) <= pushes


def test_enclosures_of_slots_already_filled_force_nothing():
    asm = grid_assembly(9)
    assert forced_extra(enclosures(asm), 0, [False] * 9, [0] * 9, 2.0) == 0


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
    # dp_max=0: the cheap terms alone (last two arrivals, forced blocks, walls)
    for dp_max in (0, REFERENCE_DP_MAX):
        assert labeled_bound(ctx, start, goals, False, dp_max=dp_max).value <= optimum


@pytest.mark.parametrize(("kind", "density"), [("random", 0.3), ("rotated", 0.3),
                                                ("random", 0.4), ("random", 0.15)])
def test_the_cheap_terms_are_never_above_the_exact_relaxation(kind, density):
    """The forced blocks argue within the relaxation's own model (grasps, push lanes, clears),
    so the relaxation solved exactly can only be higher: 9 and 12 blocks, 8 seeds."""
    config = PlannerConfig()
    for n, seed in itertools.product((9, 12), range(8)):
        scene = instance(kind, n, density, seed)
        ctx = PlanContext.for_scene(scene, config)
        start, goals = {b.id: b.pose for b in scene.blocks}, scene.goal_assignment()
        cheap = labeled_bound(ctx, start, goals, False, dp_max=0)
        exact = labeled_bound(ctx, start, goals, False, dp_max=DP_MAX)
        assert cheap.value <= exact.value, (kind, n, density, seed)


def test_a_search_cut_short_gives_less_never_more(monkeypatch):
    """Two disjoint 3-cycles of "stands on": the lazy rounds find both (2); cut after the
    first round (no cycle added yet) or out of time before any, the answer stays below."""
    clears = [0] * 6
    for a, b in ((0, 1), (1, 2), (2, 0), (3, 4), (4, 5), (5, 3)):
        clears[a] |= 1 << b
    full = forced_extra([], 0b111111, [False] * 6, clears, 2.0)
    monkeypatch.setattr(hitting, "MAX_ROUNDS", 1)
    one_round = forced_extra([], 0b111111, [False] * 6, clears, 2.0)
    monkeypatch.setattr(hitting, "MAX_ROUNDS", 30)
    monkeypatch.setattr(hitting, "TOTAL_S", 0.0)
    no_time = forced_extra([], 0b111111, [False] * 6, clears, 2.0)
    assert full == 2 and one_round == 0 and no_time == 0
