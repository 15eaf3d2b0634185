"""Where a tag's corners are on a block, and the planar block pose that best fits them.

docs/contracts.md: the 36h11 tag's black square (40.0 mm) is centred on the block's top
face (z = s); OpenCV's corner order (top-left, top-right, bottom-right, bottom-left of the
upright tag image) is block-local (-20, +20), (+20, +20), (+20, -20), (-20, -20) mm.
"""

from __future__ import annotations

import math

import numpy as np

from msgs_py import BlockPose
from msgs_py.cell import BLOCK_SIZE, TAG_SIZE

TAG_FAMILY = "36h11"

#: Block-local (x, y) of the tag corners in OpenCV order, m.
TAG_CORNERS_LOCAL = 0.5 * TAG_SIZE * np.array(
    [[-1.0, 1.0], [1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]]
)


def rotation_2d(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def local_to_world_xy(x: float, y: float, theta: float, local_xy: np.ndarray) -> np.ndarray:
    """Block-local points (N x 2, m) to world (x, y) for a block at (x, y, theta)."""
    return np.asarray(local_xy, dtype=float) @ rotation_2d(theta).T + np.array([x, y])


def tag_corners_world(block: BlockPose, block_size: float = BLOCK_SIZE,
                      tag_size: float = TAG_SIZE) -> np.ndarray:
    """The 4 tag corners (4 x 3, m, OpenCV order) of a block resting on the table."""
    local = TAG_CORNERS_LOCAL * (tag_size / TAG_SIZE)
    xy = local_to_world_xy(block.x, block.y, block.theta, local)
    return np.column_stack([xy, np.full(4, block_size)])


def fit_planar_pose(world_xy: np.ndarray, local_xy: np.ndarray = TAG_CORNERS_LOCAL,
                    weights: np.ndarray | None = None) -> tuple[float, float, float]:
    """Least-squares rigid 2-D fit (no scale) of local points onto world points.

    The closed form of the 2-D Procrustes problem: the rotation is the angle of the summed
    cross-covariance, the translation matches the (weighted) centroids.

    Returns:
        (x, y, theta) of the block-local origin in world, m and rad.
    """
    world_xy = np.asarray(world_xy, dtype=float)
    local_xy = np.asarray(local_xy, dtype=float)
    w = np.ones(len(world_xy)) if weights is None else np.asarray(weights, dtype=float)
    w = w / w.sum()
    cw, cl = w @ world_xy, w @ local_xy
    a, b = local_xy - cl, world_xy - cw
    dot = float(np.sum(w * (a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])))
    cross = float(np.sum(w * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])))
    theta = math.atan2(cross, dot)
    origin = cw - rotation_2d(theta) @ cl
    return float(origin[0]), float(origin[1]), theta
