"""Plan re-insertion: take every move of one block out of a plan and put back the fewest.

pIRS decides where a block goes one clear at a time, so in a cramped workspace a block is often
moved three to five times (cleared to a corner, cleared again, put on a push line, pushed).
With the plan complete, what the other blocks do is known; the block's moves are removed (the
others' actions stay feasible: one block fewer only frees room) and the fewest moves that fit
between the others' actions are found by a shortest path over (how many of the others' actions
are done, where the block stands), with a fixed set of candidate poses: its start, every pose
it takes in the plan (so the old moves are a path), its goal, poses on the push lines into its
goal, and a lattice of poses at the goal's yaw over the workspace. The block waits at a pose
through the others' next action only where that action's footprints (the fingers of its grasp
at both ends, the block it sets down, a push's swept area) miss it; it moves by a pick-and-
place with a free grasp at both ends or by a straight push, the others standing where they are.
``rebuffer`` changes two moves of a block at a time; this pass changes all of them at once.
Every changed plan is kept only if the replay validator accepts it.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Mapping

import numpy as np

from msgs_py import Pose2D, Push
from msgs_py.actions import Action
from msgs_py.footprint import block_corners, grasp_finger_corners, push_corners
from nodes.planner.geometry.obstacles import Obstacles, mask_to_bools, words
from nodes.planner.geometry.transfer import grasp_checks, pick_place_between, push_checks, push_line
from nodes.planner.passes.rebuffer import line_buffers

#: Spacing (block sizes) of the lattice of buffer poses (at the goal's yaw) tried.
LATTICE_STEP = 0.5
#: Most lattice poses: the pass tests every pair of candidates per moment, so its time grows
#: with the square of this (a 0.9 m square workspace, 16 blocks at density 0.05, has 1296 at
#: 0.5 block sizes; a wider workspace gets a coarser lattice).
LATTICE_MAX = 1300
INF = np.inf
#: Longest plan re-inserted (9 blocks at density 0.3 take 14-18 actions, 16 blocks 25-30).
MAX_ACTIONS = 40


def _regions(ctx, act: Action) -> np.ndarray:
    """Everything an action needs free (m, 4, 2): its grasp's fingers where it picks and
    where it places (as the validator), the block where it lands; for a push, the swept
    area and the fingertips."""
    g, a, b = ctx.geom, act.from_, act.to
    if isinstance(act, Push):
        d = act.direction
        return push_corners(g, np.array([a.x]), np.array([a.y]), np.array([d[0]]),
                            np.array([d[1]]), np.array([act.distance]))[0]
    fingers = grasp_finger_corners(g, np.array([[a.x], [b.x]]), np.array([[a.y], [b.y]]),
                                   np.array([[a.theta], [b.theta]]), np.array([act.grasp]))
    land = block_corners([b.x], [b.y], [b.theta], g.block_size)
    return np.concatenate([fingers.reshape(-1, 4, 2), land])


class _Layers:
    """Per moment i (the others' first i actions done): where the block may stand, and its
    one-action moves between candidate poses: pick-and-places between any two, pushes only
    onto the first ``push_ends`` (the poses the block takes in the plan: pushes checked
    between every pair lined up on the lattice would cost most of the time)."""

    def __init__(self, ctx, cand: np.ndarray, start: Mapping[int, Pose2D],
                 others: list[Action], push_ends: int) -> None:
        self.ctx, self.cand = ctx, cand
        p = len(cand)
        feet = block_corners(cand[:, 0], cand[:, 1], cand[:, 2], ctx.geom.block_size)
        self.mine = Obstacles(list(range(p)), feet, [True] * p, {k: k for k in range(p)},
                              words(p))
        on, d, length = push_line(np.repeat(cand, p, axis=0), np.tile(cand, (p, 1)))
        on &= length <= ctx.config.push_max_distance
        on &= np.tile(np.arange(p) < push_ends, p)  # pushes end on the block's own poses
        self.pairs = np.flatnonzero(on)
        self.d, self.length = d[self.pairs], length[self.pairs]
        self.carry = ctx.reach.segment(cand[:, None, :2], cand[None, :, :2])
        self.states = [dict(start)]
        for act in others:
            self.states.append({**self.states[-1], act.block: act.to})
        self.others = others

    def wait_ok(self, i: int) -> np.ndarray:
        """Candidates the others' action i (0-based) does not touch."""
        hit = self.mine.query(_regions(self.ctx, self.others[i])[None])[1]
        return ~mask_to_bools(hit, len(self.cand))[0]

    def moves(self, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """At moment i: stand (P,), free grasp axis per pose (P,) (-1: none), and the
        one-action moves (P, P): 1 pick-and-place, 2 push, 0 none."""
        ctx, cand, p = self.ctx, self.cand, len(self.cand)
        obstacles = ctx.obstacles(self.states[i], exclude=(), movable=())
        grasps = grasp_checks(ctx, obstacles, cand)
        stand = grasps.block_ok
        axis = np.where(grasps.fingers_ok.any(-1), np.argmax(grasps.fingers_ok, -1), -1)
        kind = np.zeros((p, p), dtype=np.int8)
        kind[np.ix_(axis >= 0, (axis >= 0) & stand)] = 1
        kind &= self.carry.astype(np.int8)
        if len(self.pairs):
            u, v = self.pairs // p, self.pairs % p
            ok, _ = push_checks(ctx, obstacles, cand[u], self.d, self.length)
            ok &= stand[v]
            kind[u[ok], v[ok]] = 2
        np.fill_diagonal(kind, 0)
        return stand, axis, kind


def _shortest(layers: _Layers, n_moments: int, source: int, target: int
              ) -> list[tuple[int, int, int, int]] | None:
    """Fewest moves (moment, from, to, kind) from ``source`` at moment 0 to ``target`` at the
    last moment, or None: breadth-first per moment over all poses at once (numpy), waits
    carrying the counts to the next moment, then walked back."""
    p = len(layers.cand)
    info = [layers.moves(i) for i in range(n_moments + 1)]
    arrived = np.full(p, INF)  # moves needed to stand at each pose, before moving at moment i
    arrived[source] = 0
    after: list[np.ndarray] = []
    befores: list[np.ndarray] = []
    for i in range(n_moments + 1):
        stand, _, kind = info[i]
        arrived = np.where(stand, arrived, INF)
        befores.append(arrived)
        dist = _closure(arrived, kind > 0)
        after.append(dist)
        if i < n_moments:
            arrived = np.where(layers.wait_ok(i), dist, INF)
    if after[-1][target] == INF:
        return None
    return _walk_back(info, befores, after, n_moments, target)


def _closure(dist: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Least moves to each pose when any number of one-action moves may follow."""
    dist = dist.copy()
    while True:
        step = np.where(edges, dist[:, None] + 1, INF).min(axis=0)
        better = step < dist
        if not better.any():
            return dist
        dist = np.minimum(dist, step)


def _walk_back(info, befores, after, moment: int, node: int
               ) -> list[tuple[int, int, int, int]]:
    moves = []
    while True:
        d = after[moment][node]
        if d == 0 and moment == 0:
            return moves[::-1]
        if befores[moment][node] == d:
            moment -= 1
            continue
        kind = info[moment][2]
        u = int(np.flatnonzero((kind[:, node] > 0) & (after[moment] == d - 1))[0])
        moves.append((moment, u, node, int(kind[u, node])))
        node = u


def reinsert_block(ctx, start: Mapping[int, Pose2D], actions: list[Action], block: int
                   ) -> list[Action] | None:
    """``actions`` with ``block``'s moves replaced by the fewest found, or None if no fewer."""
    mine = [a for a in actions if a.block == block]
    others = [a for a in actions if a.block != block]
    end = mine[-1].to
    poses = [start[block]] + [a.to for a in mine] + line_buffers(ctx, end)
    cand = np.array([[q.x, q.y, q.theta] for q in poses])
    cand = np.concatenate([cand, _lattice(ctx, end.theta)])
    layers = _Layers(ctx, cand, {b: q for b, q in start.items() if b != block}, others,
                     len(mine) + 1)
    target = len(mine)  # index of ``end`` in ``poses``
    moves = _shortest(layers, len(others), 0, target)
    if moves is None or len(moves) >= len(mine):
        return None
    return _realize(layers, block, start[block], end, others, moves)


def _lattice(ctx, yaw: float) -> np.ndarray:
    """Poses on a lattice over the workspace at ``yaw``, every block inside it."""
    size = ctx.geom.block_size
    xy = ctx.workspace.lattice(size, LATTICE_STEP * size, LATTICE_MAX)
    return np.column_stack([xy, np.full(len(xy), yaw)])


def _realize(layers: _Layers, block: int, here: Pose2D, end: Pose2D, others: list[Action],
             moves: list[tuple[int, int, int, int]]) -> list[Action]:
    out: list[Action] = []
    k = 0
    for i, act in enumerate([*others, None]):
        while k < len(moves) and moves[k][0] == i:
            _, u, v, kind = moves[k]
            to = Pose2D(*layers.cand[v]) if k < len(moves) - 1 else end
            if kind == 2:
                step: Action = Push.between(block, here, to)
            else:
                _, axis, _ = layers.moves(i)
                step = pick_place_between(block, here, layers.cand[u][2], to, int(axis[u]),
                                          int(axis[v]))
            out.append(step)
            here = step.to
            k += 1
        if act is not None:
            out.append(act)
    return out


def reinsert(ctx, start: Mapping[int, Pose2D], actions: list[Action],
             valid: Callable[[list[Action]], bool], blocks: set[int] | None = None
             ) -> list[Action]:
    """Re-insert, most-moved first, every block moved more than once (of ``blocks``), keeping
    each change the validator accepts. Plans longer than ``MAX_ACTIONS`` are left as they are:
    the cost grows with the moments times the candidate poses (a 100-block plan would spend
    tens of seconds here)."""
    if len(actions) > MAX_ACTIONS:
        return actions
    counts = Counter(a.block for a in actions)
    for block, moved in sorted(counts.items(), key=lambda kv: (-kv[1], kv[0])):
        if moved < 2 or (blocks is not None and block not in blocks):
            continue
        better = reinsert_block(ctx, start, actions, block)
        if better is not None and valid(better):
            actions = better
    return actions


__all__ = ["reinsert", "reinsert_block"]
