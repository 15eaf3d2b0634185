"""What the hypergraph search wants of an arrangement: the goal, and how good each site is.

``ArrangementGoal``: the sites that must hold a block (in the order to fill them), those that
must be empty, and the extra actions an arrangement still implies. ``SiteClasses`` ranks the
sites for one search: a goal slot (occupy first), a free site, one in the goal's way
(``soft_bad``), one a block must leave (``hard_bad``: forbidden, or overlapping a slot); with
a lower bound on the actions left (``heuristic``) and a tie-break (``progress``).
``SearchSpace`` is what the search needs of the geometry beyond an RPG's transfers.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from nodes.planner.unlabeled.rpg import Site, Transfer, TransferSpace


class SearchSpace(TransferSpace, Protocol):
    """What the search needs beyond transfers: fresh buffer sites and what is in the way."""

    def buffers(self, nodes: Collection[Site], near: Sequence[Site], count: int,
                rng: np.random.Generator) -> list[Site]:
        """Up to ``count`` new sites, compatible with ``nodes`` and with each other, out of
        the goal's way, preferably close to the sites ``near``."""
        ...

    def obstructs(self, site: Site) -> bool:
        """The site is in the goal's way (e.g. in the goal area but not a slot)."""
        ...

    def transfer(self, u: Site, v: Site, occupied: frozenset[Site]) -> Transfer | None:
        """The cheapest transfer u -> v while the sites ``occupied`` hold blocks."""
        ...


def _never(site: Site) -> bool:
    return False


def _nothing(arrangement: frozenset[Site]) -> int:
    return 0


@dataclass(frozen=True)
class ArrangementGoal:
    """Sites that must hold a block (in the order to fill them), sites that must be empty,
    and an estimate of the extra actions an arrangement still implies beyond one per
    unfilled slot (e.g. pushes the geometry will force), added to the search heuristic."""

    required: tuple[Site, ...]
    forbidden: Callable[[Site], bool] = _never
    extra: Callable[[frozenset[Site]], int] = _nothing
    #: The unfilled required sites in the order to fill them from an arrangement (default:
    #: ``required``'s order); lets the geometry re-plan the order as slots get filled.
    order: Callable[[frozenset[Site]], Sequence[Site]] | None = None

    def unfilled(self, arrangement: frozenset[Site]) -> list[Site]:
        if self.order is not None:
            return [s for s in self.order(arrangement) if s not in arrangement]
        return [s for s in self.required if s not in arrangement]


class SiteClasses:
    """How good each site is for ``goal`` (cached per site)."""

    def __init__(self, space: SearchSpace, goal: ArrangementGoal) -> None:
        self.space = space
        self.goal = goal
        self.required = frozenset(goal.required)
        self._hard: dict[Site, bool] = {}
        self._soft: dict[Site, bool] = {}
        self._blocking: dict[Site, float] = {}

    def hard_bad(self, site: Site) -> bool:
        """A block on this site must leave: forbidden, or overlapping a goal slot."""
        if site not in self._hard:
            self._hard[site] = site not in self.required and (
                self.goal.forbidden(site)
                or any(self.space.conflicts(site, g) for g in self.goal.required))
        return self._hard[site]

    def soft_bad(self, site: Site) -> bool:
        if site not in self._soft:
            self._soft[site] = site not in self.required and self.space.obstructs(site)
        return self._soft[site]

    def blocking(self, site: Site) -> float:
        """How much a block on ``site`` is in the way: the goal slots it overlaps, early
        ones (in fill order) weighing more; a forbidden site weighs like a whole goal."""
        if site not in self._blocking:
            n = len(self.goal.required)
            weight = sum(1.0 + (n - k) / n for k, g in enumerate(self.goal.required)
                         if self.space.conflicts(site, g))
            if self.goal.forbidden(site):
                weight += 2.0 * max(n, 1)
            self._blocking[site] = weight
        return self._blocking[site]

    def rank(self, site: Site) -> float:
        """Which sites an arrangement should occupy first (low) and leave first (high)."""
        if site in self.required:
            return 0.0
        if self.hard_bad(site):
            return 3.0 + 1e-3 * self.blocking(site)
        return 2.0 if self.soft_bad(site) else 1.0

    def progress(self, arrangement: frozenset[Site]) -> int:
        """Tie-break between equally good hypernodes: slots early in the fill order count
        more (filling a slot before the ones behind it can wall them in)."""
        n = len(self.goal.required)
        return sum(n - i for i, s in enumerate(self.goal.required) if s in arrangement)

    def heuristic(self, arrangement: frozenset[Site]) -> int:
        unfilled = len(self.required - arrangement)
        leaving = sum(1 for s in arrangement if self.hard_bad(s))
        return max(unfilled, leaving) + self.goal.extra(arrangement)
