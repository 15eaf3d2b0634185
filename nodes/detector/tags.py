"""Finding AprilTag 36h11 tags in a grey image and refining their corners.

OpenCV's ArUco module finds the quads and decodes the ids; the corners are then refined by
a method chosen by name (like apriltag_ros picks its pose estimator), see ``REFINEMENTS``:

* ``edges`` (default): our own sub-pixel edge fit. Each side of the black square is sampled
  along its normal at full resolution; the dark-to-light transition of every profile is
  located by its area balance (unbiased for any symmetric blur), a line is fitted through
  those points per side, and the corners are the intersections of adjacent lines. It uses
  all ~40 px of every side instead of a small window at the corner, so it is robust to
  noise and aliasing; with it the coarse detection may run on a decimated image.
* ``apriltag``: OpenCV's CORNER_REFINE_APRILTAG (accurate but ~0.5 s per 1280x960 frame).
* ``subpix``: OpenCV's CORNER_REFINE_SUBPIX (cornerSubPix at each corner).
* ``none``: the contour corners as found (biased ~0.5 px towards the tag centre).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

#: Half-length (in tag cells) of the normal profiles the edge fit samples: less than one
#: cell, so a profile sees only the black border inside and the white margin outside.
EDGE_WINDOW_CELLS = (0.8, 0.5)
#: Profiles are sampled every EDGE_STEP_PX along the normal.
EDGE_STEP_PX = 0.25
#: Profiles start this far (in cells) from a corner so they never see the adjacent side.
EDGE_CORNER_MARGIN_CELLS = 1.0
EDGE_SAMPLES = 24
MIN_EDGE_CONTRAST = 20.0  # grey levels (0-255) between the black border and the margin
#: Adaptive-threshold window sizes (px) of the coarse search: 3 and 13. OpenCV's default
#: adds 23, which finds nothing more for tags of 30-80 px (cells of 4-10 px) and costs ~40 %
#: of the detection time (measured on sim frames and noisy synthetic ones).
THRESHOLD_WINDOWS = (3, 13, 10)  # min, max, step


@dataclass(frozen=True)
class TagDetection:
    """One decoded tag: its id and its 4 corners in pixels (OpenCV order, 4 x 2)."""

    tag_id: int
    corners: np.ndarray


@dataclass(frozen=True)
class FinderSettings:
    refinement: str = "edges"
    decimate: float = 1.0  # coarse detection on an image scaled by 1/decimate
    min_perimeter_px: float = 40.0


class TagFinder:
    """A configured 36h11 finder; ``find(gray)`` -> detections with refined corners."""

    def __init__(self, settings: FinderSettings = FinderSettings()) -> None:
        if settings.refinement not in REFINEMENTS:
            raise ValueError(f"unknown corner refinement '{settings.refinement}'; "
                             f"known: {sorted(REFINEMENTS)}")
        if not settings.decimate >= 1.0:
            raise ValueError(f"decimate must be >= 1, got {settings.decimate}")
        self.settings = settings
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = _OPENCV_METHOD.get(
            settings.refinement, cv2.aruco.CORNER_REFINE_NONE)
        params.markerBorderBits = 1
        (params.adaptiveThreshWinSizeMin, params.adaptiveThreshWinSizeMax,
         params.adaptiveThreshWinSizeStep) = THRESHOLD_WINDOWS
        self._params = params
        self._dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
        self._detectors: dict[tuple[int, int], cv2.aruco.ArucoDetector] = {}

    def _detector(self, shape: tuple[int, int]) -> cv2.aruco.ArucoDetector:
        """One detector per image size: the minimum perimeter is a rate of the image size."""
        detector = self._detectors.get(shape)
        if detector is None:
            params = self._params
            params.minMarkerPerimeterRate = self.settings.min_perimeter_px / (
                self.settings.decimate * max(shape))
            detector = cv2.aruco.ArucoDetector(self._dictionary, params)
            self._detectors[shape] = detector
        return detector

    def find(self, gray: np.ndarray) -> list[TagDetection]:
        """Tags in an 8-bit grey image (H x W), corners refined at full resolution."""
        scale = 1.0 / self.settings.decimate
        small = gray if scale == 1.0 else cv2.resize(gray, None, fx=scale, fy=scale,
                                                     interpolation=cv2.INTER_AREA)
        corners, ids, _ = self._detector(small.shape[:2]).detectMarkers(small)
        if ids is None or len(ids) == 0:
            return []
        quads = np.asarray(corners, dtype=float).reshape(-1, 4, 2)
        if scale != 1.0:
            quads = (quads + 0.5) / scale - 0.5
        quads = REFINEMENTS[self.settings.refinement](gray, quads)
        return [TagDetection(int(i), q) for i, q in zip(ids.ravel(), quads, strict=True)]


# --- refinements ----------------------------------------------------------------------------
def _keep(gray: np.ndarray, quads: np.ndarray) -> np.ndarray:
    return quads


def _apriltag_shift(gray: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """OpenCV's AprilTag refinement reports corners with pixel centres at +0.5."""
    return quads - 0.5


def refine_edges(gray: np.ndarray, quads: np.ndarray) -> np.ndarray:
    """Sub-pixel corners from line fits to the four sides of each black square.

    Args:
        gray: 8-bit grey image.
        quads: T x 4 x 2 initial corners (OpenCV order), good to about a pixel.

    Returns:
        T x 4 x 2 refined corners; a tag whose sides lack contrast keeps its input corners.
    """
    quads = np.asarray(quads, dtype=float)
    if len(quads) == 0:
        return quads
    image = np.asarray(gray, dtype=np.float32)
    for window in EDGE_WINDOW_CELLS:
        lines, ok = _fit_sides(image, quads, window)
        refined = _intersect_sides(lines)
        good = ok & np.all(np.isfinite(refined), axis=(1, 2))
        good &= np.all(np.linalg.norm(refined - quads, axis=2) < 3.0, axis=1)
        quads = np.where(good[:, None, None], refined, quads)
    return quads


def _fit_sides(image: np.ndarray, quads: np.ndarray, window_cells: float):
    """Lines (point, unit direction) through the sub-pixel edge points of every side."""
    start = quads
    end = np.roll(quads, -1, axis=1)
    side = end - start  # T x 4 x 2, corner i -> i+1 (clockwise in the image)
    length = np.linalg.norm(side, axis=2, keepdims=True)
    along = side / length
    centre = quads.mean(axis=1, keepdims=True)
    normal = np.stack([along[..., 1], -along[..., 0]], axis=-1)
    mid = 0.5 * (start + end)
    flip = np.sum((mid - centre) * normal, axis=2, keepdims=True) < 0.0
    normal = np.where(flip, -normal, normal)  # outwards: dark inside -> light outside
    cell = length / 8.0
    margin = np.clip(EDGE_CORNER_MARGIN_CELLS * cell / length, 0.05, 0.4)
    frac = np.linspace(0.0, 1.0, EDGE_SAMPLES)
    t = margin + (1.0 - 2.0 * margin) * frac  # T x 4 x M
    points = start[:, :, None, :] + (t * length)[..., None] * along[:, :, None, :]
    half = np.maximum(window_cells * cell, 1.0)  # T x 4 x 1 (px)
    steps = np.arange(-1.0, 1.0 + 1e-9, EDGE_STEP_PX / 2.0)  # S, in units of half
    offsets = half[..., None] * steps  # T x 4 x 1 x S
    coords = points[..., None, :] + offsets[..., None] * normal[:, :, None, None, :]
    shape = coords.shape
    flat = coords.reshape(-1, shape[-2], 2).astype(np.float32)
    profiles = cv2.remap(image, flat[..., 0], flat[..., 1], cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_REPLICATE).reshape(shape[:-1])
    n_end = max(2, len(steps) // 8)
    lo = profiles[..., :n_end].mean(axis=-1)
    hi = profiles[..., -n_end:].mean(axis=-1)
    contrast = hi - lo
    frac_light = np.clip((profiles - lo[..., None]) / np.where(
        contrast > 0, contrast, 1.0)[..., None], 0.0, 1.0)
    ds = offsets[..., 1] - offsets[..., 0]  # T x 4 x 1
    # area balance: an ideal step at e leaves (s_max - e) / ds light samples
    light = np.trapezoid(frac_light, axis=-1) * ds
    edge = offsets[..., -1] - light  # T x 4 x M, along the normal from the sample point
    valid = contrast > MIN_EDGE_CONTRAST
    edge_pts = points + edge[..., None] * normal[:, :, None, :]
    weights = np.where(valid, contrast, 0.0)
    lines = _weighted_lines(edge_pts, weights)
    ok = np.all(valid.sum(axis=-1) >= EDGE_SAMPLES // 2, axis=1)
    return lines, ok


def _weighted_lines(points: np.ndarray, weights: np.ndarray):
    """Total-least-squares lines through T x 4 x M points: (centroid, direction) T x 4 x 2."""
    wsum = np.maximum(weights.sum(axis=-1, keepdims=True), 1e-12)
    c = (weights[..., None] * points).sum(axis=-2) / wsum
    d = points - c[..., None, :]
    sxx = (weights * d[..., 0] ** 2).sum(-1)
    syy = (weights * d[..., 1] ** 2).sum(-1)
    sxy = (weights * d[..., 0] * d[..., 1]).sum(-1)
    angle = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)  # principal axis
    direction = np.stack([np.cos(angle), np.sin(angle)], axis=-1)
    return c, direction


def _intersect_sides(lines) -> np.ndarray:
    """Corner i is where side i-1 (corner i-1 -> i) meets side i (corner i -> i+1)."""
    c, d = lines
    c_prev, d_prev = np.roll(c, 1, axis=1), np.roll(d, 1, axis=1)
    # solve c_prev + a d_prev = c + b d  for a
    det = d_prev[..., 0] * (-d[..., 1]) - d_prev[..., 1] * (-d[..., 0])
    rhs = c - c_prev
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (rhs[..., 0] * (-d[..., 1]) - rhs[..., 1] * (-d[..., 0])) / det
    return c_prev + a[..., None] * d_prev


REFINEMENTS: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "edges": refine_edges,
    "apriltag": _apriltag_shift,
    "subpix": _keep,
    "none": _keep,
}

_OPENCV_METHOD = {
    "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
    "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
}
