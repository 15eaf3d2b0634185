"""CLEAR goes round a block it failed to clear: the next clearing pose's route treats that
block as fixed, rather than choosing it again (random 49 at 0.4 seed 1: the chain kept
picking a blocker that only a block it held in place could free)."""

from __future__ import annotations

from nodes.planner.budget import Budget
from nodes.planner.labeled.pirs import NoRoute, Pirs, PirsOptions, Route


class Detour:  # a pirs.PirsSpace
    """Block 0 can go to either of two spots: straight past block 1 (cheap, if 1 may be
    moved) or the long way round (no block in the way); block 1 cannot be cleared at all."""

    def __init__(self) -> None:
        self.routes: list[tuple[int, frozenset[int]]] = []

    def at_goal(self, block, state) -> bool:
        return False

    def goal_pose(self, block, state):
        return "goal"

    def route(self, block, state, target, movable):
        self.routes.append((block, frozenset(movable)))
        if block == 1:
            return NoRoute("walled in")
        if 1 in movable:
            return Route(((block, state[block], target, "straight"),), (1,), 2.5, target, ())
        return Route(((block, state[block], target, "round"),), (), 3.0, target, ())

    def order(self, blocks, state, placed):
        return sorted(blocks)

    def clearing_poses(self, block, state, placed, region):
        return [] if block == 1 else [("spot", True), ("other spot", True)]

    def wedged(self, block, end, state, movable):
        return []

    def walls_in(self, before, after, placed) -> bool:
        return False

    def shuts_in(self, block, before, after, placed):
        return []

    def freeing_nudges(self, block, state, held, movable):
        return []

    def join(self, a, b):
        return ()


def test_a_blocker_that_could_not_be_cleared_is_routed_round_for_the_next_pose():
    space = Detour()
    search = Pirs(space, frozenset({0}), frozenset({1}), Budget.of(10.0))
    done = search.clear(0, frozenset({1}), {0: "here", 1: "there"}, frozenset(), (), 1)
    assert done is not None
    assert [a[3] for a in done.actions] == ["round"]
    assert done.state[0] == "other spot"
    # the first route may hit 1; after 1 could not be cleared, the next one may not
    assert [m for b, m in space.routes if b == 0] == [frozenset({1}), frozenset()]


def test_without_it_the_same_clear_chooses_the_blocker_again_and_fails():
    space = Detour()
    search = Pirs(space, frozenset({0}), frozenset({1}), Budget.of(10.0),
                  PirsOptions(route_round=False))
    assert search.clear(0, frozenset({1}), {0: "here", 1: "there"}, frozenset(), (), 1) is None
