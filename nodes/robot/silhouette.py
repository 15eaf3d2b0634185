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
from shapely.geometry import Polygon
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


def robot_hulls(q: Sequence[float], gap: float, project_fn: ProjectFn,
                depth_fn: Callable[[np.ndarray], np.ndarray] | None = None
                ) -> list[BaseGeometry] | None:
    """The image of each of the robot's solids at joints ``q`` (fingers ``gap`` apart): the
    convex hull of its projected corners; None when a point lies too near or behind the
    camera (the robot then covers the whole image).

    ``depth_fn`` (world points -> their depth along the camera's axis, m) guards against
    points at or behind the camera; without it every point is taken to be in front."""
    solids = [surface_points(solid, pose)
              for solid, pose in posed_solids(q, gap, FINGER_THICKNESS, FINGER_WIDTH)]
    points = np.concatenate(solids)  # every solid at once: one projection, one hull call
    if depth_fn is not None and float(np.min(depth_fn(points))) < MIN_DEPTH_M:
        return None
    pixels = np.asarray(project_fn(points), float)
    if not np.all(np.isfinite(pixels)):
        return None
    which = np.repeat(np.arange(len(solids)), [len(p) for p in solids])
    return list(shapely.convex_hull(shapely.multipoints(pixels, indices=which)))


def robot_silhouette(q: Sequence[float], gap: float, project_fn: ProjectFn,
                     depth_fn: Callable[[np.ndarray], np.ndarray] | None = None,
                     margin_px: float = MARGIN_PX) -> Silhouette:
    """The image region the arm at joints ``q`` with the fingers ``gap`` apart covers: the
    union of its solids' hulls (``robot_hulls``) grown by ``margin_px``."""
    hulls = robot_hulls(q, gap, project_fn, depth_fn)
    if hulls is None:
        return Silhouette(Polygon(), everything=True)
    return Silhouette(shapely.union_all(hulls).buffer(margin_px))


def hulls_cover(hulls: list[BaseGeometry] | None, squares_px: Sequence[np.ndarray],
                margin_px: float = MARGIN_PX) -> list[bool]:
    """Per quadrilateral of ``squares_px`` ((4, 2) pixels each): whether a hull comes within
    twice ``margin_px`` of it, i.e. what ``Silhouette.covers`` says with both grown by the
    margin, without building the union and the buffers (the executor asks this for dozens
    of arm poses before each look). Round growth, where the buffers are polygons inscribed
    in it: at the margin's edge this says covered where ``covers`` may not, never the
    other way. ``hulls`` None: the robot covers everything."""
    if hulls is None:
        return [True] * len(squares_px)
    if not squares_px:
        return []
    quads = shapely.convex_hull(shapely.polygons(np.asarray(squares_px, float)))
    near = shapely.dwithin(np.asarray(hulls, dtype=object)[:, None], quads[None, :],
                           2.0 * margin_px)
    return [bool(v) for v in near.any(axis=0)]


def top_square(x: float, y: float, theta: float, side: float, z: float) -> np.ndarray:
    """(4, 3) world corners of a horizontal square of ``side`` centred at (x, y, z), turned
    by ``theta`` about z (a tag on a block's top face: z = the block's size)."""
    c, s, h = np.cos(theta), np.sin(theta), side / 2
    local = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    xy = local @ np.array([[c, s], [-s, c]]) + (x, y)
    return np.column_stack([xy, np.full(4, z)])
