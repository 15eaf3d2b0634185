"""Blocks that no plan can ever move: a certificate that a scene has no plan.

A block moves only by a pick-and-place (the fingers of one grasp free where it stands) or a
push (the fingertips behind one face and the sweep ahead free). Both need room around the
block, and other blocks only ever take room away, so whether a block *could* move if every
block that can ever move had gone away is monotone. ``frozen_blocks`` computes that closure:
take every block that can move with the other remaining blocks as obstacles (a pick with
some grasp, or a push of one millimetre along some face normal: any longer push sweeps a
superset), remove all of them, repeat until none can. The blocks left can never move, in any
plan: the first of them to move would have to do so with at least the other left blocks still
standing where they started (and maybe more), and with only those it cannot. If one of them
is not on its goal, the scene has no plan (with these fingers and straight pushes); the
planner says so at once instead of searching until its budget runs out.

Example: a 3x3 grid with 3 mm gaps and one empty slot that is not the centre (a ``permuted``
scene): the blocks beside the hole that have the outside opposite it can leave, and then
nothing else can (every block left has a block on two adjacent sides and at most one free
side on each axis).

``locked_blocks`` is the weaker, practical sibling: the blocks that cannot be *taken away*
(picked where they stand, or nudged by a short push and then picked) even after every block
that can has gone. No order exists in which a two-finger gripper could have set them down, so
a scene generator must not make such a start; it is no proof of "no plan" (a chain of
millimetre pushes might still free them), but a search that fails on such a start names them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from msgs_py import Pose2D
from msgs_py.footprint import face_normals
from nodes.planner.geometry.context import PlanContext, State, at_pose
from nodes.planner.geometry.obstacles import Obstacles, mask_to_int
from nodes.planner.geometry.transfer import grasp_checks, push_checks
from nodes.planner.labeled.roadmap import NUDGE_LENGTHS

#: Length of the probing push (m): a push of any length sweeps at least this.
PROBE_PUSH = 5e-3


def _grasp_options(ctx: PlanContext, state: State
                   ) -> tuple[list[int], Obstacles, np.ndarray, list[list[int]]]:
    """The blocks of ``state`` (ids), all of them as movable obstacles, their poses (K, 3),
    and per block the masks (as ints) of the other blocks each grasp usable where it stands
    would hit."""
    ids = [b for b in ctx.ids if b in state]
    obstacles = ctx.obstacles(state, exclude=(), movable=ids)
    poses = np.array([[state[b].x, state[b].y, state[b].theta] for b in ids]).reshape(-1, 3)
    grasps = grasp_checks(ctx, obstacles, poses)
    masks = [[mask_to_int(grasps.fingers_hit[k, g]) & ~(1 << ctx.bit_of[b])
              for g in range(2) if grasps.fingers_ok[k, g]] for k, b in enumerate(ids)]
    return ids, obstacles, poses, masks


def move_options(ctx: PlanContext, state: State) -> dict[int, list[int]]:
    """Per block, the masks (as ints) of the other blocks each of its moves would hit: one
    per grasp whose fingers are otherwise usable, one per push direction otherwise feasible.
    A block can move when some mask holds no block that is still standing."""
    ids, obstacles, poses, masks = _grasp_options(ctx, state)
    if not ids:
        return {}
    normals = face_normals(poses[:, 2]).reshape(-1, 2)  # (K*4, 2)
    starts = np.repeat(poses, 4, axis=0)
    push_ok, push_hit = push_checks(ctx, obstacles, starts, normals,
                                    np.full(len(starts), PROBE_PUSH))
    for k, b in enumerate(ids):
        own = ~(1 << ctx.bit_of[b])
        masks[k] += [mask_to_int(push_hit[4 * k + d]) & own
                     for d in range(4) if push_ok[4 * k + d]]
    return dict(zip(ids, masks, strict=True))


def take_options(ctx: PlanContext, state: State) -> dict[int, list[int]]:
    """Per block, the masks (as ints) of the other blocks each way of taking it away would
    hit: one per grasp usable where it stands, one per nudge (a push of ``NUDGE_LENGTHS``
    along a face normal, as the roadmap offers them) and grasp usable where it ends."""
    ids, obstacles, poses, masks = _grasp_options(ctx, state)
    if not ids:
        return {}
    per_block = 4 * len(NUDGE_LENGTHS)
    starts = np.repeat(poses, per_block, axis=0)
    normals = np.repeat(face_normals(poses[:, 2]).reshape(-1, 2), len(NUDGE_LENGTHS), axis=0)
    lengths = np.tile(np.array(NUDGE_LENGTHS), 4 * len(ids))
    push_ok, push_hit = push_checks(ctx, obstacles, starts, normals, lengths)
    ends = np.column_stack([starts[:, :2] + normals * lengths[:, None], starts[:, 2]])
    after = grasp_checks(ctx, obstacles, ends)
    for k, b in enumerate(ids):
        own = ~(1 << ctx.bit_of[b])
        for j in range(k * per_block, (k + 1) * per_block):
            if push_ok[j]:
                masks[k] += [(mask_to_int(push_hit[j]) | mask_to_int(after.fingers_hit[j, g]))
                             & own for g in range(2) if after.fingers_ok[j, g]]
    return dict(zip(ids, masks, strict=True))


def frozen_blocks(ctx: PlanContext, state: State) -> list[int]:
    """The blocks of ``state`` that no sequence of actions can ever move (module docstring)."""
    return _peeled(ctx, move_options(ctx, state))


def locked_blocks(ctx: PlanContext, state: State) -> list[int]:
    """The blocks of ``state`` that cannot be taken away (picked, or nudged and picked) even
    with every block that can gone (module docstring)."""
    return _peeled(ctx, take_options(ctx, state))


def _peeled(ctx: PlanContext, options: dict[int, list[int]]) -> list[int]:
    """What is left after removing, round after round, every block with an option that hits
    no block still standing."""
    standing = {b: 1 << ctx.bit_of[b] for b in options}
    left = sum(standing.values())
    while True:
        free = [b for b in standing if any(not m & left for m in options[b])]
        if not free:
            return sorted(standing)
        for b in free:
            left &= ~standing.pop(b)


#: How a failure names frozen blocks.
FROZEN_WHY = (f"can never be freed: no grasp and no push of {PROBE_PUSH * 1e3:.0f} mm or more "
              "moves them even with every block that can move gone")


#: How a failure names locked blocks.
LOCKED_WHY = ("are locked where they start: no grasp fits them and no nudge of "
              f"{NUDGE_LENGTHS[0] * 1e3:.0f}-{NUDGE_LENGTHS[-1] * 1e3:.0f} mm frees one, even "
              "with every block that can be taken away gone (no gripper could have set them "
              "down so)")


def frozen_off_goal(ctx: PlanContext, start: State, goals: Mapping[int, Pose2D],
                    yaw_exact: bool) -> list[int]:
    """The frozen blocks (``frozen_blocks``) that have a goal and are not on it."""
    cfg = ctx.config
    return [b for b in frozen_blocks(ctx, start) if b in goals and not at_pose(
        start[b], goals[b], cfg.goal_tolerance_xy, cfg.goal_tolerance_yaw, yaw_exact)]
