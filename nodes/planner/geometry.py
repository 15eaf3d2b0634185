"""Planar geometry of blocks and two-finger gripper footprints (DESIGN §6, docs/contracts.md).

Everything is vectorised over K poses: functions return corner arrays of shape (K, ..., 4, 2)
(rectangles, counter-clockwise) and ``Obstacles`` answers bulk collision queries with one
shapely STRtree query. A query separates *fixed* blocks (placed, not in O_R: any overlap
forbids the action) from *movable* ones (in O_R: overlaps are allowed and counted, Nc), the
latter as a bit mask over the scene's block ids so that the union of the blocks hit along a
path is a bitwise OR and Nc a popcount.

Footprints that only touch (a zero gap) do not collide: an overlap must exceed
``OVERLAP_AREA_TOL``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from nodes.planner.config import PlannerConfig

#: Overlap area (m^2) below which two footprints count as touching (1 um x 1 mm sliver).
OVERLAP_AREA_TOL = 1e-9
#: Containment slack (m) for corners computed in floating point.
INSIDE_TOL = 1e-9
#: Most blocks a scene may hold: movable-block sets are uint64 bit masks.
MAX_BLOCKS = 64


@dataclass(frozen=True, slots=True)
class GripperGeometry:
    """Block and finger dimensions (m) the footprints are built from."""

    block_size: float
    finger_thickness: float
    finger_width: float
    approach_clearance: float
    push_opening: float
    push_contact_depth: float

    @classmethod
    def from_config(cls, config: PlannerConfig, block_size: float) -> GripperGeometry:
        return cls(block_size, config.finger_thickness, config.finger_width,
                   config.approach_clearance, config.push_opening, config.push_contact_depth)

    @classmethod
    def from_params(cls, params: Mapping[str, Any]) -> GripperGeometry:
        """From a plan's ``params`` (DESIGN §5); entries it lacks take the planner defaults."""
        base = cls.from_config(PlannerConfig(), float(params.get("block_size", 0.0508)))
        given = {f.name: float(params[f.name]) for f in dataclasses.fields(cls)
                 if f.name in params}
        return dataclasses.replace(base, **given)

    @property
    def approach_opening(self) -> float:
        """Finger gap while a grasp descends: clearance on both sides of the block."""
        return self.block_size + 2.0 * self.approach_clearance

    @property
    def finger_offset(self) -> float:
        """Grasp: distance from the block centre to each finger's centre, along the axis."""
        return 0.5 * self.block_size + self.approach_clearance + 0.5 * self.finger_thickness


@dataclass(frozen=True, slots=True)
class Bounds:
    """Axis-aligned region (m): the workspace for blocks, the table for fingers."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float

    def grown(self, margin: float) -> Bounds:
        return Bounds(self.x_min - margin, self.x_max + margin,
                      self.y_min - margin, self.y_max + margin)

    def contains(self, corners: np.ndarray) -> np.ndarray:
        """Whether all four corners of each ``corners[..., 4, 2]`` shape lie inside."""
        x, y = corners[..., 0], corners[..., 1]
        ok = ((x >= self.x_min - INSIDE_TOL) & (x <= self.x_max + INSIDE_TOL)
              & (y >= self.y_min - INSIDE_TOL) & (y <= self.y_max + INSIDE_TOL))
        return ok.all(axis=-1)


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


def block_corners(x, y, theta, block_size: float) -> np.ndarray:
    """Block footprints (K, 4, 2)."""
    return rect_corners(x, y, theta, block_size, block_size)


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


class Obstacles:
    """The blocks an action may hit, split into fixed and movable, for bulk queries.

    Args:
        ids: block id of each obstacle.
        corners: their footprints (n, 4, 2).
        movable: which of them are in O_R.
        bit_of: block id -> bit index in the movable masks (shared by a whole plan).
    """

    def __init__(self, ids: Sequence[int], corners: np.ndarray, movable: Sequence[bool],
                 bit_of: dict[int, int]) -> None:
        self.ids = np.asarray(ids, dtype=np.int64)
        self.polygons = to_polygons(np.asarray(corners).reshape(-1, 4, 2))
        self.movable = np.asarray(movable, dtype=bool).reshape(-1)
        self.bits = np.array([np.uint64(1) << np.uint64(bit_of[int(i)]) if m else 0
                              for i, m in zip(self.ids, self.movable, strict=True)],
                             dtype=np.uint64)
        self.tree = shapely.STRtree(self.polygons)

    def _pairs(self, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        flat = corners.reshape(-1, 4, 2)
        if len(self.polygons) == 0 or len(flat) == 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty, len(flat)
        left, right = overlapping_pairs(self.tree, self.polygons, flat)
        return left, right, len(flat)

    def query(self, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Collisions of shapes ``corners`` (K, m, 4, 2): any m-part counts for its row.

        Returns:
            fixed_hit (K,) bool: the row overlaps a fixed block.
            movable_mask (K,) uint64: bits of the movable blocks the row overlaps.
        """
        rows = corners.shape[0]
        parts = int(np.prod(corners.shape[1:-2], dtype=np.int64))
        left, right, _ = self._pairs(corners)
        row = left // max(parts, 1)
        fixed = np.zeros(rows, dtype=bool)
        fixed[row[~self.movable[right]]] = True
        mask = np.zeros(rows, dtype=np.uint64)
        mov = self.movable[right]
        np.bitwise_or.at(mask, row[mov], self.bits[right[mov]])
        return fixed, mask

    def fixed_ids_hit(self, corners: np.ndarray) -> list[int]:
        """Ids of the fixed blocks overlapped by any of the shapes (for failure reports)."""
        _, right, _ = self._pairs(corners)
        return sorted({int(self.ids[r]) for r in right if not self.movable[r]})


def mask_to_ids(mask: int, ids_by_bit: Sequence[int]) -> list[int]:
    """Block ids whose bits are set in ``mask``."""
    mask = int(mask)
    return [ids_by_bit[b] for b in range(len(ids_by_bit)) if mask >> b & 1]


def popcount(masks: np.ndarray) -> np.ndarray:
    return np.bitwise_count(masks).astype(np.int64)
