"""Plan shortcutting: merge two moves of the same block into one when the plan allows it.

pIRS often moves a block twice: out of another block's way, and later on to its goal (or to
the start of a push). If one action can do both, either at the time of the first move (the
block goes straight to its final pose early) or at the time of the second (it stays where it
was in between), and every action in between stays feasible with the block at that other pose,
the two actions become one. Feasibility is checked with the planner's geometry
(``transfer.direct_transfers``: no contact with any block); the independent replay validator
still checks the result. Greedy and deterministic: earliest pair first, until nothing merges.
"""

from __future__ import annotations

from msgs_py import Pose2D, Push
from msgs_py.actions import Action
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.transfer import direct_transfers


def _redo(ctx: PlanContext, state: dict[int, Pose2D], action: Action) -> Action | None:
    """``action`` in ``state`` if still feasible without touching any block (same kind and,
    for a pick-and-place, the same grasp when possible)."""
    others = {b: p for b, p in state.items() if b != action.block}
    options = [t for t in direct_transfers(ctx, others, action.from_, action.to) if not t.hits]
    if isinstance(action, Push):
        return action if any(t.kind == "push" for t in options) else None
    same = [t for t in options if t.kind == "pick_place" and t.grasp == action.grasp]
    if same:
        return action
    pp = [t for t in options if t.kind == "pick_place"]
    return pp[0].action(action.block, action.from_, action.to) if pp else None


def _merged(ctx: PlanContext, state: dict[int, Pose2D], block: int, start: Pose2D,
            end: Pose2D) -> Action | None:
    others = {b: p for b, p in state.items() if b != block}
    options = [t for t in direct_transfers(ctx, others, start, end) if not t.hits]
    return options[0].action(block, start, end) if options else None


def _replay(ctx: PlanContext, state: dict[int, Pose2D], actions: list[Action]
            ) -> list[Action] | None:
    """Re-check ``actions`` from ``state`` (updated in place); None if one fails."""
    out = []
    for a in actions:
        if state[a.block].distance_to(a.from_) > 1e-9:
            return None
        redo = _redo(ctx, state, a)
        if redo is None:
            return None
        out.append(redo)
        state[a.block] = redo.to
    return out


def _try_merge(ctx: PlanContext, start: dict[int, Pose2D], actions: list[Action], i: int,
               j: int) -> list[Action] | None:
    a, b = actions[i], actions[j]
    state = dict(start)
    for act in actions[:i]:
        state[act.block] = act.to
    between = actions[i + 1:j]
    if a.from_.distance_to(b.to) < 1e-9 and abs(a.from_.theta - b.to.theta) < 1e-9:
        # moved away and back: drop both if the block may stay put meanwhile
        rest = _replay(ctx, dict(state), between)
        return None if rest is None else [*actions[:i], *rest, *actions[j + 1:]]
    # (1) go straight to the final pose at the first move
    early = _merged(ctx, state, a.block, a.from_, b.to)
    if early is not None:
        s1 = dict(state)
        s1[a.block] = b.to
        rest = _replay(ctx, s1, between)
        if rest is not None:
            return [*actions[:i], early, *rest, *actions[j + 1:]]
    # (2) stay put until the second move
    rest = _replay(ctx, dict(state), between)
    if rest is not None:
        s2 = dict(state)
        for act in rest:
            s2[act.block] = act.to
        late = _merged(ctx, s2, a.block, a.from_, b.to)
        if late is not None:
            return [*actions[:i], *rest, late, *actions[j + 1:]]
    return None


def shortcut(ctx: PlanContext, start: dict[int, Pose2D], actions: list[Action]) -> list[Action]:
    """``actions`` with same-block move pairs merged wherever possible."""
    actions = list(actions)
    changed = True
    while changed:
        changed = False
        for i, a in enumerate(actions):
            j = next((k for k in range(i + 1, len(actions)) if actions[k].block == a.block),
                     None)
            if j is None:
                continue
            merged = _try_merge(ctx, start, actions, i, j)
            if merged is not None:
                actions, changed = merged, True
                break
    return actions
