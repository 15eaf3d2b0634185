"""Lens models of ``sensor_msgs/CameraInfo``, shared by the sim and the detector.

``plumb_bob``, ``rational_polynomial`` and ``equidistant`` (OpenCV's standard and fisheye
models; formulas in ``msgs_py.camera``). "Ideal pixels" are the pinhole's
(fx x + cx, fy y + cy) for ideal normalised coordinates (x, y): where a perfect lens with
the same ``k`` would image the point. The sim renders the ideal image and warps it into
the distorted one with ``lens_warp``; the detector maps its measured corners back with
``undistort_pixels``.

The rectified camera (``CameraInfo.p``) is OpenCV's optimal new camera matrix of ``k`` and
``d`` (``rectified_camera``: ``getOptimalNewCameraMatrix``, or for the fisheye model
``estimateNewCameraMatrixForUndistortRectify``), as ROS's camera_calibration computes it;
``rectify`` resamples a raw image into it the way image_proc's rectify node does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from msgs_py.camera import EQUIDISTANT, CameraIntrinsics

#: Undistortion: OpenCV's fixed-point iteration to 1e-10 (normalised) or this many steps
#: (measured: the round trip through ``distort_pixels`` closes to 1e-10 px).
UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 50, 1e-10)


def camera_matrix(intrinsics: CameraIntrinsics) -> np.ndarray:
    return np.array(intrinsics.k, dtype=float).reshape(3, 3)


def _distort_standard(xy: np.ndarray, d: tuple[float, ...]) -> np.ndarray:
    """plumb_bob (5 coefficients) and rational_polynomial (8): OpenCV's standard model."""
    k1, k2, p1, p2, k3 = d[:5]
    k4, k5, k6 = d[5:8] if len(d) == 8 else (0.0, 0.0, 0.0)
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    radial = (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return np.column_stack([xd, yd])


def _distort_equidistant(xy: np.ndarray, d: tuple[float, ...]) -> np.ndarray:
    """OpenCV's fisheye model: the ray's angle from the axis, polynomial in that angle."""
    k1, k2, k3, k4 = d
    r = np.hypot(xy[:, 0], xy[:, 1])
    theta = np.arctan(r)
    t2 = theta * theta
    theta_d = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(r > 1e-12, theta_d / r, 1.0)
    return xy * scale[:, None]


def _undistort_standard(px: np.ndarray, k: np.ndarray, d: np.ndarray) -> np.ndarray:
    return cv2.undistortPoints(px.reshape(-1, 1, 2), k, d, R=None, P=k,
                               criteria=UNDISTORT_CRITERIA)


def _undistort_equidistant(px: np.ndarray, k: np.ndarray, d: np.ndarray) -> np.ndarray:
    return cv2.fisheye.undistortPoints(px.reshape(-1, 1, 2), k, d, R=np.eye(3), P=k,
                                       criteria=UNDISTORT_CRITERIA)


@dataclass(frozen=True)
class LensMaths:
    """One model's functions: ideal -> distorted normalised coordinates (numpy), measured
    pixels -> ideal pixels, the optimal new camera matrix, and the rectification maps."""

    distort: Callable[[np.ndarray, tuple[float, ...]], np.ndarray]
    undistort: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    new_camera_matrix: Callable[..., np.ndarray]
    rectify_maps: Callable[..., tuple[np.ndarray, np.ndarray]]


def _optimal_standard(k, d, size, alpha: float) -> np.ndarray:
    new_k, _ = cv2.getOptimalNewCameraMatrix(k, d, size, alpha, size)
    return new_k


def _optimal_fisheye(k, d, size, alpha: float) -> np.ndarray:
    return cv2.fisheye.estimateNewCameraMatrixForUndistortRectify(k, d, size, np.eye(3),
                                                                  balance=alpha)


def _maps_standard(k, d, new_k, size):
    return cv2.initUndistortRectifyMap(k, d, np.eye(3), new_k, size, cv2.CV_32FC1)


def _maps_fisheye(k, d, new_k, size):
    return cv2.fisheye.initUndistortRectifyMap(k, d, np.eye(3), new_k, size, cv2.CV_32FC1)


STANDARD = LensMaths(_distort_standard, _undistort_standard, _optimal_standard,
                     _maps_standard)
FISHEYE = LensMaths(_distort_equidistant, _undistort_equidistant, _optimal_fisheye,
                    _maps_fisheye)


def lens_maths(intrinsics: CameraIntrinsics) -> LensMaths:
    """The functions of the camera's ``distortion_model``."""
    return FISHEYE if intrinsics.distortion_model == EQUIDISTANT else STANDARD


def distort_normalized(xy: np.ndarray, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Ideal normalised coordinates (N x 2) -> distorted normalised coordinates."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if not intrinsics.distorted:
        return xy.copy()
    return lens_maths(intrinsics).distort(xy, intrinsics.d)


def distort_pixels(ideal: np.ndarray, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Ideal pixels (N x 2) -> where the lens images them (distorted pixels)."""
    px = np.asarray(ideal, dtype=float).reshape(-1, 2)
    if not intrinsics.distorted:
        return px.copy()
    i = intrinsics
    xy = distort_normalized((px - [i.cx, i.cy]) / [i.fx, i.fy], i)
    return xy * [i.fx, i.fy] + [i.cx, i.cy]


def undistort_pixels(pixels: np.ndarray, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Measured (distorted) pixels (N x 2) -> the ideal pixels of the same camera."""
    px = np.asarray(pixels, dtype=float).reshape(-1, 2)
    if not intrinsics.distorted or len(px) == 0:
        return px.copy()
    ideal = lens_maths(intrinsics).undistort(px, camera_matrix(intrinsics),
                                             np.array(intrinsics.d, float))
    return ideal.reshape(-1, 2)


@lru_cache(maxsize=8)
def rectified_camera(intrinsics: CameraIntrinsics, alpha: float) -> CameraIntrinsics:
    """The rectified camera (``CameraInfo.p``): OpenCV's optimal new camera matrix of ``k``
    and ``d`` at ``alpha`` (0: every pixel of the rectified image shows the scene; 1: every
    raw pixel is kept; for the fisheye model OpenCV's ``balance``, which it judges from the
    image edges' midpoints, so only about), an ideal lens. An ideal lens's is the camera
    itself.
    """
    if not intrinsics.distorted:
        return intrinsics.pinhole()
    if not 0.0 <= alpha <= 1.0:
        raise ValueError(f"alpha must be in [0, 1], got {alpha}")
    size = (intrinsics.width, intrinsics.height)
    new_k = lens_maths(intrinsics).new_camera_matrix(
        camera_matrix(intrinsics), np.array(intrinsics.d, float), size, alpha)
    return CameraIntrinsics(intrinsics.width, intrinsics.height, float(new_k[0, 0]),
                            float(new_k[1, 1]), float(new_k[0, 2]), float(new_k[1, 2]))


@lru_cache(maxsize=4)
def _rectify_maps(raw: CameraIntrinsics, rectified: CameraIntrinsics):
    return lens_maths(raw).rectify_maps(camera_matrix(raw), np.array(raw.d, float),
                                        camera_matrix(rectified),
                                        (rectified.width, rectified.height))


def rectify(image: np.ndarray, raw: CameraIntrinsics, rectified: CameraIntrinsics
            ) -> np.ndarray:
    """The raw image resampled into the ``rectified`` camera (bilinear), as image_proc's
    rectify node publishes ``image_rect``."""
    if not raw.distorted and raw.k == rectified.k:
        return image.copy()
    map_x, map_y = _rectify_maps(raw, rectified)
    return cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)


def ideal_source_map(intrinsics: CameraIntrinsics) -> tuple[np.ndarray, np.ndarray]:
    """For every pixel of the distorted image, the ideal pixel it shows (H x W float32 maps
    for ``cv2.remap``).

    This is the inverse of what ``cv2.initUndistortRectifyMap`` computes (which, for every
    pixel of an undistorted output, gives the distorted pixel to read): here the output is
    the *distorted* image and the source the ideal one, so every output pixel centre is
    undistorted. Remapping an ideal (pinhole) image with these maps images it through the
    lens.
    """
    h, w = intrinsics.height, intrinsics.width
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    ideal = undistort_pixels(np.column_stack([u.ravel(), v.ravel()]), intrinsics)
    return (ideal[:, 0].reshape(h, w).astype(np.float32),
            ideal[:, 1].reshape(h, w).astype(np.float32))


#: Canvas margin beyond the farthest ideal pixel needed (bilinear reads one more pixel).
CANVAS_MARGIN_PX = 2


@dataclass(frozen=True)
class LensWarp:
    """How to image a scene through a lens with a pinhole renderer: render the ideal image
    of ``canvas`` (the same camera with an ideal lens, on a canvas grown until it holds
    every ideal pixel the distorted image shows), then ``apply`` the warp."""

    canvas: CameraIntrinsics
    map_x: np.ndarray
    map_y: np.ndarray

    def apply(self, ideal: np.ndarray) -> np.ndarray:
        """The distorted image (the camera's size) of an ideal image of ``canvas``."""
        return cv2.remap(ideal, self.map_x, self.map_y, cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE)


@lru_cache(maxsize=4)
def lens_warp(intrinsics: CameraIntrinsics) -> LensWarp:
    """The canvas and remap tables of a camera (computed once per camera)."""
    map_x, map_y = ideal_source_map(intrinsics)
    w, h = intrinsics.width, intrinsics.height
    left = max(0, int(np.ceil(-float(map_x.min()))) + CANVAS_MARGIN_PX)
    top = max(0, int(np.ceil(-float(map_y.min()))) + CANVAS_MARGIN_PX)
    right = max(0, int(np.ceil(float(map_x.max()) - (w - 1))) + CANVAS_MARGIN_PX)
    bottom = max(0, int(np.ceil(float(map_y.max()) - (h - 1))) + CANVAS_MARGIN_PX)
    i = intrinsics
    canvas = CameraIntrinsics(w + left + right, h + top + bottom, i.fx, i.fy, i.cx + left,
                              i.cy + top)
    return LensWarp(canvas, map_x + np.float32(left), map_y + np.float32(top))
