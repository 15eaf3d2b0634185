"""Block pose from a tag's image corners, by method name (like apriltag_ros's estimators).

* ``plane`` (default): every block rests on the table, so its tag lies in the plane
  z = block size. Each corner's pixel ray is intersected with that plane and a rigid 2-D
  fit of the tag's local corners gives (x, y, theta). Three unknowns from eight
  measurements, with the height known: tilt/depth ambiguities of a 40 mm tag seen from
  1.2 m cannot leak into x and y.
* ``pnp``: a free 6-DoF pose per tag (OpenCV SQPnP, LM-polished), the way a generic tag detector
  does it; x, y are the tag centre, theta the yaw of its x axis. Kept to compare against.

Both take the corners as measured on the (distorted) image and undistort them with the
camera's lens first (``CameraModel.rays`` / ``undistort``: ``d`` of its distortion model):
the tag's edges are fitted where they are imaged, and only the four corners are mapped to
the ideal pinhole.
Both report the RMS reprojection error (px) of the model they fitted, on the measured
image; with ``plane`` it also grows when a tag is not where a resting block's tag can be
(a lifted or tipped block).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from msgs_py import BlockPose
from nodes.common.camera_model import CameraModel
from nodes.detector.tag_geometry import (
    BLOCK_SIZE,
    TAG_CORNERS_LOCAL,
    TAG_SIZE,
    fit_planar_pose,
    tag_corners_world,
)


@dataclass(frozen=True)
class PoseEstimate:
    """A tag's block pose in world (m, rad) and the RMS reprojection error (px) of the fit."""

    x: float
    y: float
    theta: float
    reprojection_px: float

    @property
    def finite(self) -> bool:
        return all(math.isfinite(v) for v in (self.x, self.y, self.theta, self.reprojection_px))


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((np.asarray(a) - np.asarray(b)) ** 2, axis=1))))


def estimate_on_plane(camera: CameraModel, corners: np.ndarray,
                      block_size: float = BLOCK_SIZE, tag_size: float = TAG_SIZE) -> PoseEstimate:
    """Corner rays meet the tag plane z = block_size; rigid 2-D fit of the tag square."""
    local = TAG_CORNERS_LOCAL * (tag_size / TAG_SIZE)
    world = camera.intersect_plane_z(corners, block_size)
    if not np.all(np.isfinite(world)):
        return PoseEstimate(math.nan, math.nan, math.nan, math.inf)
    x, y, theta = fit_planar_pose(world[:, :2], local)
    model = tag_corners_world(BlockPose(0, x, y, theta), block_size, tag_size)
    return PoseEstimate(x, y, theta, _rms(camera.project(model), corners))


def estimate_pnp(camera: CameraModel, corners: np.ndarray,
                 block_size: float = BLOCK_SIZE, tag_size: float = TAG_SIZE) -> PoseEstimate:
    """Free 6-DoF tag pose (IPPE_SQUARE); the block pose is the tag centre and x-axis yaw."""
    local = TAG_CORNERS_LOCAL * (tag_size / TAG_SIZE)
    object_pts = np.column_stack([local, np.zeros(4)])
    image_pts = camera.undistort(corners).reshape(4, 1, 2)
    # SQPnP is a global solver; IPPE_SQUARE, the usual choice for a square, is inexact
    # near fronto-parallel views (an overhead camera's normal case) even after LM.
    ok, rvec, tvec = cv2.solvePnP(object_pts, image_pts, camera.k, None,
                                  flags=cv2.SOLVEPNP_SQPNP)
    if not ok:
        return PoseEstimate(math.nan, math.nan, math.nan, math.inf)
    rvec, tvec = cv2.solvePnPRefineLM(object_pts, image_pts, camera.k, None, rvec, tvec)
    r_ct, _ = cv2.Rodrigues(rvec)
    tag_cam = object_pts @ r_ct.T + tvec.reshape(3)
    error = _rms(camera.project(camera.position + tag_cam @ camera.rotation.T), corners)
    r_wt = camera.rotation @ r_ct
    centre = camera.position + camera.rotation @ tvec.reshape(3)
    theta = math.atan2(r_wt[1, 0], r_wt[0, 0])
    return PoseEstimate(float(centre[0]), float(centre[1]), theta, error)


Estimator = Callable[..., PoseEstimate]

ESTIMATORS: dict[str, Estimator] = {
    "plane": estimate_on_plane,
    "pnp": estimate_pnp,
}
