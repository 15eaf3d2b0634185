"""Where to set down a block found in the fingers (after an executor restart, say).

The executor does not know how it came to hold the block, only that the fingers stopped at
a block's width. It sets the block down at the free spot nearest where it wants it: block
and both fingers (closing axis at the tool's yaw) clear of every perceived block by a
margin, the block in the workspace, the fingers on the table.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import shapely

from msgs_py import Pose2D, Workspace
from msgs_py.cell import BLOCK_SIZE, TABLE_MARGIN, GripperGeometry
from msgs_py.footprint import block_corners, grasp_finger_corners, to_polygons

#: Finger gap (m) that means "holding a block": the pads stopped on a cube of the contract's
#: BLOCK_SIZE (open for a grasp is the block + 2 x clearance, closed on nothing is 0, a push
#: 20 mm). Other block sizes scale it.
HOLDING_GAP = (0.040, 0.058)


def holds_block(finger_gap: float | None, block_size: float = BLOCK_SIZE) -> bool:
    if finger_gap is None:
        return False
    lo, hi = (g * block_size / BLOCK_SIZE for g in HOLDING_GAP)
    return lo <= finger_gap <= hi


def free_spot(
    perceived: Mapping[int, Pose2D],
    workspace: Workspace,
    geo: GripperGeometry,
    tool_yaw: float,
    near: tuple[float, float],
    table_margin: float = TABLE_MARGIN,
    margin: float = 0.008,
    step: float = 0.01,
) -> Pose2D | None:
    """The candidate pose nearest ``near`` where block and fingers are clear, or None."""
    xs = np.arange(workspace.x_min, workspace.x_max + 1e-9, step)
    ys = np.arange(workspace.y_min, workspace.y_max + 1e-9, step)
    gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
    order = np.argsort(np.hypot(gx - near[0], gy - near[1]), kind="stable")
    gx, gy = gx[order], gy[order]
    yaw = np.full_like(gx, tool_yaw)
    blocks = block_corners(gx, gy, yaw, geo.block_size)
    fingers = grasp_finger_corners(geo, gx, gy, yaw, np.zeros_like(gx))
    inside = _inside(blocks, workspace, 0.0) & _inside(fingers, workspace, table_margin).all(-1)
    if not perceived:
        hits = np.zeros(len(gx), dtype=bool)
    else:
        p = np.array([[q.x, q.y, q.theta] for q in perceived.values()])
        obstacles = shapely.buffer(to_polygons(block_corners(p[:, 0], p[:, 1], p[:, 2],
                                                             geo.block_size)), margin)
        tree = shapely.STRtree(obstacles)
        shapes = np.concatenate([to_polygons(blocks)[:, None], to_polygons(fingers)], axis=1)
        hit_rows, _ = tree.query(shapes.ravel(), predicate="intersects")
        hits = np.zeros(shapes.size, dtype=bool)
        hits[hit_rows] = True
        hits = hits.reshape(shapes.shape).any(axis=1)
    ok = np.flatnonzero(inside & ~hits)
    if ok.size == 0:
        return None
    k = ok[0]
    return Pose2D(float(gx[k]), float(gy[k]), float(tool_yaw))


def _inside(corners: np.ndarray, ws: Workspace, grow: float) -> np.ndarray:
    x, y = corners[..., 0], corners[..., 1]
    ok = ((x >= ws.x_min - grow) & (x <= ws.x_max + grow)
          & (y >= ws.y_min - grow) & (y <= ws.y_max + grow))
    return ok.all(axis=-1)
