"""Square footprints of blocks on the table and the overlap test used by validation.

A cube's footprint is a square of side ``s`` centred on the block pose. Two footprints that
only touch (a zero gap in a dense grid) do not overlap: the test uses a small area tolerance.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Polygon

#: Intersection area (m^2) below which two footprints count as touching, not overlapping.
#: 1e-9 m^2 is a 1 um sliver along a 1 mm edge: far below any physical meaning.
OVERLAP_AREA_TOL = 1e-9


def square_corners(x: float, y: float, theta: float, side: float) -> np.ndarray:
    """Corners (4x2, counter-clockwise) of a square of ``side`` at pose (x, y, theta)."""
    half = 0.5 * side
    c, s = math.cos(theta), math.sin(theta)
    local = np.array([[-half, -half], [half, -half], [half, half], [-half, half]])
    rot = np.array([[c, -s], [s, c]])
    return local @ rot.T + np.array([x, y])


def square_polygon(x: float, y: float, theta: float, side: float) -> Polygon:
    return Polygon(square_corners(x, y, theta, side))


def overlapping_pairs(polygons: list[Polygon]) -> list[tuple[int, int]]:
    """Index pairs (i < j) whose interiors overlap by more than ``OVERLAP_AREA_TOL``."""
    if len(polygons) < 2:
        return []
    tree = shapely.STRtree(polygons)
    left, right = tree.query(polygons, predicate="intersects")
    pairs = []
    for i, j in zip(left.tolist(), right.tolist(), strict=True):
        if i < j and polygons[i].intersection(polygons[j]).area > OVERLAP_AREA_TOL:
            pairs.append((i, j))
    return sorted(pairs)
