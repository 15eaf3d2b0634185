"""Unlabeled pebble motion: feasibility by component counts, valid moves to the goal."""

from __future__ import annotations

import networkx as nx
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nodes.planner.unlabeled.pebble_motion import (
    Infeasible,
    apply_moves,
    check_goal,
    components,
    is_feasible,
    signature,
    solve,
)


def assert_valid(graph, start, moves, required=(), forbidden=()):
    occ = set(start)
    for u, v in moves:
        assert graph.has_edge(u, v), f"move {u}->{v} is not along an edge"
        assert u in occ and v not in occ
        occ = (occ - {u}) | {v}
    assert set(required) <= occ
    assert not occ & set(forbidden)
    assert len(occ) == len(set(start))
    return occ


def test_path_graph_pebbles_slide_to_the_other_end():
    g = nx.path_graph(6)
    moves = solve(g, {0, 1, 2}, required={3, 4, 5})
    assert_valid(g, {0, 1, 2}, moves, required={3, 4, 5})
    assert len(moves) == 9  # each of 3 pebbles slides 3 steps: unlabeled pebbles never pass


def test_complete_graph_needs_one_move_per_missing_goal_node():
    g = nx.complete_graph(8)
    start, goal = {0, 1, 2, 3}, {2, 3, 4, 5}
    moves = solve(g, start, required=goal, forbidden=set(g) - goal)
    assert_valid(g, start, moves, goal)
    assert len(moves) == 2  # 0 and 1 go straight to 4 and 5; 2 and 3 stay


def test_star_tree_needs_the_centre_cleared_first():
    g = nx.star_graph(4)  # centre 0, leaves 1..4
    start, goal = {0, 1}, {3, 4}
    moves = solve(g, start, required=goal, forbidden=set(g) - goal)
    assert_valid(g, start, moves, goal)


def test_grid_graph_full_rearrangement():
    g = nx.convert_node_labels_to_integers(nx.grid_2d_graph(3, 4))
    start, goal = {0, 1, 2, 3, 4}, {7, 8, 9, 10, 11}
    moves = solve(g, start, required=goal, forbidden=set(g) - goal)
    assert_valid(g, start, moves, goal)


def test_unsolvable_when_a_component_has_the_wrong_count():
    g = nx.Graph([(0, 1), (1, 2), (3, 4)])
    assert signature(components(g), {0, 1}) == (2, 0)
    assert not is_feasible(g, {0, 1}, required={3, 4})
    reason = check_goal(g, {0, 1}, required={2, 3})
    assert reason is not None and "component" in reason
    with pytest.raises(Infeasible):
        solve(g, {0, 1}, required={2, 3})


def test_unsolvable_when_forbidden_nodes_leave_no_room():
    g = nx.path_graph(3)
    assert not is_feasible(g, {0, 1}, forbidden={1, 2})
    assert is_feasible(g, {0, 1}, forbidden={1})


def test_surplus_pebbles_stay_where_they_are():
    g = nx.complete_graph(6)
    moves = solve(g, {0, 1, 2}, required={5})
    assert_valid(g, {0, 1, 2}, moves, required={5})
    assert len(moves) == 1


def test_clearing_an_area_moves_only_the_pebbles_inside_it():
    g = nx.complete_graph(7)
    moves = solve(g, {0, 1, 2, 3}, forbidden={0, 1})
    occ = assert_valid(g, {0, 1, 2, 3}, moves, forbidden={0, 1})
    assert len(moves) == 2 and {2, 3} <= occ


def test_isolated_nodes_keep_their_pebbles():
    g = nx.Graph()
    g.add_nodes_from(range(4))
    g.add_edge(0, 1)
    assert solve(g, {0, 3}, required={1, 3}) == [(0, 1)]
    assert not is_feasible(g, {0, 3}, required={2})


def test_apply_moves_refuses_invalid_moves():
    with pytest.raises(ValueError):
        apply_moves({0, 1}, [(0, 1)])
    assert apply_moves({0, 1}, [(0, 2)]) == {1, 2}


@st.composite
def instances(draw):
    n = draw(st.integers(2, 12))
    seed = draw(st.integers(0, 10_000))
    g = nx.gnp_random_graph(n, draw(st.floats(0.15, 0.8)), seed=seed)
    k = draw(st.integers(0, n))
    nodes = list(g.nodes)
    start = set(draw(st.permutations(nodes))[:k])
    goal = set(draw(st.permutations(nodes))[:k])
    return g, start, goal


@given(instances())
def test_random_graphs_solved_iff_component_counts_match(case):
    g, start, goal = case
    comps = components(g)
    feasible = signature(comps, start) == signature(comps, goal)
    assert is_feasible(g, start, required=goal, forbidden=set(g) - goal) == feasible
    if feasible:
        moves = solve(g, start, required=goal, forbidden=set(g) - goal)
        assert_valid(g, start, moves, goal, set(g) - goal)
