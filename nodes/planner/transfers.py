"""One-action transfers between two poses, as a pure function of the occupied poses.

For planners that reason about many (block, slot) pairs at once, like the unlabeled planner
of issue 7 (pebble graphs): given the blocks standing around (``occupied``, some of them
movable), can a block at ``start`` reach ``end`` in one pick-and-place (which grasps) or one
push, which movable blocks would it hit, and at what cost (same cost model as the roadmap)?
Multi-action routes for one block come from ``roadmap.plan_route`` with the same inputs.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from msgs_py import Pose2D
from msgs_py.footprint import block_corners, face_normals, grasp_finger_corners, push_corners
from nodes.planner.context import PlanContext, State
from nodes.planner.geometry import mask_to_ids
from nodes.planner.roadmap import LINE_TOL, MIN_PUSH


@dataclass(frozen=True)
class DirectTransfer:
    """A feasible one-action move: ``kind`` "pick_place" (with ``grasp``) or "push"."""

    kind: str
    grasp: int | None
    hits: tuple[int, ...]  # movable blocks in the way (Nc = len)
    cost: float


def direct_transfers(ctx: PlanContext, occupied: State, start: Pose2D, end: Pose2D,
                     movable: Iterable[int] = ()) -> list[DirectTransfer]:
    """Every single action taking a block from ``start`` to ``end`` among ``occupied``.

    ``occupied`` must not contain the moving block itself. Blocks in ``movable`` may be hit
    (listed in ``hits``); any other overlap rules the action out. Sorted by cost.
    """
    cfg, geom = ctx.config, ctx.geom
    obstacles = ctx.obstacles(occupied, exclude=(), movable=movable)
    ids_by_bit = list(ctx.ids)
    moved = math.hypot(end.x - start.x, end.y - start.y)
    per_m = cfg.a_dist if cfg.distance_cost else 0.0
    out: list[DirectTransfer] = []
    end_block = block_corners(end.x, end.y, end.theta, geom.block_size)[None]
    b_fixed, b_mask = obstacles.query(end_block[:, None])
    if ctx.workspace.contains(end_block)[0] and not b_fixed[0]:
        pick = grasp_finger_corners(geom, start.x, start.y, start.theta, np.arange(2))
        place = grasp_finger_corners(geom, end.x, end.y, end.theta, np.arange(2))
        p_fixed, p_mask = obstacles.query(pick)
        q_fixed, q_mask = obstacles.query(place)
        inside = ctx.table.contains(pick).all(-1) & ctx.table.contains(place).all(-1)
        for g in range(2):
            if p_fixed[g] or q_fixed[g] or not inside[g]:
                continue
            hits = mask_to_ids(int(p_mask[g] | q_mask[g] | b_mask[0]), ids_by_bit)
            out.append(DirectTransfer("pick_place", g, tuple(hits),
                                cfg.a1 + cfg.a3 * len(hits) + per_m * moved))
    same_yaw = abs(math.remainder(end.theta - start.theta, 2 * math.pi)) < 1e-9
    if same_yaw and moved > MIN_PUSH:
        v = np.array([end.x - start.x, end.y - start.y])
        for d in face_normals(start.theta):
            if abs(v[0] * d[1] - v[1] * d[0]) < LINE_TOL and v @ d > 0:
                sweep = push_corners(geom, start.x, start.y, d[0], d[1], moved)[None]
                fixed, mask = obstacles.query(sweep)
                inside = (ctx.workspace.contains(sweep[:, 0])[0]
                          and ctx.table.contains(sweep[:, 1:]).all())
                if not fixed[0] and inside:
                    hits = mask_to_ids(int(mask[0]), ids_by_bit)
                    extra = (cfg.a_dist + cfg.a_push_len) * moved if cfg.distance_cost else 0.0
                    out.append(DirectTransfer("push", None, tuple(hits),
                                        cfg.a2 + cfg.a3 * len(hits) + extra))
    return sorted(out, key=lambda t: (t.cost, t.kind, t.grasp or 0))
