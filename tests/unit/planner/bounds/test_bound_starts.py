"""The start-aware lower bound: its search on hand-made ways, and never above the exact optimum
(and pIRS) on small scenes."""

from __future__ import annotations

import pytest

from msgs_py import BlockPose, Goal, GoalSlot, Scene, Workspace
from nodes.bench.instances import instance
from nodes.bench.planner import exact_actions
from nodes.planner.bounds import bound_starts
from nodes.planner.bounds.bound import DP_MAX, labeled_bound
from nodes.planner.bounds.bound_starts import StartSearch, StartWays, start_ways
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext

CONFIG = PlannerConfig()
FREE: list[tuple[int, int]] = [(0, 0)]  # a way that nothing blocks


def ways(n: int, **over) -> StartWays:
    """n slots whose every way is free, but for ``over``'s fields."""
    base = {"grasp_in": [list(FREE) for _ in range(n)], "push_in": [[] for _ in range(n)],
            "out": [list(FREE) for _ in range(n)], "on_slot": [0] * n}
    return StartWays(**{**base, **over})


def test_blocks_that_stand_nowhere_in_the_way_take_one_action_each():
    assert StartSearch(ways(3), 0b111, [False] * 3).solve([0]) == 3


def test_two_blocks_on_each_others_slots_take_three():
    # block 0 starts on slot 1 and block 1 on slot 0: one leaves first (a clear)
    w = ways(2, on_slot=[0b10, 0b01])
    assert StartSearch(w, 0b11, [False, False]).solve([0]) == 3


def test_a_start_under_the_only_grasp_of_a_slot_forces_a_clear():
    # slot 0's only way in has block 1's start under its fingers, and slot 1's only way in
    # has block 0's start there: the old slot-only bound sees nothing, this one a clear
    w = ways(2, grasp_in=[[(0, 0b10)], [(0, 0b01)]])
    assert StartSearch(w, 0b11, [False, False]).solve([0]) == 3
    # the same, but block 1 may first arrive on its slot: no clear
    w = ways(2, grasp_in=[[(0, 0b10)], [(0, 0)]])
    assert StartSearch(w, 0b11, [False, False]).solve([0]) == 2


def test_a_push_in_needs_its_block_moved_before_unless_it_starts_on_the_line():
    w = ways(1, grasp_in=[[]], push_in=[list(FREE)])
    assert StartSearch(w, 0b1, [False]).solve([0]) == 2
    assert StartSearch(w, 0b1, [True]).solve([0]) == 1


def test_a_block_that_cannot_leave_its_start_until_a_slot_empties_needs_it_moved():
    # slot 1 is filled at the start (block 1 placed); block 0's only way out covers it:
    # block 1 goes away and back (2), block 0 arrives (1)
    w = ways(2, out=[[(0b10, 0)], list(FREE)])
    assert StartSearch(w, 0b01, [False, False]).solve([0b10]) is None
    assert StartSearch(w, 0b01, [False, False]).solve([0b10, 0]) == 3


def test_the_search_gives_up_beyond_its_expansions(monkeypatch):
    monkeypatch.setattr(bound_starts, "MAX_EXPANSIONS", 2)
    assert StartSearch(ways(4), 0b1111, [False] * 4).solve([0]) is None


def test_start_ways_see_a_start_under_the_fingers_of_a_slot():
    # one slot; block 1 (its goal far away) starts 5 mm off slot 0's +x face: the grasp that
    # closes along x has a finger on it, the one along y does not
    s, ws = 0.0508, Workspace(0.45, 0.85, -0.20, 0.20)
    scene = Scene(ws, s, (BlockPose(0, 0.50, -0.15, 0.3), BlockPose(1, 0.65 + s + 0.005, 0.0, 0.0)),
                  Goal(slots=(GoalSlot(0.65, 0.0, 0.0, 0), GoalSlot(0.80, 0.15, 0.0, 1))))
    ctx = PlanContext.for_scene(scene, CONFIG)
    start = {b.id: b.pose for b in scene.blocks}
    w = start_ways(ctx, start, scene.goal_assignment(), [0, 1], 0b11)
    assert sorted(m for _, m in w.grasp_in[0]) == [0, 0b10]
    assert w.on_slot == [0, 0]


def _bounds(scene: Scene) -> tuple[int, int]:
    """(slot-only bound, start-aware bound) of a labeled scene."""
    ctx = PlanContext.for_scene(scene, CONFIG)
    start = {b.id: b.pose for b in scene.blocks}
    goals = scene.goal_assignment()
    full = labeled_bound(ctx, start, goals, False)
    ids = sorted(goals)
    slot_only = full.relaxation
    assert slot_only is not None and len(ids) <= DP_MAX
    cost, _ = slot_only.best_start()
    return round(cost), full.value


@pytest.mark.parametrize("seed", [7, 18])
def test_cramped_scenes_where_the_starts_raise_the_bound_below_the_exact_optimum(seed):
    # 4 blocks at density 0.3: measured, slot-only bound 5, start-aware 6, exact optimum 7 / 9
    scene = instance("random", 4, 0.3, seed)
    old, new = _bounds(scene)
    best = exact_actions(scene, CONFIG)
    assert best is not None
    assert old < new <= best


@pytest.mark.parametrize(("kind", "n", "density", "seeds"),
                         [("random", 3, 0.3, range(8)), ("random", 4, 0.3, range(8)),
                          ("random", 4, 0.2, range(4)), ("rotated", 4, 0.3, range(4)),
                          ("permuted", 4, 0.2, range(4))])
def test_the_bound_never_exceeds_the_exact_optimum(kind, n, density, seeds):
    for seed in seeds:
        scene = instance(kind, n, density, seed)
        best = exact_actions(scene, CONFIG)
        if best is None:
            continue
        _, bound = _bounds(scene)
        assert bound <= best, (kind, n, density, seed)
