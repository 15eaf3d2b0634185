"""The hypergraph of rearrangement pebble graphs: from the start arrangement to the goal.

A hypernode is (RPG, signature): an arrangement class of one graph. Two hypernodes are
joined when their graphs share an arrangement consistent with both signatures (the blocks
stay put, only the graph around them changes), or, inside one graph, by a one-way arc that
moves a block between components. The goal hypernode is any class holding an arrangement
with every required site occupied and every forbidden one empty.

The paper samples graphs until start and goal connect. Random graphs rarely contain the
narrow sequences a dense grid needs (its centre must be filled before its neighbours even
exist as nodes), so graphs are *proposed* from the arrangement at hand instead: the arrangement
plus ``b`` new sites, which are the next goal slots in assembly order and/or buffer sites out
of the way. Inside the new graph the unlabeled solver moves the blocks to the best arrangement
of their class (goal slots first, nothing left on a site that blocks a goal slot), and useful
arcs are taken (a spare block pushed into a slot only reachable one way). Two single moves
join graphs that cannot share an arrangement: a block overlapping a slot moved straight onto
it, and a block on a filled slot slid into a free slot no other block can reach (walled in),
leaving its own slot on the outside. The search over
these hypernodes is weighted A*: g = actions so far, h = a lower bound on the actions left
(unfilled slots, blocks that must still leave their site).
"""

from __future__ import annotations

import heapq
import itertools
from collections.abc import Callable, Collection, Iterator
from dataclasses import dataclass, field

import numpy as np

from nodes.planner.budget import Budget
from nodes.planner.unlabeled.arrangements import ArrangementGoal, SearchSpace, SiteClasses
from nodes.planner.unlabeled.joins import obstructors, overlap_moves, slide_moves
from nodes.planner.unlabeled.rpg import (
    RearrangementPebbleGraph,
    Site,
    Transfer,
    best_arrangement,
    build_rpg,
)

__all__ = ["ArrangementGoal", "HypergraphSearch", "HypergraphStats", "SearchConfig",
           "SearchFailure", "SearchSpace"]


@dataclass(frozen=True)
class SearchConfig:
    b: int = 2  # extra empty nodes per RPG
    weight: float = 1.5  # A* weight on the heuristic
    budget: Budget | None = None  # time and stop request (None: no limit)
    max_expansions: int = 5000
    max_proposals: int = 4  # RPGs proposed per expansion


@dataclass
class HypergraphStats:
    expansions: int = 0
    rpgs: int = 0
    hypernodes: int = 0
    arcs_taken: int = 0
    hyperpath: list[tuple[int, tuple[int, ...]]] = field(default_factory=list)

    def as_metrics(self) -> dict[str, float]:
        return {"expansions": float(self.expansions), "rpgs": float(self.rpgs),
                "hypernodes": float(self.hypernodes), "arcs_taken": float(self.arcs_taken),
                "hyperpath_length": float(len(self.hyperpath))}


class SearchFailure(Exception):
    def __init__(self, reason: str, stats: HypergraphStats) -> None:
        super().__init__(reason)
        self.reason = reason
        self.stats = stats


@dataclass
class _Node:
    arrangement: frozenset[Site]
    rpg: RearrangementPebbleGraph | None
    actions: int
    cost: float
    moves: list[Transfer]
    parent: _Node | None
    h: int = 0
    progress: int = 0
    goal: bool = False


@dataclass
class _Frontier:
    """The open hypernodes of one run, what has been seen, and the best goal so far."""

    heap: list[tuple]
    seen: dict[frozenset[Site], int]
    best_h: int
    best_goal: _Node | None = None
    tie: Iterator[int] = field(default_factory=itertools.count)


class HypergraphSearch:
    """Weighted A* over hypernodes; ``run`` returns the transfers from start to goal."""

    def __init__(self, space: SearchSpace, start: Collection[Site], goal: ArrangementGoal,
                 config: SearchConfig, rng: np.random.Generator) -> None:
        self.space = space
        self.start = frozenset(start)
        self.goal = goal
        self.required = frozenset(goal.required)
        self.config = config
        self.rng = rng
        self.stats = HypergraphStats()
        self._rpgs: dict[frozenset[Site], RearrangementPebbleGraph] = {}
        self._hyper: dict[tuple[frozenset[Site], tuple[int, ...]], int] = {}
        self.sites = SiteClasses(space, goal)
        if config.b < 0:
            raise ValueError(f"b must be >= 0, got {config.b}")

    # --- graphs ----------------------------------------------------------------------------
    def rpg(self, nodes: frozenset[Site]) -> RearrangementPebbleGraph:
        if nodes not in self._rpgs:
            self._rpgs[nodes] = build_rpg(self.space, nodes)
            self.stats.rpgs += 1
        return self._rpgs[nodes]

    def note_hypernode(self, rpg: RearrangementPebbleGraph, arrangement: frozenset[Site]
                       ) -> tuple[int, tuple[int, ...]]:
        sig = rpg.signature(arrangement)
        key = (rpg.nodes, sig)
        if key not in self._hyper:
            self._hyper[key] = len(self._hyper)
            self.stats.hypernodes += 1
        return self._hyper[key], sig

    def forbidden_in(self, rpg: RearrangementPebbleGraph) -> frozenset[Site]:
        return frozenset(s for s in rpg.nodes if s not in self.required and self.goal.forbidden(s))

    def is_goal(self, rpg: RearrangementPebbleGraph, arrangement: frozenset[Site]) -> bool:
        return rpg.satisfiable(rpg.signature(arrangement), self.required, self.forbidden_in(rpg))

    # --- proposals -------------------------------------------------------------------------
    def proposals(self, arrangement: frozenset[Site]) -> list[tuple[frozenset[Site], bool]]:
        """New node sets, the arrangement plus up to b new sites, each with whether blocks
        should be evicted into its new non-goal sites.

        *Fill* graphs add the next free goal slots (in fill order; all b, fewer, one, and a
        random choice) and buffers for room to manoeuvre that blocks may pass through but
        not stay on. *Evict* graphs add one or b buffers that the blocks most in the goal's
        way move to (moving a block aside costs an action it may not need later, so
        evictions are their own, small, proposals).
        """
        b = self.config.b
        unfilled = self.goal.unfilled(arrangement)
        free = [s for s in unfilled
                if not any(self.space.conflicts(s, a) for a in arrangement)]
        sites = self.sites
        offenders = sorted((a for a in arrangement if sites.hard_bad(a) or sites.soft_bad(a)),
                           key=lambda a: (-sites.rank(a), a))
        movers = offenders or [a for a in sorted(arrangement) if a not in self.required]
        j_max = min(b, len(free))
        picks: list[tuple[list[Site], int, bool]] = []
        for j in dict.fromkeys(c for c in (j_max, j_max - 1, 1) if 1 <= c <= j_max):
            picks.append((free[:j], b - j, False))
        if len(free) > j_max >= 1:  # one variety: other slots than the first ones
            chosen = self.rng.choice(len(free), size=j_max, replace=False)
            picks.append(([free[i] for i in sorted(chosen)], b - j_max, False))
        if offenders and b >= 1:
            picks += [([], n, True) for n in dict.fromkeys((1, b))]
        out: list[tuple[frozenset[Site], bool]] = []
        for slots, n_buffers, evict in picks:
            extra = self.space.buffers(arrangement | set(slots), movers, n_buffers,
                                       self.rng) if n_buffers > 0 else []
            nodes = arrangement | set(slots) | set(extra)
            if nodes != arrangement and all(nodes != o for o, _ in out):
                out.append((nodes, evict))
            if len(out) >= self.config.max_proposals:
                break
        return out

    def unblock(self, arrangement: frozenset[Site]
                ) -> tuple[frozenset[Site], frozenset[Site]] | None:
        """A graph that moves obstructors of the first free slot (those that can move now,
        at most b) to buffers: the nodes and the sites to vacate, or None."""
        free = [s for s in self.goal.unfilled(arrangement)
                if not any(self.space.conflicts(s, a) for a in arrangement)]
        if not free or self.config.b < 1:
            return None
        for away in obstructors(self.space, self.sites, arrangement, free[0]):
            extra = self.space.buffers(arrangement, away, min(len(away), self.config.b),
                                       self.rng)
            movable = [a for a in away
                       if any(self.space.transfer(a, z, arrangement - {a}) is not None
                              for z in extra)][:len(extra)]
            if movable:
                return arrangement | set(extra), frozenset(movable)
        return None

    # --- settling inside one graph ---------------------------------------------------------
    def settle(self, rpg: RearrangementPebbleGraph, arrangement: frozenset[Site],
               evict: bool = True, vacate: frozenset[Site] = frozenset()
               ) -> tuple[frozenset[Site], list[Transfer]]:
        """Best arrangement of the class, then useful arcs, repeatedly; with the moves.

        Without ``evict``, blocks do not stay on the graph's new non-goal sites; blocks on
        ``vacate`` leave them if they can.
        """
        def rank(s: Site) -> float:
            if s in vacate:
                return 5.0
            if not evict and s not in arrangement and s not in self.required:
                return 4.0
            return self.sites.rank(s)
        moves: list[Transfer] = []
        current = arrangement
        for _ in range(len(rpg.nodes) + 1):
            target = best_arrangement(rpg, current, rank)
            moves += rpg.moves_to(current, target)
            current = target
            arc = self.useful_arc(rpg, current)
            if arc is None:
                break
            prep, current = self.take_arc(rpg, current, arc, rank)
            moves += prep
            self.stats.arcs_taken += 1
        return current, moves

    def useful_arc(self, rpg: RearrangementPebbleGraph, arrangement: frozenset[Site]
                   ) -> Transfer | None:
        """An arc from a component with a block to spare into one that needs a block (an
        unfilled goal slot), or out of a component whose blocks cannot all get out of the
        way inside it; cheapest first."""
        sig = rpg.signature(arrangement)
        need, spare, crowded, room = [], [], [], []
        for k, comp in enumerate(rpg.components):
            req = sum(1 for s in comp if s in self.required)
            good = sum(1 for s in comp if self.sites.rank(s) <= 1.0)
            need.append(sig[k] < req)
            spare.append(sig[k] > req)
            crowded.append(sig[k] > good)
            room.append(sig[k] < good)
        best, best_key = None, None
        for (u, v), t in rpg.arcs.items():
            a, b = rpg.comp_of[u], rpg.comp_of[v]
            if sig[a] < 1 or sig[b] >= len(rpg.components[b]):
                continue
            if not ((spare[a] and need[b]) or (crowded[a] and room[b] and not need[a])):
                continue
            # Take a block that must leave its site anyway, not one a slot would then miss.
            key = (t.n_actions, -self.sites.rank(u), t.cost, u, v)
            if best_key is None or key < best_key:
                best, best_key = t, key
        return best

    def take_arc(self, rpg: RearrangementPebbleGraph, arrangement: frozenset[Site],
                 arc: Transfer, base: Callable[[Site], float]
                 ) -> tuple[list[Transfer], frozenset[Site]]:
        u, v = arc.source, arc.target

        def rank(s: Site) -> float:
            return -1.0 if s == u else 9.0 if s == v else base(s)
        ready = best_arrangement(rpg, arrangement, rank)
        moves = rpg.moves_to(arrangement, ready)
        return [*moves, arc], (ready - {u}) | {v}

    # --- search ----------------------------------------------------------------------------
    def child(self, parent: _Node, rpg: RearrangementPebbleGraph, evict: bool,
              vacate: frozenset[Site] = frozenset()) -> _Node:
        arrangement, moves = self.settle(rpg, parent.arrangement, evict, vacate)
        return _Node(arrangement, rpg,
                     parent.actions + sum(t.n_actions for t in moves),
                     parent.cost + sum(t.cost for t in moves), moves, parent,
                     self.sites.heuristic(arrangement), self.sites.progress(arrangement))

    def slid(self, parent: _Node, t: Transfer) -> _Node:
        """The hypernode after an overlap move: the new arrangement in its own graph."""
        arrangement = (parent.arrangement - {t.source}) | {t.target}
        return _Node(arrangement, self.rpg(arrangement), parent.actions + t.n_actions,
                     parent.cost + t.cost, [t], parent, self.sites.heuristic(arrangement),
                     self.sites.progress(arrangement))

    def run(self) -> list[Transfer]:
        """Transfers from the start arrangement to a goal arrangement.

        A hypernode whose class holds a goal arrangement becomes a goal entry with its
        total cost (the moves to that arrangement included); the search returns when a goal
        entry comes off the queue, i.e. no open hypernode promises fewer actions (weighted
        by ``weight``), or the best goal found so far when time or expansions run out.

        Raises:
            SearchFailure: no goal hypernode reached within the deadline / expansions.
        """
        if self.required <= self.start and not any(self.goal.forbidden(s) for s in self.start):
            return []  # already there
        root = _Node(self.start, None, 0, 0.0, [], None, self.sites.heuristic(self.start))
        front = _Frontier([(0.0, root.h, 0, 0.0, -1, root)], {root.arrangement: 0}, root.h)
        while front.heap:
            why = self._out_of_limits()
            if why:
                return self._give_up(front, why)
            *_, node = heapq.heappop(front.heap)
            if node.goal:
                return self.finish(node)
            if front.seen.get(node.arrangement, -1) < node.actions:
                continue
            self.stats.expansions += 1
            for kid in self.expand(node, front.seen):
                self._enqueue(kid, front)
        return self._give_up(front, "the hypergraph ran out of hypernodes to expand")

    def _out_of_limits(self) -> str:
        """Why the search must stop now ('' if it need not); a stop request raises."""
        cfg = self.config
        if cfg.budget is not None and cfg.budget.stopped():
            raise SearchFailure("stopped on request", self.stats)
        if cfg.budget is not None and cfg.budget.expired():
            return "time budget exhausted"
        if self.stats.expansions >= cfg.max_expansions:
            return f"{cfg.max_expansions} expansions without reaching the goal"
        return ""

    def _give_up(self, front: _Frontier, why: str) -> list[Transfer]:
        if front.best_goal is not None:
            return self.finish(front.best_goal)
        raise SearchFailure(f"{why}; best arrangement still needed {front.best_h} actions",
                            self.stats)

    def expand(self, node: _Node, seen: dict[frozenset[Site], int]) -> list[_Node]:
        """The hypernodes the proposed graphs, overlap and slide moves lead to from ``node``, and,
        when none of the new ones gets closer, the graph that unblocks the next slot."""
        kids = [self.child(node, self.rpg(nodes), evict)
                for nodes, evict in self.proposals(node.arrangement)]
        joins = (*overlap_moves(self.space, self.goal, self.sites, node.arrangement),
                 *slide_moves(self.space, self.goal, node.arrangement))
        kids += [self.slid(node, t) for t in joins]
        fresh = [kid for kid in kids if kid.arrangement not in seen]
        if not any(kid.h < node.h for kid in fresh):
            stuck = self.unblock(node.arrangement)
            if stuck is not None:
                kids.append(self.child(node, self.rpg(stuck[0]), True, stuck[1]))
        return kids

    def _enqueue(self, kid: _Node, front: _Frontier) -> None:
        """Queue ``kid``, or its goal entry when its class holds a goal arrangement."""
        self.note_hypernode(kid.rpg, kid.arrangement)
        if self.is_goal(kid.rpg, kid.arrangement):
            done = self.goal_entry(kid)
            best = front.best_goal
            if best is None or (done.actions, done.cost) < (best.actions, best.cost):
                front.best_goal = done
                heapq.heappush(front.heap, (float(done.actions), 0, -done.progress, done.cost,
                                            next(front.tie), done))
            return
        if kid.arrangement in front.seen and front.seen[kid.arrangement] <= kid.actions:
            return
        front.seen[kid.arrangement] = kid.actions
        front.best_h = min(front.best_h, kid.h)
        f = kid.actions + self.config.weight * kid.h
        heapq.heappush(front.heap, (f, kid.h, -kid.progress, kid.cost, next(front.tie), kid))

    def goal_entry(self, node: _Node) -> _Node:
        """The goal reached from ``node``'s class: the final moves inside its graph."""
        rpg = node.rpg
        assert rpg is not None
        final = rpg.solve(node.arrangement, self.required, self.forbidden_in(rpg))
        arrangement = frozenset(node.arrangement)
        for t in final:
            arrangement = (arrangement - {t.source}) | {t.target}
        return _Node(arrangement, rpg, node.actions + sum(t.n_actions for t in final),
                     node.cost + sum(t.cost for t in final), final, node, 0,
                     self.sites.progress(arrangement), goal=True)

    def finish(self, node: _Node) -> list[Transfer]:
        chain: list[_Node] = []
        walk: _Node | None = node
        while walk is not None:
            chain.append(walk)
            walk = walk.parent
        chain.reverse()
        moves: list[Transfer] = []
        for n in chain:
            moves += n.moves
            if n.rpg is not None and not n.goal:
                self.stats.hyperpath.append(self.note_hypernode(n.rpg, n.arrangement))
        return moves
