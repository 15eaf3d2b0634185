"""An assembly order for the goal layout, found by disassembly.

A goal slot is *enterable* given a set of fixed (already placed) slots when the block can be
set down on it with some grasp, or pushed into it along a face normal from a pose where it can
be set down, without the fingers or the swept block touching a fixed block. Removing blocks
only ever frees space, so peeling off every enterable slot of the full layout, round after
round, is a complete test for this relaxation, and the reverse of the peeling is an order in
which each block can still get in when its turn comes (dense grids: centre first, then ring by
ring outwards). pIRS tries blocks in this order instead of by id; blocks a round cannot peel
(walled in for good) are reported up front.
"""

from __future__ import annotations

import math

import numpy as np

from msgs_py import Pose2D
from nodes.planner.context import PlanContext
from nodes.planner.geometry import (
    Obstacles,
    block_corners,
    face_normals,
    grasp_finger_corners,
    push_corners,
)

#: Push lengths (in block sizes) tried when testing whether a slot can be pushed into.
PUSH_STEPS = (0.1, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0)


def enterable(ctx: PlanContext, slots: dict[int, Pose2D], fixed: set[int],
              candidates: list[int]) -> dict[int, bool]:
    """For each candidate slot, whether its block can get in with ``fixed`` slots filled."""
    geom = ctx.geom
    out: dict[int, bool] = {}
    steps = np.array(PUSH_STEPS) * geom.block_size
    for c in candidates:
        ids = sorted(fixed - {c})
        poses = [slots[i] for i in ids]
        corners = block_corners([p.x for p in poses], [p.y for p in poses],
                                [p.theta for p in poses], geom.block_size).reshape(-1, 4, 2)
        obstacles = Obstacles(ids, corners, [False] * len(ids), {i: 0 for i in ids})
        goal = slots[c]
        fingers = grasp_finger_corners(geom, goal.x, goal.y, goal.theta, np.arange(2))
        hit, _ = obstacles.query(fingers)
        if np.any(~hit & ctx.table.contains(fingers).all(-1)):
            out[c] = True
            continue
        normals = face_normals(goal.theta)
        d = np.repeat(normals, len(steps), axis=0)
        length = np.tile(steps, 4)
        qx, qy = goal.x - d[:, 0] * length, goal.y - d[:, 1] * length
        sweep = push_corners(geom, qx, qy, d[:, 0], d[:, 1], length)
        s_hit, _ = obstacles.query(sweep)
        s_in = ctx.workspace.contains(sweep[:, 0]) & ctx.table.contains(sweep[:, 1:]).all(-1)
        q_fingers = grasp_finger_corners(geom, qx[:, None], qy[:, None], goal.theta,
                                         np.arange(2))
        q_hit, _ = obstacles.query(q_fingers.reshape(-1, 2, 4, 2))
        q_ok = (~q_hit.reshape(-1, 2) & ctx.table.contains(q_fingers).all(-1)).any(-1)
        out[c] = bool(np.any(~s_hit & s_in & q_ok))
    return out


def assembly_layers(ctx: PlanContext, slots: dict[int, Pose2D]) -> tuple[dict[int, int], list[int]]:
    """Layer of each block (0 = place first) and the blocks no disassembly round frees.

    Args:
        slots: goal pose by block id.
    """
    remaining = set(slots)
    rounds: list[list[int]] = []
    while remaining:
        free = enterable(ctx, slots, remaining, sorted(remaining))
        peel = [b for b in sorted(remaining) if free[b]]
        if not peel:
            break
        rounds.append(peel)
        remaining -= set(peel)
    layers = {b: len(rounds) - 1 - r for r, peel in enumerate(rounds) for b in peel}
    return layers, sorted(remaining)


def slot_distance_key(slots: dict[int, Pose2D]) -> dict[int, float]:
    """Distance of each slot from the layout's centroid (ties inside a layer: inner first)."""
    if not slots:
        return {}
    cx = sum(p.x for p in slots.values()) / len(slots)
    cy = sum(p.y for p in slots.values()) / len(slots)
    return {b: math.hypot(p.x - cx, p.y - cy) for b, p in slots.items()}
