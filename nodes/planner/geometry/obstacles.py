"""Bulk collision queries of the planner: fixed and movable blocks, as bit masks.

Footprints (blocks, grasping fingers, pushes) come from ``msgs_py.footprint``: rectangles,
vectorised over K poses. ``Obstacles`` answers bulk collision queries in numpy: bounding
boxes first, then the separating-axis test on the pairs left (how deep two rectangles
interpenetrate along their four edge normals), and for the few that barely do, the area they
share (more than ``OVERLAP_AREA_TOL``, as ``msgs_py.footprint.overlapping_pairs`` decides:
footprints that only touch, a zero gap in a dense grid, do not collide). A query separates
*fixed* blocks (placed, not in O_R: any overlap forbids the action) from *movable* ones (in
O_R: overlaps are allowed and counted, Nc), the latter as a bit mask over the scene's block
ids so that the union of the blocks hit along a path is a bitwise OR and Nc a popcount. A mask
is a row of ``words(n)`` uint64 words (bit b of the set is bit b % 64 of word b // 64), so a
scene may hold any number of blocks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely

from msgs_py.cell import INSIDE_TOL, OVERLAP_AREA_TOL
from msgs_py.footprint import to_polygons

WORD = 64
#: Rectangles that interpenetrate by more than this (m) along all their axes overlap...
DEEP = 1e-3
#: ... those that do not by this much are apart or touch; in between (a corner poking in),
#: they overlap when the area they share exceeds OVERLAP_AREA_TOL, as for ``msgs_py``.
SHALLOW = 1e-9
#: Shape-obstacle pairs tested per numpy batch (memory).
BATCH_PAIRS = 2_000_000


def words(n_bits: int) -> int:
    """uint64 words a mask of ``n_bits`` bits needs (at least one)."""
    return max(1, -(-n_bits // WORD))


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

    def clipped(self, other: Bounds) -> Bounds:
        """The part of this region inside ``other`` (empty regions keep x_min <= x_max)."""
        x_min, y_min = max(self.x_min, other.x_min), max(self.y_min, other.y_min)
        return Bounds(x_min, max(x_min, min(self.x_max, other.x_max)),
                      y_min, max(y_min, min(self.y_max, other.y_max)))

    def lattice(self, size: float, step: float, max_points: int) -> np.ndarray:
        """Centres (K, 2) of a lattice ``step`` apart whose squares of side ``size`` lie
        inside, row-major from (x_min, y_min); the step widened (by the square root of the
        excess) where it would hold more than ``max_points``, so memory is bounded before
        anything is built on it."""
        span_x = max(self.x_max - self.x_min - size, 0.0)
        span_y = max(self.y_max - self.y_min - size, 0.0)
        count = (span_x / step + 1.0) * (span_y / step + 1.0)
        if count > max_points:
            step *= math.sqrt(count / max_points) * (1.0 + 1e-9)
        xs = np.arange(self.x_min + 0.5 * size, self.x_max - 0.5 * size + 1e-9, step)
        ys = np.arange(self.y_min + 0.5 * size, self.y_max - 0.5 * size + 1e-9, step)
        return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)

    def contains(self, corners: np.ndarray) -> np.ndarray:
        """Whether all four corners of each ``corners[..., 4, 2]`` shape lie inside."""
        x, y = corners[..., 0], corners[..., 1]
        ok = ((x >= self.x_min - INSIDE_TOL) & (x <= self.x_max + INSIDE_TOL)
              & (y >= self.y_min - INSIDE_TOL) & (y <= self.y_max + INSIDE_TOL))
        return ok.all(axis=-1)


class Obstacles:
    """The blocks an action may hit, split into fixed and movable, for bulk queries.

    Args:
        ids: block id of each obstacle.
        corners: their footprints (n, 4, 2).
        movable: which of them are in O_R.
        bit_of: block id -> bit index in the movable masks (shared by a whole plan).
        n_words: words per mask (default: enough for the largest bit in ``bit_of``).
    """

    def __init__(self, ids: Sequence[int], corners: np.ndarray, movable: Sequence[bool],
                 bit_of: dict[int, int], n_words: int | None = None) -> None:
        self.ids = np.asarray(ids, dtype=np.int64)
        self.corners = np.asarray(corners, dtype=float).reshape(-1, 4, 2)
        self.box = _boxes(self.corners)
        self.frames = frames(self.corners)
        self.movable = np.asarray(movable, dtype=bool).reshape(-1)
        self.n_words = n_words or words(max(bit_of.values(), default=-1) + 1)
        self.bits = np.zeros((len(self.ids), self.n_words), dtype=np.uint64)
        for k, (i, m) in enumerate(zip(self.ids, self.movable, strict=True)):
            if m:
                bit = bit_of[int(i)]
                self.bits[k, bit // WORD] = np.uint64(1) << np.uint64(bit % WORD)

    def _pairs(self, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        """(shape index, obstacle index) of every overlapping pair."""
        flat = np.asarray(corners, dtype=float).reshape(-1, 4, 2)
        n = len(self.corners)
        if n == 0 or len(flat) == 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty, len(flat)
        box, shape_frames = _boxes(flat), frames(flat)
        lefts, rights = [], []
        step = max(1, BATCH_PAIRS // n)
        for start in range(0, len(flat), step):
            b = box[start:start + step]
            near = ((b[:, None, 0] < self.box[None, :, 2]) & (b[:, None, 2] > self.box[None, :, 0])
                    & (b[:, None, 1] < self.box[None, :, 3])
                    & (b[:, None, 3] > self.box[None, :, 1]))
            left, right = np.nonzero(near)
            left = left + start
            depth = penetration(shape_frames[left], self.frames[right])
            hit = depth > DEEP
            maybe = np.flatnonzero((depth > SHALLOW) & ~hit)
            if len(maybe):
                shared = shapely.area(shapely.intersection(
                    to_polygons(flat[left[maybe]]), to_polygons(self.corners[right[maybe]])))
                hit[maybe] = shared > OVERLAP_AREA_TOL
            lefts.append(left[hit])
            rights.append(right[hit])
        return np.concatenate(lefts), np.concatenate(rights), len(flat)

    def query(self, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Collisions of shapes ``corners`` (K, m, 4, 2): any m-part counts for its row.

        Returns:
            fixed_hit (K,) bool: the row overlaps a fixed block.
            movable_mask (K, W) uint64: bits of the movable blocks the row overlaps.
        """
        rows = corners.shape[0]
        parts = int(np.prod(corners.shape[1:-2], dtype=np.int64))
        left, right, _ = self._pairs(corners)
        row = left // max(parts, 1)
        fixed = np.zeros(rows, dtype=bool)
        fixed[row[~self.movable[right]]] = True
        mask = np.zeros((rows, self.n_words), dtype=np.uint64)
        mov = self.movable[right]
        np.bitwise_or.at(mask, row[mov], self.bits[right[mov]])
        return fixed, mask

    def fixed_ids_hit(self, corners: np.ndarray) -> list[int]:
        """Ids of the fixed blocks overlapped by any of the shapes (for failure reports)."""
        _, right, _ = self._pairs(corners)
        return sorted({int(self.ids[r]) for r in right if not self.movable[r]})


def _boxes(corners: np.ndarray) -> np.ndarray:
    """Bounding boxes (K, 4): x_min, y_min, x_max, y_max of shapes (K, 4, 2)."""
    return np.concatenate([corners.min(axis=1), corners.max(axis=1)], axis=1)


def frames(corners: np.ndarray) -> np.ndarray:
    """Rectangles (K, 4, 2), corners in order round them, as (K, 2, 5): per coordinate the
    centre, the two edges from corner 0 and their unit directions (``penetration``'s input,
    computed once per shape rather than once per pair)."""
    centre = 0.5 * (corners[:, 0] + corners[:, 2])
    e1 = corners[:, 1] - corners[:, 0]
    e2 = corners[:, 2] - corners[:, 1]
    l1 = np.hypot(e1[:, 0], e1[:, 1])[:, None]
    l2 = np.hypot(e2[:, 0], e2[:, 1])[:, None]
    u1 = e1 / np.where(l1 > 0.0, l1, 1.0)
    u2 = e2 / np.where(l2 > 0.0, l2, 1.0)
    return np.stack([centre, e1, e2, u1, u2], axis=-1)


def penetration(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """How deep the rectangles a and b (P, 2, 5 ``frames``, pairwise) interpenetrate (m): the
    least overlap of their projections on the four edge directions (<= 0: apart or
    touching). A projection is the centre's +- half the edges' projected lengths, so two
    intervals overlap by min(ra + rb - |centre distance|, 2 ra, 2 rb)."""
    axes = np.concatenate([a[:, :, 3:5], b[:, :, 3:5]], axis=-1)  # (P, 2, 4)
    ax, ay = axes[:, 0], axes[:, 1]

    def radius(f: np.ndarray) -> np.ndarray:
        return 0.5 * (np.abs(f[:, 0, 1:2] * ax + f[:, 1, 1:2] * ay)
                      + np.abs(f[:, 0, 2:3] * ax + f[:, 1, 2:3] * ay))
    ra, rb = radius(a), radius(b)
    d = b[:, :, 0] - a[:, :, 0]
    apart = np.abs(d[:, 0:1] * ax + d[:, 1:2] * ay)
    return np.minimum(ra + rb - apart, 2.0 * np.minimum(ra, rb)).min(axis=-1)


def mask_to_int(mask: np.ndarray) -> int:
    """One mask (W,) as a Python int (bit b of the set is bit b of the int)."""
    return sum(int(w) << (WORD * k) for k, w in enumerate(np.asarray(mask).reshape(-1)))


def mask_to_ids(mask: np.ndarray, ids_by_bit: Sequence[int]) -> list[int]:
    """Block ids whose bits are set in ``mask`` (W,), in bit order."""
    value = mask_to_int(mask)
    return [ids_by_bit[b] for b in range(len(ids_by_bit)) if value >> b & 1]


def mask_to_bools(masks: np.ndarray, n_bits: int) -> np.ndarray:
    """Masks (..., W) as booleans (..., n_bits): entry b is bit b."""
    masks = np.ascontiguousarray(masks, dtype=np.uint64)
    bits = np.unpackbits(masks.view(np.uint8), axis=-1, bitorder="little")
    return bits[..., :n_bits].astype(bool)


def popcount(masks: np.ndarray) -> np.ndarray:
    """Bits set per mask (..., W) -> (...)."""
    return np.bitwise_count(masks).sum(axis=-1, dtype=np.int64)
