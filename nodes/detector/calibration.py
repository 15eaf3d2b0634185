"""Camera pose in ``world`` from tags at known poses: the extrinsic calibration.

Every tag corner of a block at a known pose is a known world point (z = block size). All
corners of all frames go into one PnP problem (planar IPPE for a start, then
Levenberg-Marquardt on the reprojection error, through the lens's distortion: OpenCV's
standard model takes plumb_bob and rational_polynomial ``d`` as they are and the corners
where they are measured; an equidistant (fisheye) lens's corners are undistorted to ideal
pixels first, OpenCV's PnP knowing no fisheye). A *group* of corners is
one tag at one known pose: a tag of a board (``calibrate_camera``), or the one block the
arm sets down at several places (``calibrate_views`` with one ``placement`` per place).
Groups that disagree with the consensus (a block not where the list says) are dropped and
the pose solved again. The residual per group and overall is reported, with the pose's
standard deviations from the Gauss-Newton covariance, so a user can judge the result
before the detector relies on it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from msgs_py import BlockPose
from msgs_py.camera import EQUIDISTANT, CameraIntrinsics
from nodes.common.camera_model import CameraModel, camera_matrix, dist_coeffs
from nodes.common.lens import undistort_pixels
from nodes.detector.tag_geometry import BLOCK_SIZE, TAG_SIZE, tag_corners_world
from nodes.detector.tags import TagDetection

MIN_TAGS = 4
OUTLIER_FACTOR = 5.0  # a tag whose RMS exceeds this many times the median is dropped
OUTLIER_FLOOR_PX = 0.5  # ... and also exceeds this


@dataclass(frozen=True)
class CalibrationResult:
    """The estimated camera, its residuals (px) and 1-sigma uncertainties."""

    camera: CameraModel
    rms_px: float
    max_px: float
    per_tag_px: dict[int, float]
    n_frames: int
    n_points: int
    dropped_tags: tuple[int, ...] = ()
    position_sigma_m: tuple[float, float, float] = (math.nan,) * 3
    rotation_sigma_deg: float = math.nan
    unknown_tags: tuple[int, ...] = field(default=())
    group_name: str = "tag"  #: what ``per_tag_px`` and ``dropped_tags`` count: tag, placement

    def report(self) -> str:
        p = self.camera.position
        sx, sy, sz = (1000.0 * s for s in self.position_sigma_m)
        worst = sorted(self.per_tag_px.items(), key=lambda kv: -kv[1])[:3]
        lines = [
            f"camera position [m]: [{p[0]:.5f}, {p[1]:.5f}, {p[2]:.5f}] "
            f"(1-sigma {sx:.3f}, {sy:.3f}, {sz:.3f} mm)",
            "camera orientation xyzw: [" + ", ".join(
                f"{v:.6f}" for v in self.camera.pose.orientation_xyzw) + "] "
            f"(1-sigma {self.rotation_sigma_deg:.4f} deg)",
            f"reprojection residual: RMS {self.rms_px:.3f} px, max {self.max_px:.3f} px over "
            f"{self.n_points} corners of {len(self.per_tag_px)} {self.group_name}s in "
            f"{self.n_frames} frames",
            f"worst {self.group_name}s (RMS px): " + ", ".join(
                f"{i}: {e:.3f}" for i, e in worst),
        ]
        if self.dropped_tags:
            lines.append(f"dropped as outliers: {list(self.dropped_tags)}")
        if self.unknown_tags:
            lines.append(f"seen but not at a known pose (ignored): {list(self.unknown_tags)}")
        return "\n".join(lines)


@dataclass(frozen=True)
class View:
    """One frame's tag detections and the known poses of its blocks. Frames of one
    arrangement share a ``placement`` number."""

    detections: Sequence[TagDetection]
    known: Mapping[int, BlockPose]
    placement: int = 0


GROUP_BY = ("tag", "placement")


def correspondences(views: Iterable[View], block_size: float = BLOCK_SIZE,
                    tag_size: float = TAG_SIZE, group_by: str = "tag"):
    """(world points N x 3, image points N x 2, group per point, unknown ids, n frames);
    a point's group is its tag id (``group_by="tag"``) or its view's placement."""
    if group_by not in GROUP_BY:
        raise ValueError(f"group_by must be one of {GROUP_BY}, got {group_by!r}")
    world, image, groups, unknown = [], [], [], set()
    n_frames = 0
    for view in views:
        n_frames += 1
        counts: dict[int, int] = {}
        for det in view.detections:
            counts[det.tag_id] = counts.get(det.tag_id, 0) + 1
        for det in view.detections:
            if det.tag_id not in view.known:
                unknown.add(det.tag_id)
                continue
            if counts[det.tag_id] > 1:  # ambiguous in this frame
                continue
            world.append(tag_corners_world(view.known[det.tag_id], block_size, tag_size))
            image.append(np.asarray(det.corners, dtype=float).reshape(4, 2))
            groups += [det.tag_id if group_by == "tag" else view.placement] * 4
    if not world:
        return np.zeros((0, 3)), np.zeros((0, 2)), np.zeros(0, int), sorted(unknown), n_frames
    return (np.vstack(world), np.vstack(image), np.asarray(groups), sorted(unknown), n_frames)


def calibrate_camera(frames: Iterable[Sequence[TagDetection]], intrinsics: CameraIntrinsics,
                     known: Mapping[int, BlockPose], block_size: float = BLOCK_SIZE,
                     tag_size: float = TAG_SIZE) -> CalibrationResult:
    """Solve the camera pose from tag detections (one list per frame) of known blocks.

    Raises:
        ValueError: fewer than MIN_TAGS known tags were seen, or PnP failed.
    """
    return calibrate_views([View(f, known) for f in frames], intrinsics, block_size,
                           tag_size, group_by="tag")


def calibrate_views(views: Iterable[View], intrinsics: CameraIntrinsics,
                    block_size: float = BLOCK_SIZE, tag_size: float = TAG_SIZE,
                    group_by: str = "tag") -> CalibrationResult:
    """Solve the camera pose from views whose blocks stand at known poses; residuals and
    outliers per tag or per placement (``group_by``).

    Raises:
        ValueError: fewer than MIN_TAGS groups were seen, or PnP failed.
    """
    world, image, ids, unknown, n_frames = correspondences(views, block_size, tag_size,
                                                           group_by)
    dropped: list[int] = []
    while True:
        tags = sorted(set(ids.tolist()))
        if len(tags) < MIN_TAGS:
            raise ValueError(f"need at least {MIN_TAGS} known {group_by}s, saw {len(tags)}"
                             f" ({tags}); unknown ids seen: {unknown}")
        rvec, tvec = _solve(world, image, intrinsics)
        residual = _residuals(world, image, intrinsics, rvec, tvec)
        per_tag = {t: float(np.sqrt(np.mean(residual[ids == t] ** 2))) for t in tags}
        median = float(np.median(list(per_tag.values())))
        worst = max(per_tag, key=per_tag.get)
        if per_tag[worst] > max(OUTLIER_FACTOR * median, OUTLIER_FLOOR_PX):
            dropped.append(worst)
            keep = ids != worst
            world, image, ids = world[keep], image[keep], ids[keep]
            continue
        break
    camera = CameraModel.from_rvec_tvec(intrinsics, rvec, tvec)
    sigma_p, sigma_r = _uncertainty(world, image, intrinsics, rvec, tvec)
    return CalibrationResult(
        camera=camera, rms_px=float(np.sqrt(np.mean(residual**2))),
        max_px=float(residual.max()), per_tag_px=per_tag, n_frames=n_frames,
        n_points=len(world), dropped_tags=tuple(dropped), position_sigma_m=sigma_p,
        rotation_sigma_deg=sigma_r, unknown_tags=tuple(unknown), group_name=group_by)


def _pnp_problem(image: np.ndarray, intrinsics: CameraIntrinsics):
    """(image points, camera matrix, distortion vector) OpenCV's PnP can take: the measured
    corners with the standard model's ``d``, or a fisheye camera's corners as ideal pixels."""
    if intrinsics.distorted and intrinsics.distortion_model == EQUIDISTANT:
        return undistort_pixels(image, intrinsics), camera_matrix(intrinsics), None
    return image, camera_matrix(intrinsics), dist_coeffs(intrinsics)


def _solve(world: np.ndarray, image: np.ndarray, intrinsics: CameraIntrinsics):
    points, k, dist = _pnp_problem(image, intrinsics)
    obj = world.reshape(-1, 1, 3).astype(np.float64)
    img = points.reshape(-1, 1, 2).astype(np.float64)
    planar = np.ptp(world[:, 2]) < 1e-9
    ok, rvec, tvec = cv2.solvePnP(obj, img, k, dist,
                                  flags=cv2.SOLVEPNP_IPPE if planar else cv2.SOLVEPNP_SQPNP)
    if not ok:
        raise ValueError("PnP found no camera pose for these correspondences")
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-12)
    rvec, tvec = cv2.solvePnPRefineLM(obj, img, k, dist, rvec, tvec, criteria)
    return rvec.reshape(3), tvec.reshape(3)


def _residuals(world, image, intrinsics, rvec, tvec) -> np.ndarray:
    """Per corner, the distance (px) between where it was measured and where the solved
    camera images it through its lens."""
    projected = CameraModel.from_rvec_tvec(intrinsics, rvec, tvec).project(world)
    return np.linalg.norm(projected - image, axis=1)


def _uncertainty(world, image, intrinsics, rvec, tvec):
    """1-sigma camera position (m, world axes) and rotation (deg) from J^T J of the PnP
    problem as OpenCV solved it."""
    points, k, dist = _pnp_problem(image, intrinsics)
    projected, jac = cv2.projectPoints(world.astype(np.float64), rvec, tvec, k, dist)
    residual = np.linalg.norm(projected.reshape(-1, 2) - points, axis=1)
    j = jac[:, :6]  # d(u, v) / d(rvec, tvec)
    dof = max(2 * len(world) - 6, 1)
    sigma2 = float(np.sum(residual**2)) / dof
    try:
        cov = sigma2 * np.linalg.inv(j.T @ j)
    except np.linalg.LinAlgError:
        return (math.nan,) * 3, math.nan
    # camera centre c = -R^T t: propagate numerically through (rvec, tvec)
    def centre(x):
        r, _ = cv2.Rodrigues(x[:3].reshape(3, 1))
        return -r.T @ x[3:]
    x0 = np.concatenate([rvec, tvec])
    eps = 1e-7
    jc = np.column_stack([(centre(x0 + eps * e) - centre(x0 - eps * e)) / (2 * eps)
                          for e in np.eye(6)])
    cov_c = jc @ cov @ jc.T
    sigma_p = tuple(float(math.sqrt(max(v, 0.0))) for v in np.diag(cov_c))
    sigma_r = math.degrees(math.sqrt(max(float(np.trace(cov[:3, :3])), 0.0)))
    return sigma_p, sigma_r
