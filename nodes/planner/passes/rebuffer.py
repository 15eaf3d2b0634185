"""Plan rebuffering: a block moved out of the way and later onto a push line into its goal
goes to such a push line (or straight to its goal) in one move.

In a cramped workspace pIRS clears a blocking block to wherever there is room at that moment,
often a corner; later the block is moved again onto a push line into its slot and pushed in:
three actions where two would do if the first move had chosen a pose on that push line. By
the time the plan is complete it is known which blocks move when, so the buffer can be chosen
with hindsight: for two consecutive moves of a block (``S -> A``, then ``A -> B``, maybe
followed by ``B -> G``), try one move ``S -> X`` instead, made before any of the other
blocks' actions that lay between the two, where ``X`` is the block's next end ``G`` itself
(the two or three moves become one) or a pose on a push line into ``G`` (the push then starts
from ``X``). Everything the other blocks do meanwhile is replayed with the block at ``X``
(``shortcut``'s checks: no contact with any block), so a merge is kept only when the whole
plan stays feasible; the independent replay validator still checks the result. The
``shortcut`` pass tries the first and the last of these moments with ``X = B``; this pass adds
the moments in between and the other buffers. Greedy and deterministic: earliest pair first,
until nothing merges.
"""

from __future__ import annotations

import numpy as np

from msgs_py import Pose2D, Push
from msgs_py.actions import Action
from msgs_py.footprint import face_normals
from nodes.planner.geometry.context import PlanContext
from nodes.planner.passes.shortcut import _merged, _replay

#: Distances (block sizes) from the goal at which a buffer on a push line into it is tried.
LINE_STEPS = (0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0)
#: Most actions from a block's first move to its last one merged: every moment in between is
#: tried with a replay of the rest, so the cost grows with the square of the window (a long
#: plan of many blocks would spend seconds here; in a 9-block plan every window fits).
MAX_WINDOW = 24


def line_buffers(ctx: PlanContext, goal: Pose2D) -> list[Pose2D]:
    """Poses on the four push lines into ``goal`` (same yaw), nearest first, no farther than
    the longest push the planner samples."""
    size = ctx.geom.block_size
    steps = [k * size for k in LINE_STEPS if k * size <= ctx.config.push_max_distance]
    normals = face_normals(goal.theta)
    return [Pose2D(goal.x - n[0] * d, goal.y - n[1] * d, goal.theta)
            for d in steps for n in np.asarray(normals)]


def _state_at(start: dict[int, Pose2D], actions: list[Action], i: int) -> dict[int, Pose2D]:
    state = dict(start)
    for act in actions[:i]:
        state[act.block] = act.to
    return state


def _moves(actions: list[Action], block: int, after: int) -> list[int]:
    return [k for k in range(after, len(actions)) if actions[k].block == block]


def _buffers(ctx: PlanContext, end: Pose2D, pushed: bool) -> list[tuple[Pose2D, bool]]:
    """(buffer, whether a last move from it to ``end`` follows): ``end`` itself, and when
    the block's last move is a push into ``end`` (``pushed``) the poses on push lines into
    it."""
    if not pushed:
        return [(end, False)]
    return [(end, False)] + [(x, True) for x in line_buffers(ctx, end)]


def _try(ctx: PlanContext, start: dict[int, Pose2D], actions: list[Action], p: int, q: int,
         r: int | None) -> list[Action] | None:
    """Moves p and q (and r when a push, see ``_buffers``) of one block replaced by a move to
    a buffer at some moment between p and q (and the push from it); None if none fits."""
    block, origin = actions[p].block, actions[p].from_
    pushed = r is not None and isinstance(actions[r], Push) and r - q <= MAX_WINDOW
    between, last = actions[p + 1:q], (r if pushed else q)
    after = actions[q + 1:last]
    final_state = _state_at(start, actions, last)  # where the others stand before the end
    end = actions[last].to
    options = []
    for x, then in _buffers(ctx, end, pushed):
        if x.distance_to(origin) < 1e-9:
            continue
        if then:
            final_state[block] = x
            if _merged(ctx, final_state, block, x, end) is None:
                continue  # the last move from x is ruled out whenever the move is made
        options.append((x, then))
    if not options:
        return None
    state = _state_at(start, actions, p)
    done: list[Action] = []
    for t in range(len(between) + 1):
        if t:
            step = _replay(ctx, state, [between[t - 1]])
            if step is None:
                return None  # the block must be out of the way by then
            done += step
        found = _from_moment(ctx, state, block, origin, options, between[t:] + after, end)
        if found is not None:
            return [*actions[:p], *done, *found, *actions[last + 1:]]
    return None


def _from_moment(ctx: PlanContext, state: dict[int, Pose2D], block: int, origin: Pose2D,
                 options: list[tuple[Pose2D, bool]], rest: list[Action], end: Pose2D
                 ) -> list[Action] | None:
    """The move to the first buffer of ``options`` that works from ``state``, the others'
    ``rest`` replayed with the block there, and the last move from it to ``end``."""
    for x, then in options:
        move = _merged(ctx, state, block, origin, x)
        if move is None:
            continue
        s = {**state, block: x}
        replayed = _replay(ctx, s, rest)
        if replayed is None:
            continue
        if not then:
            return [move, *replayed]
        last = _merged(ctx, s, block, x, end)
        if last is not None:
            return [move, *replayed, last]
    return None


def rebuffer(ctx: PlanContext, start: dict[int, Pose2D], actions: list[Action]
             ) -> list[Action]:
    """``actions`` with consecutive moves of a block merged through a better buffer wherever
    the plan allows (see the module docstring)."""
    actions = list(actions)
    p = 0
    while p < len(actions):
        nxt = _moves(actions, actions[p].block, p + 1)
        if not nxt or nxt[0] - p > MAX_WINDOW:
            p += 1
            continue
        merged = _try(ctx, start, actions, p, nxt[0], nxt[1] if len(nxt) > 1 else None)
        if merged is None:
            p += 1
        else:
            actions = merged  # try the same index again: its block may merge further
    return actions
