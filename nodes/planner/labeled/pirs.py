"""pIRS and CLEAR (Algorithms 1-2 of the paper), over any geometry that speaks ``PirsSpace``.

The search knows blocks (ids), poses (opaque), routes and regions (opaque); the geometry
answers: where is a block's goal, is it there, the cheapest route of a block to a pose with
the movable blocks it hits (the paper's PRM), which blocks to try next, where a blocking
block may be cleared to. ``cell_pirs.CellPirs`` is the work cell; the unit tests run the
same search on a toy space.

``Pirs.run`` tries the blocks in the space's order, as the paper's top level does, and returns
the concatenated actions and the final state, or raises ``PlanningFailure`` naming the block
and the reason of the failure that got furthest (most blocks placed). Differences from the
pseudocode, all deliberate:

* Algorithm 1 line 7 recurses on ``O_R \\ o_r`` (the paper prints ``o_b``, a typo).
* A block already on its goal succeeds with an empty action list (the paper's test
  ``pi != {}`` would reject it), and blocks ``keep`` asks to leave on their goal are placed
  from the start (a replan late in a run: the missing few go in around them); if that
  fails within half the budget, the search starts again with every block movable.
* Blocks the goal does not name stay movable obstacles for the whole search.
* CLEAR tries the space's clearing poses in turn, and after clearing its own way retries the
  *same* pose (the path to it was just cleared) rather than a new one. A block in its way
  that could not be cleared is fixed for the routes to the poses tried after it (they go
  round it: choosing it again fails again, after seconds of nested clears in a crowded scene).
* Re-planning a block after a clear (line 14) keeps the regions its earlier routes swept:
  later clears stay out of all of them (the route is sampled afresh each time, and a block
  cleared out of one route's way stood in the next one's; 49 blocks at density 0.3: 4-6
  actions fewer per scene).
* Among the first ``probe`` candidates, one whose route hits no movable block goes first.
* With ``max_backtracks``, a search that backtracks more often stops (``thrashed``), for
  the caller to start again otherwise.
* A placement that would take the last free grasp of a movable block (``wedged``) clears
  that block first.
* A placement that leaves a goal slot no order can fill any more, counting the blocks that
  stand on their goal without being placed (a block cleared onto its own goal), where the
  state before it left none (``walls_in``), is a dead end: the search backtracks at once
  rather than finding out a dozen placements later that such a block, hemmed in where it
  stands, can be neither moved nor left. So is a placement that leaves a block still to move
  with no grasp and no push free of the placed blocks (``shuts_in``): placed blocks never
  move again.
* A block to clear that no route leaves where it stands, its grasps covered by blocks the
  search holds in place (the chain of clears above it), is cleared after a short push of
  one of those that frees a grasp (``freeing_nudges``); the chain re-plans that block's move
  from where it then stands, as it does after every clear.

Deterministic for a seed (the space draws from one generator in a fixed order). It stops
with a failure when the budget runs out or a block's clearing nests deeper than ``max_depth``.
"""

from __future__ import annotations

import itertools
from collections.abc import Collection, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

from nodes.planner.budget import Budget, OutOfTime
from nodes.planner.labeled.pirs_space import NoRoute, PirsSpace, Route, State

__all__ = ["NoRoute", "Pirs", "PirsOptions", "PirsSpace", "PirsStats", "PlanningFailure",
           "Route", "State"]


class PlanningFailure(Exception):
    """No plan: ``block`` is the block the search could not get further with; ``thrashed``:
    the search stopped at ``max_backtracks``, not for want of time or of a way."""

    def __init__(self, block: int | None, reason: str, thrashed: bool = False) -> None:
        super().__init__(f"block {block}: {reason}" if block is not None else reason)
        self.block = block
        self.reason = reason
        self.thrashed = thrashed


class _Thrashing(Exception):
    """The search backtracked ``max_backtracks`` times: unwinds it."""


@dataclass
class PirsStats:
    roadmaps: int = 0
    clears: int = 0
    backtracks: int = 0
    placed_max: int = 0
    nudges: int = 0  # freeing nudges of a held block tried
    failure: tuple[int, int | None, str] = (-1, None, "")  # (progress, block, reason)

    def as_metrics(self) -> dict[str, float]:
        return {"roadmaps": float(self.roadmaps), "clears": float(self.clears),
                "backtracks": float(self.backtracks), "placed_max": float(self.placed_max),
                "freeing_nudges": float(self.nudges)}


@dataclass(frozen=True)
class PirsOptions:
    probe: int = 5  # candidates routed before choosing the next block
    max_depth: int = 8  # nested CLEAR / re-plan recursion per block
    route_round: bool = True  # CLEAR's next routes go round a block it failed to clear
    max_backtracks: int | None = None  # stop (``PlanningFailure.thrashed``) after this many


@dataclass
class _Result:
    actions: list[Any]
    state: dict[int, Any]


@dataclass
class Pirs:
    space: PirsSpace
    goals: frozenset[int]  # blocks with a goal
    free: frozenset[int]  # blocks without one: movable obstacles throughout
    budget: Budget
    options: PirsOptions = field(default_factory=PirsOptions)
    stats: PirsStats = field(default_factory=PirsStats)
    #: backtracks in the current ``_search`` (``max_backtracks`` counts these)
    _backtracks: int = field(default=0, init=False, repr=False)

    # --- top level --------------------------------------------------------------------------
    def run(self, start: State, keep: Collection[int] = ()
            ) -> tuple[list[Any], dict[int, Any]]:
        """Actions from ``start`` to every block on its goal; the blocks ``keep`` (on their
        goal) stay put if that succeeds within half the budget."""
        keep = frozenset(keep) & self.goals
        if keep and keep != self.goals:
            outer, self.budget = self.budget, self.budget.share(0.5)
            try:
                result = self._search(dict(start), self.goals - keep, keep)
            except (OutOfTime, _Thrashing):
                result = None
            self.budget = outer
            if result is not None:
                return result
        try:
            result = self._search(dict(start), self.goals, frozenset())
        except _Thrashing:
            _, block, reason = self.stats.failure
            raise PlanningFailure(block, f"the search backtracked {self._backtracks} times "
                                  f"(max_backtracks) after placing at most "
                                  f"{self.stats.placed_max} of {len(self.goals)} blocks"
                                  + (f"; last failure: {reason}" if reason else ""),
                                  thrashed=True) from None
        except OutOfTime:
            _, block, reason = self.stats.failure
            given = self.budget.deadline - self.budget.started
            why = ("stop requested" if self.budget.stopped()
                   else f"its time budget ({given:.1f} s) exhausted")
            raise PlanningFailure(block, f"{why} after placing at most {self.stats.placed_max} "
                                  f"of {len(self.goals)} blocks"
                                  + (f"; last failure: {reason}" if reason else "")) from None
        if result is not None:
            return result
        _, block, reason = self.stats.failure
        raise PlanningFailure(block, reason or "no plan found")

    def _search(self, start: dict[int, Any], targets: frozenset[int], placed: frozenset[int]
                ) -> tuple[list[Any], dict[int, Any]] | None:
        self._backtracks = 0
        if not targets:
            return [], start
        for o in self.space.order(targets, start, placed):
            result = self.pirs(o, targets - {o}, start, placed, 0)
            if result is not None:
                return result.actions, result.state
        return None

    # --- helpers ----------------------------------------------------------------------------
    def fail(self, block: int, placed: frozenset[int], reason: str) -> None:
        if len(placed) > self.stats.failure[0]:
            self.stats.failure = (len(placed), block, reason)

    def _too_deep(self, block: int, placed: frozenset[int], depth: int, what: str) -> bool:
        """Out of time (raises OutOfTime), or ``what`` nests deeper than ``max_depth``."""
        self.budget.check()
        if depth <= self.options.max_depth:
            return False
        self.fail(block, placed, f"{what} needed more than max_depth="
                  f"{self.options.max_depth} nested clears")
        return True

    def route(self, block: int, state: State, target: Any, movable: frozenset[int]
              ) -> Route | NoRoute:
        self.budget.check()
        self.stats.roadmaps += 1
        return self.space.route(block, state, target, movable)

    def probed(self, remaining: frozenset[int], state: dict[int, Any], placed: frozenset[int]
               ) -> Iterator[tuple[int, Route | NoRoute | None]]:
        """The space's candidates, but among the first ``probe`` of them one whose route is
        already free of movable blocks goes first (it needs no clearing); the routes found
        are handed on so they are not planned twice."""
        space = self.space
        rest = iter(space.order(remaining, state, placed))
        head = list(itertools.islice(rest, self.options.probe))
        known: dict[int, Route | NoRoute] = {}
        for b in head:
            if space.at_goal(b, state):
                break
            route = self.route(b, state, space.goal_pose(b, state), remaining - {b} | self.free)
            known[b] = route
            if isinstance(route, Route) and not route.blocked:
                head.remove(b)
                head.insert(0, b)
                break
        for b in itertools.chain(head, rest):
            yield b, known.pop(b, None)

    # --- Algorithm 1 ------------------------------------------------------------------------
    def pirs(self, o: int, remaining: frozenset[int], state: dict[int, Any],
             placed: frozenset[int], depth: int, known: Route | NoRoute | None = None,
             swept: Any = None) -> _Result | None:
        """Place ``o`` on its goal, then the ``remaining`` goal blocks; None on failure.
        ``swept``: the regions of the routes earlier tries to place ``o`` (in this chain of
        clears) swept; blocks cleared now stay out of them too, so the next route, sampled
        afresh, does not find a block just cleared in its way again."""
        if self._too_deep(o, placed, depth, "clearing its way"):
            return None
        movable = remaining | self.free
        route = self._goal_route(o, state, movable, placed, known)
        if isinstance(route, NoRoute):
            self.fail(o, placed, f"no way to its goal: {route.reason}")
            return None
        if not route.blocked:
            return self._placed(o, route, remaining, state, placed)
        o_b = route.blocked[0]
        region = route.region if swept is None else self.space.join(swept, route.region)
        cleared = self.clear(o_b, movable - {o_b}, state, placed, region, depth + 1)
        if cleared is None:
            self.fail(o, placed, f"block {o_b} stands in its way and could not be cleared")
            return None
        sub = self.pirs(o, remaining, cleared.state, placed, depth + 1, swept=region)
        if sub is None:
            return None
        return _Result([*cleared.actions, *sub.actions], sub.state)

    def _goal_route(self, o: int, state: State, movable: frozenset[int],
                    placed: frozenset[int], known: Route | NoRoute | None) -> Route | NoRoute:
        if self.space.at_goal(o, state):
            return Route((), (), 0.0, state[o])
        route = known if known is not None else self.route(
            o, state, self.space.goal_pose(o, state), movable)
        if isinstance(route, Route) and not route.blocked:
            wedged = self.space.wedged(o, route.end, state, movable)
            if not wedged:  # one it would shut in for good: clear it while it can move
                wedged = self.space.shuts_in(o, state, {**state, o: route.end}, placed)
            if wedged:  # clear it while it can still be grasped
                return Route(route.actions, (wedged[0],), route.cost, route.end, route.region)
        return route

    def _placed(self, o: int, route: Route, remaining: frozenset[int], state: dict[int, Any],
                placed: frozenset[int]) -> _Result | None:
        state2 = {**state, o: route.end}
        placed2 = placed | {o}
        if self.space.walls_in(state, state2, placed):
            self.fail(o, placed, "placing it would wall in a goal slot of a block still to "
                      "place, with the blocks that stand on their goals")
            return None
        # a route that moves ``o`` was checked by ``_goal_route`` (its shut-in blocks are
        # cleared first); one that leaves it standing on its goal was not
        shut = [] if route.actions else self.space.shuts_in(o, state, state2, placed)
        if shut:
            self.fail(o, placed, f"placing it would shut in block(s) {shut}: off their goal, "
                      "every grasp and push of theirs blocked by placed blocks, the table's edge "
                      "or the arm's reach")
            return None
        self.stats.placed_max = max(self.stats.placed_max, len(placed2))
        if not remaining:
            return _Result(list(route.actions), state2)
        for o_r, known in self.probed(remaining, state2, placed2):
            sub = self.pirs(o_r, remaining - {o_r}, state2, placed2, 0, known)
            if sub is not None:
                return _Result([*route.actions, *sub.actions], sub.state)
            self._backtrack()
        return None

    def _backtrack(self) -> None:
        """Count a backtrack; raises _Thrashing past ``max_backtracks``."""
        self.stats.backtracks += 1
        self._backtracks += 1
        limit = self.options.max_backtracks
        if limit is not None and self._backtracks > limit:
            raise _Thrashing

    # --- Algorithm 2 ------------------------------------------------------------------------
    def clear(self, o: int, movable: frozenset[int], state: dict[int, Any],
              placed: frozenset[int], region: Any, depth: int, target: Any = None,
              nudge: bool = True) -> _Result | None:
        """Move ``o`` out of the way (of ``region``), clearing its own way recursively; if
        no route leaves where it stands, after a freeing nudge of a held block (``nudge``)."""
        if self._too_deep(o, placed, depth, "clearing it"):
            return None
        self.stats.clears += 1
        tries: Sequence[tuple[Any, bool]] = (
            [(target, True)] if target is not None
            else self.space.clearing_poses(o, state, placed, region))
        if not tries:
            self.fail(o, placed, "no free pose to clear it to")
        no_route = False
        way = movable  # less a block whose clearing failed: the next route goes round it
        for pose, recurse in tries:
            route = self.route(o, state, pose, way)
            if isinstance(route, NoRoute):
                self.fail(o, placed, f"cannot be cleared: {route.reason}")
                no_route = True
                continue
            if not route.blocked:
                return _Result(list(route.actions), {**state, o: route.end})
            if recurse:
                done = self._clear_way(o, pose, route, way, state, placed, region, depth)
                if done is not None:
                    return done
                if self.options.route_round:
                    way = way - {route.blocked[0]}
        if no_route and nudge:
            return self._clear_nudged(o, movable, state, placed, region, depth, target)
        return None

    def _clear_nudged(self, o: int, movable: frozenset[int], state: dict[int, Any],
                      placed: frozenset[int], region: Any, depth: int, target: Any
                      ) -> _Result | None:
        """Clear ``o`` after a short push of a block the search holds in place (the block
        whose way is being cleared, or one of the chain above it) that frees a grasp of
        ``o``: the chain's own moves would need ``o`` gone first. The nudged block's move is
        planned again from where it then stands, as after any clear."""
        held = frozenset(state) - movable - placed - {o}
        if not held:
            return None
        for h, push in self.space.freeing_nudges(o, state, held, movable):
            self.stats.nudges += 1
            sub = self.clear(o, movable, {**state, h: push.end}, placed, region, depth + 1,
                             target, nudge=False)
            if sub is not None:
                return _Result([*push.actions, *sub.actions], sub.state)
        return None

    def _clear_way(self, o: int, pose: Any, route: Route, movable: frozenset[int],
                   state: dict[int, Any], placed: frozenset[int], region: Any, depth: int
                   ) -> _Result | None:
        """Clear the first block on ``o``'s way to ``pose``, then move ``o`` there."""
        o_b = route.blocked[0]
        sub = self.clear(o_b, movable - {o_b}, state, placed,
                         self.space.join(region, route.region), depth + 1)
        if sub is None:
            return None
        again = self.clear(o, movable, sub.state, placed, region, depth + 1, target=pose)
        if again is None:
            return None
        return _Result([*sub.actions, *again.actions], again.state)
