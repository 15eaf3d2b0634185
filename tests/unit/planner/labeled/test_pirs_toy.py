"""pIRS on a toy space: the search needs nothing of the work cell but ``PirsSpace``."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from nodes.planner.budget import Budget
from nodes.planner.labeled.pirs import NoRoute, Pirs, PirsOptions, PlanningFailure, Route

Pose = tuple[str, int]  # ("shelf", depth) with depth 0 at the front, or ("table", k)


@dataclass
class Shelf:  # a pirs.PirsSpace
    """A shelf reached from its front: a block at depth d moves only when nothing stands in
    front of it, and goes in only past empty depths; the table beside it is always free."""

    goals: dict[int, int]  # block -> goal depth
    table: int = 6

    def _in_front(self, pose: Pose, state) -> set[int]:
        if pose[0] != "shelf":
            return set()
        return {b for b, p in state.items() if p[0] == "shelf" and p[1] < pose[1]}

    def at_goal(self, block, state) -> bool:
        return state[block] == ("shelf", self.goals[block])

    def goal_pose(self, block, state) -> Pose:
        return ("shelf", self.goals[block])

    def route(self, block, state, target, movable) -> Route | NoRoute:
        others = {b: p for b, p in state.items() if b != block}
        way = self._in_front(state[block], others) | self._in_front(target, others)
        way |= {b for b, p in others.items() if p == target}
        if way - movable:
            return NoRoute(f"blocks {sorted(way - movable)} are fixed in the way")
        region = frozenset(p for b, p in others.items() if b in way)
        return Route(((block, state[block], target),), tuple(sorted(way)), 1.0 + len(way),
                     target, region)

    def order(self, blocks, state, placed) -> list[int]:
        # deepest goal first: filling a front slot early walls in the ones behind it
        pending = [self.goals[b] for b in self.goals if b not in placed]
        return sorted((b for b in blocks if self.goals[b] == max(pending)),
                      key=lambda b: -self.goals[b])

    def clearing_poses(self, block, state, placed, region) -> list[tuple[Pose, bool]]:
        used = set(state.values())
        return [(("table", k), True) for k in range(self.table) if ("table", k) not in used][:3]

    def wedged(self, block, end, state, movable) -> list[int]:
        return []

    def walls_in(self, before, after, placed) -> bool:
        return False

    def shuts_in(self, block, before, after, placed) -> list[int]:
        return []

    def freeing_nudges(self, block, state, held, movable) -> list:
        return []

    def join(self, a, b):
        return (a or frozenset()) | (b or frozenset())


def replay(space: Shelf, start, actions):
    state = dict(start)
    for block, frm, to in actions:
        assert state[block] == frm
        others = {b: p for b, p in state.items() if b != block}
        assert not space._in_front(frm, others) and not space._in_front(to, others)
        assert to not in others.values()
        state[block] = to
    return state


def test_a_block_deep_in_the_wrong_place_is_cleared_and_the_shelf_filled_from_the_back():
    space = Shelf({0: 0, 1: 1, 2: 2})
    start = {0: ("shelf", 2), 1: ("table", 0), 2: ("table", 1)}
    search = Pirs(space, frozenset(space.goals), frozenset(), Budget.of(10.0))
    actions, end = search.run(start)
    assert replay(space, start, actions) == end
    assert all(space.at_goal(b, end) for b in space.goals)
    assert [a[0] for a in actions] == [0, 2, 1, 0]  # 0 cleared out, then back to front
    assert search.stats.clears == 1


def test_blocks_kept_on_their_goal_stay_when_they_can():
    space = Shelf({0: 0, 1: 1, 2: 2})
    start = {0: ("table", 0), 1: ("table", 1), 2: ("shelf", 2)}
    actions, _ = Pirs(space, frozenset(space.goals), frozenset(), Budget.of(10.0)).run(
        start, keep={2})
    assert [a[0] for a in actions] == [1, 0]


def test_a_fixed_block_in_the_way_is_a_named_failure():
    space = Shelf({0: 1})
    start = {0: ("table", 0), 9: ("shelf", 0)}  # block 9 has no goal: movable, so it works
    actions, end = Pirs(space, frozenset({0}), frozenset({9}), Budget.of(10.0)).run(start)
    assert end[0] == ("shelf", 1) and len(actions) == 2
    with pytest.raises(PlanningFailure) as err:  # now block 9 is not movable at all
        Pirs(space, frozenset({0}), frozenset(), Budget.of(10.0)).run(start)
    assert err.value.block == 0 and "fixed in the way" in err.value.reason


def test_a_stop_request_ends_the_search_as_a_failure():
    space = Shelf({0: 0, 1: 1, 2: 2})
    start = {0: ("shelf", 2), 1: ("shelf", 1), 2: ("shelf", 0)}
    with pytest.raises(PlanningFailure, match="stop requested"):
        Pirs(space, frozenset(space.goals), frozenset(),
             Budget.of(10.0, should_stop=lambda: True)).run(start)


@dataclass
class RecordingShelf(Shelf):
    """The shelf, remembering the region each clear was asked to keep out of."""

    regions: list = None

    def clearing_poses(self, block, state, placed, region):
        self.regions.append((block, region))
        return super().clearing_poses(block, state, placed, region)


def test_a_second_clear_for_the_same_placement_keeps_out_of_the_first_route_too():
    space = RecordingShelf({0: 2, 1: 1, 2: 0}, regions=[])
    start = {0: ("table", 0), 1: ("shelf", 0), 2: ("shelf", 1)}
    search = Pirs(space, frozenset(space.goals), frozenset(), Budget.of(10.0))
    actions, end = search.run(start)
    assert replay(space, start, actions) == end
    (first, r1), (second, r2) = space.regions[:2]
    assert (first, second) == (1, 2)  # both stood in front of block 0's goal
    assert ("shelf", 0) in r1 and r1 <= r2  # the first route's region is kept


@dataclass
class FrontFirstShelf(Shelf):
    """The shelf, offering the front slots first: a front block set down walls in the slots
    behind it, found only a placement later, so the search backtracks."""

    def order(self, blocks, state, placed) -> list[int]:
        return sorted(blocks, key=lambda b: self.goals[b])


def test_a_search_past_max_backtracks_stops_as_thrashed_and_unbounded_solves():
    space = FrontFirstShelf({0: 0, 1: 1, 2: 2})
    start = {0: ("table", 0), 1: ("table", 1), 2: ("table", 2)}
    search = Pirs(space, frozenset(space.goals), frozenset(), Budget.of(10.0))
    actions, end = search.run(start)
    assert replay(space, start, actions) == end
    assert all(space.at_goal(b, end) for b in space.goals)
    assert search.stats.backtracks >= 2
    limited = Pirs(space, frozenset(space.goals), frozenset(), Budget.of(10.0),
                   PirsOptions(max_backtracks=1))
    with pytest.raises(PlanningFailure, match="backtracked 2 times") as err:
        limited.run(start)
    assert err.value.thrashed
    with pytest.raises(PlanningFailure) as out_of_ways:  # a failure for want of a way is not
        Pirs(Shelf({0: 1}), frozenset({0}), frozenset(), Budget.of(10.0),
             PirsOptions(max_backtracks=1)).run({0: ("table", 0), 9: ("shelf", 0)})
    assert not out_of_ways.value.thrashed
