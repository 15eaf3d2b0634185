"""Rearrangement pebble graphs, signatures and the hypergraph search, on toy geometry."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from nodes.planner.unlabeled.hypergraph import (
    ArrangementGoal,
    HypergraphSearch,
    SearchConfig,
    SearchFailure,
)
from nodes.planner.unlabeled.rpg import Transfer, best_arrangement, build_rpg
from nodes.planner.unlabeled.smoothing import smooth
from nodes.planner.unlabeled.toy import GraphSpace, ShelfSpace


def run(space, start, goal, b=1, **kw):
    search = HypergraphSearch(space, start, goal, SearchConfig(b=b, **kw),
                              np.random.default_rng(0))
    return search, search.run()


def replay(start, moves):
    occ = set(start)
    for t in moves:
        assert t.source in occ and t.target not in occ
        occ = (occ - {t.source}) | {t.target}
    return occ


def test_shelf_rpg_edges_hold_whatever_the_occupancy():
    shelf = ShelfSpace(depth=3)
    out1, out2 = shelf.outside_sites(2)
    rpg = build_rpg(shelf, [0, 1, 2, out1, out2])
    # An edge must hold whichever other nodes are occupied: site 1 only trades with site 0
    # (the block in front of it is the one moving), site 2 with nobody (0 or 1 may hold a
    # block in front of it).
    assert rpg.graph.has_edge(0, out1) and rpg.graph.has_edge(out1, out2)
    assert rpg.graph.has_edge(0, 1) and not rpg.graph.has_edge(1, out1)
    assert rpg.graph.degree(2) == 0
    assert rpg.components == (frozenset({0, 1, out1, out2}), frozenset({2}))
    assert rpg.signature({1, out1}) == (2, 0)
    assert rpg.signature({2, out1}) == (1, 1)
    assert rpg.satisfiable((2, 0), required={1, 0}, forbidden=set())
    assert not rpg.satisfiable((2, 0), required={2}, forbidden=set())
    assert not rpg.satisfiable((1, 1), required={0, 1}, forbidden=set())


def test_rpg_refuses_overlapping_nodes():
    space = GraphSpace(edges=[(0, 1)], conflict_pairs=[(0, 1)])
    with pytest.raises(ValueError, match="overlap"):
        build_rpg(space, [0, 1])


def test_arcs_between_components_are_signature_transitions():
    space = GraphSpace(edges=[(0, 1), (2, 3)], arcs=[(1, 2)], spare=[1, 2])
    rpg = build_rpg(space, [0, 1, 2, 3])
    assert rpg.signature({0}) == (1, 0)
    [(arc, sig)] = rpg.arc_transitions((1, 0))
    assert (arc.source, arc.target, sig) == (1, 2, (0, 1))
    assert rpg.arc_transitions((0, 1)) == []  # nothing flows back
    search, moves = run(space, {0}, ArrangementGoal(required=(3,)), b=3)
    assert search.stats.arcs_taken == 1
    assert [(t.source, t.target) for t in moves] == [(0, 1), (1, 2), (2, 3)]


def test_best_arrangement_fills_low_rank_nodes_of_each_component():
    space = GraphSpace(edges=[(0, 1), (1, 2), (3, 4)])
    rpg = build_rpg(space, range(5))
    chosen = best_arrangement(rpg, {0, 3}, rank=lambda s: 0 if s in (2, 4) else 1)
    assert chosen == {2, 4}


def test_overlapping_start_and_goal_need_two_graphs():
    # Site 0 (start) overlaps goal slot 9: no RPG holds both, so the block goes through the
    # buffer 5 in one graph and into the slot in the next: two hypernodes on the path.
    space = GraphSpace(edges=[(0, 5), (5, 9)], conflict_pairs=[(0, 9)], spare=[5])
    search, moves = run(space, {0}, ArrangementGoal(required=(9,)), b=1)
    assert [(t.source, t.target) for t in moves] == [(0, 5), (5, 9)]
    assert len({nodes for nodes, _ in search._hyper}) >= 2
    assert len(search.stats.hyperpath) == 2


@pytest.mark.parametrize("b", [1, 2, 3, 4])
def test_shelf_is_filled_from_the_back_with_unlabeled_blocks(b):
    shelf = ShelfSpace(depth=4)
    start = set(shelf.outside_sites(4))
    _search, moves = run(shelf, start, ArrangementGoal(required=(3, 2, 1, 0)), b=b)
    assert replay(start, moves) == {0, 1, 2, 3}
    smoothed, report = smooth(shelf, start, moves)
    assert replay(start, smoothed) == {0, 1, 2, 3}
    # One transfer per block: any block may take any slot (the graphs may route a block
    # through the front slot; smoothing takes the short way once the shelf is emptier).
    assert report.actions_after == len(smoothed) == 4


def test_clearing_the_front_of_a_shelf_moves_only_the_blocks_in_front():
    shelf = ShelfSpace(depth=4, fixed=frozenset({3}))  # block 3 is the one to retrieve
    start = {0, 1, 2}
    goal = ArrangementGoal(required=(), forbidden=lambda s: ShelfSpace.inside(s) and s < 3)
    _, moves = run(shelf, start, goal, b=2)
    end = replay(start, moves)
    assert not any(ShelfSpace.inside(s) for s in end)
    smoothed, _ = smooth(shelf, start, moves)
    assert not any(ShelfSpace.inside(s) for s in replay(start, smoothed))
    assert len(smoothed) == 3


def test_smoothing_drops_a_move_there_and_back():
    space = GraphSpace(edges=[(0, 1), (1, 2), (0, 2)])
    moves = [Transfer(0, 1), Transfer(1, 0), Transfer(0, 2)]
    smoothed, report = smooth(space, {0}, moves)
    assert [(t.source, t.target) for t in smoothed] == [(0, 2)]
    assert (report.actions_before, report.actions_after) == (3, 1)


def test_smoothing_keeps_moves_the_rest_depends_on():
    # 0 -> 1 then 1 -> 2 cannot merge: there is no transfer 0 -> 2.
    space = GraphSpace(edges=[(0, 1), (1, 2)])
    moves = [Transfer(0, 1), Transfer(1, 2)]
    smoothed, _ = smooth(space, {0}, moves)
    assert [(t.source, t.target) for t in smoothed] == [(0, 1), (1, 2)]


def test_unreachable_goal_fails_with_a_reason():
    space = GraphSpace(edges=[(0, 1)], spare=[])
    with pytest.raises(SearchFailure, match=r"ran out|expansions"):
        run(space, {0}, ArrangementGoal(required=(7,)), b=1)


@st.composite
def shelf_problems(draw):
    depth = draw(st.integers(1, 5))
    n_out = draw(st.integers(0, 3))
    shelf = ShelfSpace(depth=depth)
    outside = shelf.outside_sites(n_out)
    inside = draw(st.lists(st.integers(0, depth - 1), unique=True, max_size=depth))
    start = set(inside) | set(outside)
    k = len(start)
    # fill the back of the shelf with as many blocks as fit, any of them
    required = tuple(range(depth - 1, depth - 1 - min(k, depth), -1))
    return shelf, start, required, draw(st.integers(1, 3))


@given(shelf_problems())
def test_shelf_searches_end_in_the_goal_with_replayable_moves(case):
    shelf, start, required, b = case
    search = HypergraphSearch(shelf, start, ArrangementGoal(required=required),
                              SearchConfig(b=b), np.random.default_rng(0))
    moves = search.run()
    end = replay(start, moves)
    assert set(required) <= end and len(end) == len(start)
    occ = set(start)
    for t in moves:  # each move is feasible for the blocks standing there at its turn
        assert shelf.transfer(t.source, t.target, frozenset(occ - {t.source})) is not None
        occ = (occ - {t.source}) | {t.target}
    smoothed, report = smooth(shelf, start, moves)
    assert set(required) <= replay(start, smoothed)
    assert report.actions_after <= report.actions_before
