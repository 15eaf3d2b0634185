"""Where the robot covers the camera's image, from its joints: which tags it hides.

A real cell looks while it works: at every frame the arm's pose is known (its joint states at
the frame's stamp), so the part of the image the arm and the gripper cover is known too. Each
solid of ``nodes.robot.body`` is convex, so its image under a pinhole camera is the convex
hull of its projected corners (a lens's distortion bends that hull by far less than the
margin). The silhouette is the union of those hulls, grown by ``margin_px`` for what the
model leaves out (joint states a few milliseconds off the frame, the calibration's error, a
real arm's cables and rounded covers).

A tag is *covered* when its square, grown by the same margin, meets the silhouette: its
corners cannot be trusted (a finger over one side bends the fitted edge), so it is not
judged from this frame. Pure geometry: the projection is injected (``project_fn``: world
points (n, 3) -> pixels (n, 2)), so the detector and the executor use it with their own
camera models.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import MultiPoint, Polygon
from shapely.geometry.base import BaseGeometry

from msgs_py.cell import FINGER_THICKNESS, FINGER_WIDTH
from nodes.robot.body import posed_solids, surface_points

ProjectFn = Callable[[np.ndarray], np.ndarray]

#: Default growth of the silhouette and of a tag's square (px): at the cell's 1.25 m and
#: 1400 px focal length, 5 px is about 4 mm on the table. The sim's robot is these solids, so
#: with no margin every tag a segmentation render shows the arm hiding is covered (and 222 of
#: 223 it shows whole are not); a real arm differs from them by its cables and covers: raise
#: it there (config/real/).
MARGIN_PX = 5.0
#: A point closer than this in front of the camera (m) cannot be projected sensibly: the
#: robot then counts as covering the whole image.
MIN_DEPTH_M = 0.05


@dataclass(frozen=True)
class Silhouette:
    """The image region the robot covers (pixels, grown by the margin), or everything."""

    region: BaseGeometry
    everything: bool = False

    def covers(self, square_px: np.ndarray, margin_px: float = MARGIN_PX) -> bool:
        """Whether the robot covers any of the quadrilateral ``square_px`` ((4, 2) pixels)
        grown by ``margin_px``."""
        if self.everything:
            return True
        if self.region.is_empty:
            return False
        quad = Polygon(np.asarray(square_px, float)).convex_hull.buffer(margin_px)
        return bool(self.region.intersects(quad))


def robot_silhouette(q: Sequence[float], gap: float, project_fn: ProjectFn,
                     depth_fn: Callable[[np.ndarray], np.ndarray] | None = None,
                     margin_px: float = MARGIN_PX) -> Silhouette:
    """The image region the arm at joints ``q`` with the fingers ``gap`` apart covers.

    ``depth_fn`` (world points -> their depth along the camera's axis, m) guards against
    points at or behind the camera; without it every point is taken to be in front."""
    hulls = []
    for solid, pose in posed_solids(q, gap, FINGER_THICKNESS, FINGER_WIDTH):
        points = surface_points(solid, pose)
        if depth_fn is not None and float(np.min(depth_fn(points))) < MIN_DEPTH_M:
            return Silhouette(Polygon(), everything=True)
        pixels = np.asarray(project_fn(points), float)
        if not np.all(np.isfinite(pixels)):
            return Silhouette(Polygon(), everything=True)
        hulls.append(MultiPoint(pixels).convex_hull)
    region = shapely.union_all(hulls).buffer(margin_px)
    return Silhouette(region)


def top_square(x: float, y: float, theta: float, side: float, z: float) -> np.ndarray:
    """(4, 3) world corners of a horizontal square of ``side`` centred at (x, y, z), turned
    by ``theta`` about z (a tag on a block's top face: z = the block's size)."""
    c, s, h = np.cos(theta), np.sin(theta), side / 2
    local = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    xy = local @ np.array([[c, s], [-s, c]]) + (x, y)
    return np.column_stack([xy, np.full(4, z)])
