"""What frees a block the chain of clears cannot free, and what shuts one in for good.

Two situations of crowded scenes (49 random blocks at density 0.4) that pIRS's clearing alone
does not get out of:

* **A freeing nudge of a held neighbour** (``freeing_nudges``). A block to clear that no
  grasp reaches where it stands, because its fingers land on blocks the search holds in place
  for this move (the block whose way is being cleared, and the blocks of the clearing chain
  above it): clearing the chain's blocks first is what the chain is trying to do, so the
  search goes round in a circle (A's way blocked by B, B's grasp covered by A). The move a
  person makes is a short push (``roadmap.NUDGE_LENGTHS``) of the held neighbour away from
  the block, into room that is free, after which a grasp of the block fits; the chain then
  plans the neighbour's own move again from where it now stands. Only a push that touches no
  other block and frees a grasp is offered, fewest movable blocks under the freed grasp
  first, then shortest. Placed blocks are never nudged (they stay on their goal).
* **A block shut in by placed blocks** (``shut_in``). pIRS never moves a placed block, so a
  block off its goal whose every grasp and every push (``frozen.PROBE_PUSH``: a push of any
  length sweeps at least that) is blocked by placed blocks, or leaves the table or the reach,
  can never reach its goal: the placement that did that is a dead end (checked for blocks
  near the block just placed, where before it they could still move). Without it, a block
  cleared onto a pending slot early in a 49-block scene (random 0.4, seed 15) was walled in
  by its neighbours' placements and the search spent its budget reordering the last blocks.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping

import numpy as np

from msgs_py import Pose2D, Push
from msgs_py.footprint import block_corners, face_normals, grasp_finger_corners, push_corners
from nodes.planner.bounds.frozen import PROBE_PUSH
from nodes.planner.geometry.context import PlanContext, State
from nodes.planner.geometry.obstacles import Obstacles, popcount
from nodes.planner.geometry.transfer import GRASPS, grasp_checks, push_checks
from nodes.planner.labeled.pirs import Route
from nodes.planner.labeled.roadmap import NUDGE_LENGTHS

#: Centre distance (block sizes) within which a neighbour can cover a grasp of a block (a
#: block's half diagonal, a finger's clearance and thickness, the other's half diagonal).
NEAR = 2.2
#: Freeing nudges offered per block (best first).
MAX_NUDGES = 3


def _near(ctx: PlanContext, state: State, centre: Pose2D, blocks: Collection[int]
          ) -> list[int]:
    limit = NEAR * ctx.geom.block_size
    return [b for b in sorted(blocks)
            if np.hypot(state[b].x - centre.x, state[b].y - centre.y) < limit]


def freeing_nudges(ctx: PlanContext, block: int, state: State, held: Collection[int],
                   movable: Collection[int]) -> list[tuple[int, Route]]:
    """Short pushes of a ``held`` neighbour after which ``block`` has a grasp whose fingers
    land on no block but ``movable`` ones (module docstring): (neighbour, its one-push route),
    best first; none where ``block`` has such a grasp already."""
    here = state[block]
    pose = np.array([[here.x, here.y, here.theta]])
    others = ctx.obstacles(state, exclude=(block,), movable=movable)
    if grasp_checks(ctx, others, pose).fingers_ok[0].any():
        return []
    geom = ctx.geom
    fingers = grasp_finger_corners(geom, here.x, here.y, here.theta, GRASPS).reshape(2, 2, 4, 2)
    found: list[tuple[tuple[int, float], int, Route]] = []
    for h in _near(ctx, state, here, held):
        # the grasps of ``block`` once ``h`` is gone, as they stand against every other block
        without = grasp_checks(ctx, ctx.obstacles(state, exclude=(block, h), movable=movable),
                               pose)
        if not without.fingers_ok[0].any():
            continue  # something other than h covers every grasp
        start = state[h]
        normals = np.repeat(face_normals(start.theta), len(NUDGE_LENGTHS), axis=0)
        lengths = np.tile(np.array(NUDGE_LENGTHS), 4)
        starts = np.repeat([[start.x, start.y, start.theta]], len(lengths), axis=0)
        ok, _ = push_checks(ctx, ctx.obstacles(state, exclude=(h,), movable=()), starts,
                            normals, lengths)
        ends = starts[:, :2] + normals * lengths[:, None]
        moved = block_corners(ends[:, 0], ends[:, 1], np.full(len(ends), start.theta),
                              geom.block_size)
        for k in np.flatnonzero(ok):
            at = Obstacles([0], moved[k][None], [False], {})
            covered, _ = at.query(fingers)  # (2,): h, nudged, still under grasp g
            free = without.fingers_ok[0] & ~covered
            if not free.any():
                continue
            hits = min(int(popcount(without.fingers_hit[0, g])) for g in np.flatnonzero(free))
            end = Pose2D(float(ends[k, 0]), float(ends[k, 1]), start.theta)
            region = push_corners(geom, start.x, start.y, normals[k, 0], normals[k, 1],
                                  lengths[k]).reshape(-1, 4, 2)
            route = Route((Push.between(h, start, end),), (), ctx.cost.push(lengths[k]), end,
                          region)
            found.append(((hits, float(lengths[k])), h, route))
    found.sort(key=lambda f: f[0])
    return [(h, route) for _, h, route in found[:MAX_NUDGES]]


def _stuck(ctx: PlanContext, state: State, blocks: list[int], fixed: Collection[int]
           ) -> np.ndarray:
    """Which ``blocks`` have no grasp and no probing push free of the ``fixed`` blocks (the
    only obstacles), the table and the reach."""
    if not blocks:
        return np.zeros(0, dtype=bool)
    poses = np.array([[state[b].x, state[b].y, state[b].theta] for b in blocks])
    walls = ctx.obstacles({b: state[b] for b in fixed}, exclude=(), movable=())
    grasp = grasp_checks(ctx, walls, poses).fingers_ok.any(-1)
    normals = face_normals(poses[:, 2]).reshape(-1, 2)
    push, _ = push_checks(ctx, walls, np.repeat(poses, 4, axis=0), normals,
                          np.full(len(normals), PROBE_PUSH))
    return ~grasp & ~push.reshape(-1, 4).any(-1)


def shut_in(ctx: PlanContext, goals: Mapping[int, Pose2D], block: int, before: State,
            after: State, placed: Collection[int], off_goal: Collection[int]) -> list[int]:
    """The blocks of ``off_goal`` (to move yet) near ``block``'s pose in ``after`` that
    ``block`` placed there shuts in: stuck (``_stuck``) with the ``placed`` blocks (before
    it) and ``block`` standing, not stuck with the placed blocks alone."""
    cand = [b for b in _near(ctx, after, after[block], off_goal) if b != block and b in goals]
    if not cand:
        return []
    now = _stuck(ctx, after, cand, [*placed, block])
    cand = [b for b, s in zip(cand, now, strict=True) if s]
    if not cand:
        return []
    was = _stuck(ctx, before, cand, [b for b in placed if b != block])
    return [b for b, s in zip(cand, was, strict=True) if not s]
