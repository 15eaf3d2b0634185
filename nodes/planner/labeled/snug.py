"""Buffer poses packed against what is already there, for crowded scenes.

At density 0.4 random draws almost never land a block where it and a grasp's fingers fit
(in a 49-block scene, 59 of 93,000 lattice poses do at the start): the free room lies in
slivers beside the blocks and along the workspace's edges. ``snug_poses`` proposes exactly
those: a block beside each other block, face to face at ``SNUG_GAP``, level with it or half a
block along its face, and blocks flush with each side of the workspace (the fingers may reach
over the table margin), at the workspace's yaw and at the goal yaw. The caller tests them
like any other candidate.
"""

from __future__ import annotations

import numpy as np

from msgs_py.footprint import face_normals
from nodes.planner.geometry.context import PlanContext, State

#: Gap (m) left between a snug pose and the block it stands beside: the grid's 3 mm plus a
#: millimetre for the place's spread.
SNUG_GAP = 0.004
#: Offsets along a neighbour's face, in block sizes.
ALONG = (-0.5, 0.0, 0.5)
#: Spacing (block sizes) of the poses along each side of the workspace.
EDGE_STEP = 0.5


def snug_poses(ctx: PlanContext, state: State, exclude: int, yaws: tuple[float, ...] = (0.0,)
               ) -> np.ndarray:
    """(K, 3) poses beside every block of ``state`` but ``exclude`` and along the workspace's
    edges (at each of ``yaws``), not yet tested for collisions."""
    s = ctx.geom.block_size
    others = np.array([[p.x, p.y, p.theta] for b, p in state.items() if b != exclude])
    out = [_beside(others, s)] if len(others) else []
    out.append(_along_edges(ctx, s, yaws))
    return np.concatenate(out)


def _beside(poses: np.ndarray, s: float) -> np.ndarray:
    normals = face_normals(poses[:, 2])  # (K, 4, 2)
    tangents = np.stack([-normals[..., 1], normals[..., 0]], axis=-1)
    parts = []
    for along in ALONG:
        xy = (poses[:, None, :2] + normals * (s + SNUG_GAP) + tangents * (along * s))
        parts.append(np.concatenate([xy.reshape(-1, 2),
                                     np.repeat(poses[:, 2], 4)[:, None]], axis=1))
    return np.concatenate(parts)


def _along_edges(ctx: PlanContext, s: float, yaws: tuple[float, ...]) -> np.ndarray:
    w = ctx.workspace
    half = 0.5 * s + 0.001
    xs = np.arange(w.x_min + half, w.x_max - half + 1e-9, EDGE_STEP * s)
    ys = np.arange(w.y_min + half, w.y_max - half + 1e-9, EDGE_STEP * s)
    xy = np.concatenate([
        np.column_stack([xs, np.full(len(xs), w.y_min + half)]),
        np.column_stack([xs, np.full(len(xs), w.y_max - half)]),
        np.column_stack([np.full(len(ys), w.x_min + half), ys]),
        np.column_stack([np.full(len(ys), w.x_max - half), ys])])
    return np.concatenate([np.column_stack([xy, np.full(len(xy), yaw)]) for yaw in yaws])
