"""Single moves that join rearrangement pebble graphs that cannot share an arrangement, and
the blocks that wall a goal slot in.

A block overlapping a free goal slot, moved straight onto it (``overlap_moves``), and a block
on a filled slot slid into a walled-in free slot (``slide_moves``) are transitions between the
graph of one arrangement and the graph of the next: no one graph holds both sites. Each is
checked with every other block in place, like a graph edge.
"""

from __future__ import annotations

from nodes.planner.unlabeled.arrangements import ArrangementGoal, SearchSpace, SiteClasses
from nodes.planner.unlabeled.rpg import Site, Transfer


def obstructors(space: SearchSpace, sites: SiteClasses, arrangement: frozenset[Site],
                slot: Site) -> list[list[Site]]:
    """When no block can get to ``slot`` as things stand: sets of blocks whose removal
    lets one in (e.g. blocks on filled slots in front of it), smallest first, each found
    by taking every other block away and putting back all that are not in the way."""
    transfer = space.transfer
    if any(transfer(u, slot, arrangement - {u}) is not None for u in arrangement):
        return []
    found: list[list[Site]] = []
    for u in sorted(arrangement):
        if transfer(u, slot, frozenset()) is None:
            continue
        away = set(arrangement - {u})
        rank = sites.rank
        for a in sorted(away, key=lambda a: (rank(a) != 0.0, -rank(a), a)):
            if transfer(u, slot, frozenset(arrangement - {u} - (away - {a}))) is not None:
                away.discard(a)  # it can stay
        found.append(sorted(away, key=lambda a: (sites.rank(a) == 0.0, a)))
    return sorted(found, key=lambda g: (len(g), sum(sites.rank(a) == 0.0 for a in g)))


def overlap_moves(space: SearchSpace, goal: ArrangementGoal, sites: SiteClasses,
                  arrangement: frozenset[Site]) -> list[Transfer]:
    """Blocks moved straight onto a goal slot that overlaps their own site (and no other
    block): no graph can hold both sites, so this is a transition between the graph of
    the arrangement and the graph of the arrangement with the slot instead. Checked with
    every other block in place, like a graph edge."""
    out = []
    unfilled = goal.unfilled(arrangement)
    for a in sorted(arrangement):
        if not sites.hard_bad(a):
            continue
        for g in unfilled:
            if not space.conflicts(a, g):
                continue
            others = arrangement - {a}
            if any(space.conflicts(g, o) for o in others):
                continue
            t = space.transfer(a, g, others)
            if t is not None:
                out.append(t)
    return out

def slide_moves(space: SearchSpace, goal: ArrangementGoal, arrangement: frozenset[Site]
                ) -> list[Transfer]:
    """Blocks on filled slots moved into a free slot that no other block can reach as
    things stand (walled in by filled slots, the centre of a grid): the slot left behind
    is on the outside, where a block can get in. A transition like ``overlap_moves``."""
    out = []
    transfer = space.transfer
    required = frozenset(goal.required)
    outside = [u for u in sorted(arrangement) if u not in required]
    for g in goal.unfilled(arrangement):
        if any(space.conflicts(g, o) for o in arrangement):
            continue
        if any(transfer(u, g, arrangement - {u}) is not None for u in outside):
            continue
        for a in sorted(arrangement & required):
            t = transfer(a, g, arrangement - {a})
            if t is not None:
                out.append(t)
    return out
