"""Anytime improvement: after the first valid plan, restart pIRS and keep the shortest plan.

pIRS is greedy per block (no look-ahead past the next placement), so which blocks it clears
where, and in which order near-tied blocks go, decide how often a block is moved twice. A
restart with another generator seed (other roadmap samples and clearing poses) and a jittered
order (near ties broken at random) often finds a plan one or two actions shorter. The cell
executor replans in its loop, so planning time matters: the restarts get their own explicit
budget, ``max(improve_min_s, improve_factor x first solve time)`` capped at
``improve_max_s`` (and by what is left of the planning budget), and stop as soon as a plan
meets the certified lower bound (nothing shorter exists). Every plan compared has been
through the same shortcut and necessity passes as the first; a shorter one replaces the best
only once the independent replay validator accepts it, so the result is never longer than
the first plan and always validated.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from msgs_py.actions import Action
from nodes.planner.budget import Budget, OutOfTime

#: Order jitter of restart k (cycled): 0 only varies the samples, 1.0 lets estimates that
#: differ by less than one action swap.
JITTERS = (0.0, 0.6, 1.0)

#: Restart k: (k, jitter, budget) -> its pruned actions, or None (no plan). Restart k draws
#: from its own generator stream, so restarts differ from the first attempt and each other.
Solver = Callable[[int, float, Budget], "list[Action] | None"]
#: Does this pruned plan pass the replay validator?
Validator = Callable[["list[Action]"], bool]


@dataclass(frozen=True)
class ImproveSettings:
    """The improvement budget: ``max(min_s, factor * first_s)`` capped at ``max_s``."""

    factor: float = 4.0
    min_s: float = 1.0
    max_s: float = 3.0

    def seconds(self, first_s: float) -> float:
        """Time given to the restarts after a first solve that took ``first_s``."""
        if self.max_s <= 0.0:
            return 0.0
        return min(self.max_s, max(self.min_s, self.factor * first_s))


@dataclass
class Improvement:
    """The best plan so far and what the restarts did."""

    best: list[Action]
    tries: int = 0
    better: int = 0  # restarts that gave a shorter validated plan
    rejected: int = 0  # shorter plans the validator refused

    def metrics(self, first: int) -> dict[str, float]:
        return {"improve_tries": float(self.tries), "improve_better": float(self.better),
                "improve_rejected": float(self.rejected),
                "improve_saved": float(first - len(self.best))}


def improve(first: list[Action], solve: Solver, valid: Validator, budget: Budget,
            lower_bound: int, first_s: float) -> Improvement:
    """Restarts 1, 2, ... of ``solve`` within ``budget``; keep the shortest plan that ``valid``
    accepts (``first`` if none is shorter). A restart starts only while at least ``first_s``
    (the first solve's time, what a restart is expected to take) is left, so no time goes to
    one that cannot finish. Deterministic in what it tries; how many fit depends on the
    machine."""
    out = Improvement(list(first))
    k = 0
    while (len(out.best) > lower_bound and budget.remaining() >= first_s
           and not budget.stopped()):
        k += 1
        out.tries += 1
        try:
            actions = solve(k, JITTERS[k % len(JITTERS)], budget)
        except OutOfTime:
            break
        if actions is None or len(actions) >= len(out.best):
            continue
        if valid(actions):
            out.best, out.better = actions, out.better + 1
        else:
            out.rejected += 1
    return out
