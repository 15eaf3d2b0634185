"""The interface between pIRS (``pirs``) and a geometry: the routes it asks for and the
questions it asks (``PirsSpace``). ``cell_pirs.CellPirs`` answers them for the work cell, the
unit tests for a toy space."""

from __future__ import annotations

from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

State = Mapping[int, Any]


@dataclass(frozen=True)
class Route:
    """A path for one block: its actions, the movable blocks it hits (O_b, in order of first
    contact), its cost, its end pose, and the region it sweeps (opaque to the search)."""

    actions: tuple[Any, ...]
    blocked: tuple[int, ...]
    cost: float
    end: Any
    region: Any = None


@dataclass(frozen=True)
class NoRoute:
    """Why no path exists even through movable blocks."""

    reason: str
    fixed_blockers: tuple[int, ...] = ()


class PirsSpace(Protocol):
    """The geometry pIRS needs."""

    def at_goal(self, block: int, state: State) -> bool: ...

    def goal_pose(self, block: int, state: State) -> Any:
        """The pose to route ``block`` to for its goal (e.g. the goal yaw nearest its own)."""

    def route(self, block: int, state: State, target: Any, movable: frozenset[int]
              ) -> Route | NoRoute:
        """Cheapest path of ``block`` to ``target``; blocks in ``movable`` may be hit."""

    def order(self, blocks: Collection[int], state: State, placed: frozenset[int]
              ) -> Iterable[int]:
        """``blocks`` to place next, best first (may be lazy); those that must not go next
        left out."""

    def clearing_poses(self, block: int, state: State, placed: frozenset[int], region: Any
                       ) -> list[tuple[Any, bool]]:
        """Poses to clear ``block`` to, out of ``region``, best first, each with whether its
        own way may be cleared recursively."""

    def wedged(self, block: int, end: Any, state: State, movable: frozenset[int]
               ) -> list[int]:
        """Movable blocks that ``block`` standing at ``end`` would leave ungraspable."""

    def walls_in(self, before: State, after: State, placed: frozenset[int]) -> bool:
        """Whether ``after`` leaves a goal slot that can no longer be filled in any order,
        where ``before`` left none (``placed``: the blocks placed before; the blocks standing
        on their goal count as filling their slot either way)."""

    def shuts_in(self, block: int, before: State, after: State, placed: frozenset[int]
                 ) -> list[int]:
        """Blocks still to move that ``block`` placed (``before`` -> ``after``; ``placed``:
        the blocks placed before it) leaves unable to move at all while the placed blocks
        stand, where before they could."""

    def freeing_nudges(self, block: int, state: State, held: frozenset[int],
                       movable: frozenset[int]) -> list[tuple[int, Route]]:
        """Short moves of a ``held`` block (one the search holds in place for this move, not
        a placed one) after which ``block`` can be taken, best first: (that block, its
        route); none where ``block`` can be taken already."""

    def join(self, a: Any, b: Any) -> Any:
        """The union of two regions."""
