"""Footprints in the table plane: blocks, grasping fingers, pushes, and the overlap test.

The planar model of docs/contracts.md, shared by the scene checks, the planner
and the executor. Everything is vectorised over K poses: functions return corner arrays of
shape (K, ..., 4, 2) (rectangles, counter-clockwise), and ``overlapping_pairs`` answers bulk
queries with one shapely STRtree query. Footprints that only touch (a zero gap in a dense
grid) do not overlap: an overlap must exceed ``OVERLAP_AREA_TOL``.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Polygon

from msgs_py.cell import OVERLAP_AREA_TOL, GripperGeometry


def rect_corners(cx, cy, yaw, length, width) -> np.ndarray:
    """Corners (..., 4, 2) of rectangles centred at (cx, cy), ``length`` along ``yaw``."""
    cx, cy, yaw, length, width = np.broadcast_arrays(*(np.asarray(v, float) for v in
                                                       (cx, cy, yaw, length, width)))
    c, s = np.cos(yaw), np.sin(yaw)
    hl, hw = 0.5 * length, 0.5 * width
    out = np.empty((*cx.shape, 4, 2))
    for k, (u, v) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        lx, ly = u * hl, v * hw
        out[..., k, 0] = cx + c * lx - s * ly
        out[..., k, 1] = cy + s * lx + c * ly
    return out


def block_corners(x, y, theta, block_size: float) -> np.ndarray:
    """Block footprints (K, 4, 2): squares of side ``block_size`` at (x, y, theta)."""
    return rect_corners(x, y, theta, block_size, block_size)


def block_polygon(x: float, y: float, theta: float, side: float) -> Polygon:
    """One block's footprint as a shapely polygon."""
    return Polygon(block_corners(x, y, theta, side))


def to_polygons(corners: np.ndarray) -> np.ndarray:
    """Shapely polygons (shape corners[..., 0, 0]) from rectangle corners."""
    flat = corners.reshape(-1, 4, 2)
    return shapely.polygons(flat).reshape(corners.shape[:-2])


def overlapping_pairs(tree: shapely.STRtree, polygons: np.ndarray, corners: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(shape index, tree index) of the shapes (K, 4, 2) that overlap a tree polygon by more
    than OVERLAP_AREA_TOL: shapes that only touch (a 0-area intersection) do not collide."""
    geoms = to_polygons(corners)
    left, right = tree.query(geoms, predicate="intersects")
    if len(left):
        area = shapely.area(shapely.intersection(geoms[left], polygons[right]))
        real = area > OVERLAP_AREA_TOL
        left, right = left[real], right[real]
    return left, right


def overlapping_blocks(corners: np.ndarray) -> list[tuple[int, int]]:
    """Index pairs (i < j) of the footprints (K, 4, 2) of one set whose interiors overlap."""
    corners = np.asarray(corners, dtype=float).reshape(-1, 4, 2)
    if len(corners) < 2:
        return []
    polygons = to_polygons(corners)
    left, right = overlapping_pairs(shapely.STRtree(polygons), polygons, corners)
    return sorted((int(i), int(j)) for i, j in zip(left, right, strict=True) if i < j)


def grasp_finger_corners(geom: GripperGeometry, x, y, theta, grasp) -> np.ndarray:
    """The two finger pads (K, 2, 4, 2) of grasp 0/1 on blocks at (x, y, theta).

    The closing axis is at yaw theta + grasp * pi/2; each pad is ``finger_thickness`` along it
    and ``finger_width`` across, centred at +-finger_offset from the block centre.
    """
    x, y, theta, grasp = np.broadcast_arrays(*(np.asarray(v, float) for v in (x, y, theta, grasp)))
    axis = theta + grasp * (0.5 * math.pi)
    ax, ay = np.cos(axis), np.sin(axis)
    r = geom.finger_offset
    pads = [rect_corners(x + sign * r * ax, y + sign * r * ay, axis, geom.finger_thickness,
                         geom.finger_width) for sign in (1.0, -1.0)]
    return np.stack(pads, axis=-3)


def face_normals(theta) -> np.ndarray:
    """The four face normals (K, 4, 2) of blocks at yaw theta: theta + k pi/2, k = 0..3."""
    angles = np.asarray(theta, float)[..., None] + 0.5 * math.pi * np.arange(4)
    return np.stack([np.cos(angles), np.sin(angles)], axis=-1)


def push_corners(geom: GripperGeometry, x, y, dx, dy, distance) -> np.ndarray:
    """Swept areas (K, 3, 4, 2) of a push: the block, then the two fingertips.

    The block (yaw along the unit push direction d, a face normal) slides from p1 to
    p1 + d * distance. The TCP descends at p1 - d (s/2 + push_contact_depth + finger_width/2)
    and travels d * (distance + push_contact_depth); each fingertip is ``finger_thickness``
    across d and ``finger_width`` along it, at +-(push_opening/2 + finger_thickness/2)
    across d, so its sweep is a rectangle of length distance + depth + finger_width.
    """
    x, y, dx, dy, distance = np.broadcast_arrays(
        *(np.asarray(v, float) for v in (x, y, dx, dy, distance)))
    s = geom.block_size
    yaw = np.arctan2(dy, dx)
    block = rect_corners(x + 0.5 * distance * dx, y + 0.5 * distance * dy, yaw, s + distance, s)
    back = 0.5 * s + geom.push_contact_depth + 0.5 * geom.finger_width
    travel = distance + geom.push_contact_depth
    tx = x - back * dx + 0.5 * travel * dx
    ty = y - back * dy + 0.5 * travel * dy
    across = 0.5 * geom.push_opening + 0.5 * geom.finger_thickness
    nx, ny = -dy, dx
    length = travel + geom.finger_width
    pads = [rect_corners(tx + sign * across * nx, ty + sign * across * ny, yaw, length,
                         geom.finger_thickness) for sign in (1.0, -1.0)]
    return np.stack([block, *pads], axis=-3)
