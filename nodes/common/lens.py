"""The plumb_bob lens model (``sensor_msgs/CameraInfo`` ``d``), shared by the sim and the detector.

OpenCV's meaning and order, d = (k1, k2, p1, p2, k3): a point at ideal normalised
coordinates (x, y) = (X/Z, Y/Z), r^2 = x^2 + y^2, is imaged at

    x' = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)
    y' = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y

then through the camera matrix: u = fx x' + cx, v = fy y' + cy. "Ideal pixels" are the
pinhole's (fx x + cx, fy y + cy): where the point would be imaged by a perfect lens.
The sim renders the ideal image and warps it into the distorted one with ``lens_warp``;
the detector maps its measured corners back with ``undistort_pixels``.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np

from msgs_py.camera import CameraIntrinsics

#: Undistortion: OpenCV's fixed-point iteration to 1e-10 (normalised) or this many steps
#: (measured: the round trip through ``distort_pixels`` closes to 1e-10 px).
UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 50, 1e-10)


def camera_matrix(intrinsics: CameraIntrinsics) -> np.ndarray:
    return np.array(intrinsics.k, dtype=float).reshape(3, 3)


def distort_normalized(xy: np.ndarray, d) -> np.ndarray:
    """Ideal normalised coordinates (N x 2) -> distorted normalised coordinates."""
    k1, k2, p1, p2, k3 = (float(v) for v in d)
    x, y = xy[:, 0], xy[:, 1]
    r2 = x * x + y * y
    radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
    yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
    return np.column_stack([xd, yd])


def distort_pixels(ideal: np.ndarray, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Ideal pixels (N x 2) -> where the lens images them (distorted pixels)."""
    px = np.asarray(ideal, dtype=float).reshape(-1, 2)
    if not intrinsics.distorted:
        return px.copy()
    i = intrinsics
    xy = distort_normalized((px - [i.cx, i.cy]) / [i.fx, i.fy], i.d)
    return xy * [i.fx, i.fy] + [i.cx, i.cy]


def undistort_pixels(pixels: np.ndarray, intrinsics: CameraIntrinsics) -> np.ndarray:
    """Measured (distorted) pixels (N x 2) -> the ideal pixels of the same camera."""
    px = np.asarray(pixels, dtype=float).reshape(-1, 2)
    if not intrinsics.distorted or len(px) == 0:
        return px.copy()
    k = camera_matrix(intrinsics)
    ideal = cv2.undistortPoints(px.reshape(-1, 1, 2), k, np.array(intrinsics.d, float),
                                R=None, P=k, criteria=UNDISTORT_CRITERIA)
    return ideal.reshape(-1, 2)


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
