"""Smoothing a transfer sequence: drop redundant moves, re-plan each move for what is there.

The hypergraph's transfers are feasible with *every* node of their graph occupied; when the
sequence is replayed, fewer blocks stand around, so a move may be done more cheaply (one
pick-and-place instead of a place-and-push) and two moves of the same block may become one.
Rewrites, each kept only when the whole rest of the sequence still replays and the
plan gets shorter (fewer actions, then lower cost):

* re-realise every transfer under the actual occupancy (``space.transfer(u, v, occupied)``);
* a block's move u -> w followed (later) by its next move w -> v becomes one move u -> v,
  done at the time of the first or of the second;
* a block's move u -> w followed by its next move w -> u disappears;
* a block's move a -> b followed by another block's c -> a becomes c -> b (blocks are alike:
  this is only for interchangeable blocks, which is all this module is used for);
* two neighbouring independent moves swap (the first may have walled in the second).
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from dataclasses import dataclass
from typing import Protocol

from nodes.planner.unlabeled.rpg import Site, Transfer


class OccupancySpace(Protocol):
    def conflicts(self, a: Site, b: Site) -> bool: ...

    def transfer(self, u: Site, v: Site, occupied: frozenset[Site]) -> Transfer | None:
        """The cheapest way to move a block from u to v while the sites ``occupied`` (not u)
        hold blocks, or None."""
        ...


@dataclass(frozen=True)
class SmoothingReport:
    actions_before: int
    actions_after: int
    rounds: int


def n_actions(transfers: Sequence[Transfer]) -> int:
    return sum(t.n_actions for t in transfers)


def _score(transfers: Sequence[Transfer]) -> tuple[int, float]:
    return n_actions(transfers), sum(t.cost for t in transfers)


def replay(space: OccupancySpace, start: Collection[Site], moves: Sequence[tuple[Site, Site]]
           ) -> list[Transfer] | None:
    """Each move (u, v) realised for the occupancy at its turn; None if one is infeasible."""
    occ = set(start)
    out = []
    for u, v in moves:
        if u == v or u not in occ or v in occ:
            return None
        others = frozenset(occ - {u})
        if any(space.conflicts(v, o) for o in others):
            return None
        t = space.transfer(u, v, others)
        if t is None:
            return None
        out.append(t)
        occ.remove(u)
        occ.add(v)
    return out


def _block_of_each(start: Collection[Site], moves: Sequence[tuple[Site, Site]]) -> list[int]:
    """Which block (numbered by sorted start site) each move carries."""
    at = {s: k for k, s in enumerate(sorted(start))}
    out = []
    for u, v in moves:
        block = at.pop(u)
        at[v] = block
        out.append(block)
    return out


def _candidates(moves: list[tuple[Site, Site]], i: int, j: int) -> list[list[tuple[Site, Site]]]:
    (u, _), (_, v) = moves[i], moves[j]
    rest = moves[i + 1:j]
    if u == v:
        return [moves[:i] + rest + moves[j + 1:]]
    return [moves[:i] + rest + [(u, v)] + moves[j + 1:],
            [*moves[:i], (u, v), *rest, *moves[j + 1:]]]


def _merges(moves: list[tuple[Site, Site]], start: Collection[Site]
            ) -> list[list[tuple[Site, Site]]]:
    """Sequences with two successive moves of one block merged (or dropped)."""
    blocks = _block_of_each(start, moves)
    out = []
    last: dict[int, int] = {}
    for j, blk in enumerate(blocks):
        if blk in last:
            out += _candidates(moves, last[blk], j)
        last[blk] = j
    return out


def _shortcuts(moves: list[tuple[Site, Site]]) -> list[list[tuple[Site, Site]]]:
    """A block moves a -> b, later another takes its place c -> a: the blocks being alike,
    the second may go c -> b instead and the first stay (a shifted chain of blocks
    becomes one move)."""
    out = []
    for i, (a, b) in enumerate(moves):
        for j in range(i + 1, len(moves)):
            c, d = moves[j]
            if a in (c, d) or b in (c, d):
                if d == a and c != b:
                    rest = moves[i + 1:j]
                    out.append([*moves[:i], *rest, (c, b), *moves[j + 1:]])
                    out.append([*moves[:i], (c, b), *rest, *moves[j + 1:]])
                break  # the first later move touching a or b decides
    return out


def _swaps(moves: list[tuple[Site, Site]]) -> list[list[tuple[Site, Site]]]:
    """Sequences with two neighbouring, independent moves (different blocks, no site the
    second needs from the first) done the other way round: an earlier move may leave room
    for a cheaper later one."""
    out = []
    for i in range(len(moves) - 1):
        (a, b), (c, d) = moves[i], moves[i + 1]
        if c != b and d != a:
            out.append([*moves[:i], (c, d), (a, b), *moves[i + 2:]])
    return out


def smooth(space: OccupancySpace, start: Collection[Site], transfers: Sequence[Transfer],
           max_rounds: int = 60) -> tuple[list[Transfer], SmoothingReport]:
    """A shorter sequence with the same end arrangement (of interchangeable blocks).

    Each round takes the first rewrite (merge, drop, then reorder) that makes the sequence
    strictly better, so the rounds end.
    """
    before = n_actions(transfers)
    best = list(transfers)
    moves = [(t.source, t.target) for t in transfers]
    again = replay(space, start, moves)
    if again is not None and _score(again) <= _score(best):
        best = again
    rounds = 0
    improved = True
    while improved and rounds < max_rounds:
        improved = False
        rounds += 1
        moves = [(t.source, t.target) for t in best]
        for cand in [*_merges(moves, start), *_shortcuts(moves), *_swaps(moves)]:
            realised = replay(space, start, cand)
            if realised is not None and _score(realised) < _score(best):
                best = realised
                improved = True
                break
    return best, SmoothingReport(before, n_actions(best), rounds)
