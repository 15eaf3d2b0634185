"""Synthetic overhead images of tagged blocks, rendered without the simulator.

Tests and the detector's own tuning need images whose truth is exact. Each block's top face
(white, with its 36h11 tag centred) is warped into the image through the plane homography
of the face; the cube's sides are its projected silhouette. Rendering happens on a
``supersample``-times finer canvas that is then area-averaged, so edges are anti-aliased
the way a real sensor integrates light; blur and Gaussian noise are optional. A camera with
lens distortion (``intrinsics.d`` of any model) is rendered as the sim does it: the ideal
image on a larger canvas, warped through the lens (``nodes.common.lens.lens_warp``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import cv2
import numpy as np

from msgs_py import BlockPose
from msgs_py.camera import DISTORTION_MODEL, NO_DISTORTION, CameraIntrinsics, CameraPose
from nodes.common.camera_model import CameraModel
from nodes.common.lens import lens_warp
from nodes.common.transforms import matrix_to_quaternion
from nodes.detector.tag_geometry import BLOCK_SIZE, TAG_SIZE, local_to_world_xy

TEXTURE_PX_PER_MM = 8.0
_CUBE_LOCAL = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)


def overhead_camera(
    width: int = 1280, height: int = 960, focal_px: float = 1100.0,
    center_xy: tuple[float, float] = (0.70, 0.0), height_m: float = 1.25,
    distortion: tuple[float, ...] = NO_DISTORTION, distortion_model: str = DISTORTION_MODEL,
) -> CameraModel:
    """The cell's overhead camera looking straight down (docs/contracts.md geometry), with
    the lens ``distortion`` of ``distortion_model`` (default plumb_bob k1, k2, p1, p2, k3).

    The image's long side runs along world y, image up is world +x: camera x = -world y,
    camera y = -world x, camera z = -world z.
    """
    intrinsics = CameraIntrinsics(width, height, focal_px, focal_px,
                                  (width - 1) / 2.0, (height - 1) / 2.0, distortion,
                                  distortion_model)
    rot = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    pose = CameraPose((center_xy[0], center_xy[1], height_m),
                      tuple(float(v) for v in matrix_to_quaternion(rot)))
    return CameraModel.from_pose(intrinsics, pose)


@cache
def face_texture(tag_id: int, px_per_mm: float = TEXTURE_PX_PER_MM,
                 block_size: float = BLOCK_SIZE, tag_size: float = TAG_SIZE) -> np.ndarray:
    """The top face as a float image in [0, 1]: white margin, 36h11 tag (8 cells) centred."""
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    face_px = round(block_size * 1000.0 * px_per_mm)
    cell_px = round(tag_size * 1000.0 * px_per_mm / 8.0)
    tag = cv2.aruco.generateImageMarker(dictionary, tag_id, 8 * cell_px, borderBits=1)
    face = np.full((face_px, face_px), 255, np.uint8)
    off = (face_px - tag.shape[0]) // 2
    face[off:off + tag.shape[0], off:off + tag.shape[1]] = tag
    return face.astype(np.float32) / 255.0


@dataclass(frozen=True)
class RenderStyle:
    """Grey levels (0-255) and image degradations of a synthetic frame."""

    table: float = 95.0
    side: float = 150.0
    white: float = 225.0
    black: float = 25.0
    occluder: float = 60.0
    blur_sigma_px: float = 0.0
    noise_std: float = 0.0
    supersample: int = 3


def render_blocks(
    camera: CameraModel,
    blocks: Sequence[BlockPose],
    style: RenderStyle = RenderStyle(),
    rng: np.random.Generator | None = None,
    occluders: Sequence[np.ndarray] = (),
    block_size: float = BLOCK_SIZE,
    tag_size: float = TAG_SIZE,
) -> np.ndarray:
    """An rgb8 image (H x W x 3) of blocks resting on the table seen by ``camera``.

    Args:
        occluders: convex polygons in world (N x 3 points, m) drawn over everything, e.g. an
            arm between the camera and the blocks.
    """
    k = style.supersample
    warp = lens_warp(camera.intrinsics) if camera.intrinsics.distorted else None
    ideal = warp.canvas if warp is not None else camera.intrinsics
    fine = CameraModel(ideal.scaled(k), camera.rotation, camera.position)
    w, h = fine.intrinsics.width, fine.intrinsics.height
    canvas = np.full((h, w), style.table, np.float32)
    half = 0.5 * block_size
    for b in blocks:  # silhouettes first: a cube's side never covers another cube's top
        xy = local_to_world_xy(b.x, b.y, b.theta, half * _CUBE_LOCAL)
        corners = np.vstack([np.column_stack([xy, np.zeros(4)]),
                             np.column_stack([xy, np.full(4, block_size)])])
        hull = cv2.convexHull(_fixed_point(fine.project(corners)))
        cv2.fillConvexPoly(canvas, hull, style.side, lineType=cv2.LINE_8, shift=4)
    for b in blocks:
        _draw_face(canvas, fine, b, style, block_size, tag_size)
    for poly in occluders:
        pts = _fixed_point(fine.project(np.asarray(poly, dtype=float)))
        cv2.fillConvexPoly(canvas, pts, style.occluder, lineType=cv2.LINE_8, shift=4)
    image = cv2.resize(canvas, (ideal.width, ideal.height), interpolation=cv2.INTER_AREA)
    if warp is not None:
        image = warp.apply(image)
    if style.blur_sigma_px > 0.0:
        image = cv2.GaussianBlur(image, (0, 0), style.blur_sigma_px)
    if style.noise_std > 0.0:
        rng = rng if rng is not None else np.random.default_rng(0)
        image = image + rng.normal(0.0, style.noise_std, image.shape).astype(np.float32)
    gray = np.clip(np.rint(image), 0, 255).astype(np.uint8)
    return np.dstack([gray, gray, gray])


def _fixed_point(pixels: np.ndarray) -> np.ndarray:
    """Pixel coordinates as OpenCV's 4-bit fixed-point int32 polygon (pixel centres exact)."""
    return np.rint(np.asarray(pixels) * 16.0).astype(np.int32).reshape(-1, 1, 2)


def _draw_face(canvas: np.ndarray, fine: CameraModel, block: BlockPose, style: RenderStyle,
               block_size: float, tag_size: float) -> None:
    """Warp the block's face texture into ``canvas`` with anti-aliased coverage."""
    texture = face_texture(block.id, TEXTURE_PX_PER_MM, block_size, tag_size)
    n = texture.shape[0]
    half = 0.5 * block_size
    local = half * np.array([[-1.0, 1.0], [1.0, 1.0], [1.0, -1.0], [-1.0, -1.0]])
    xy = local_to_world_xy(block.x, block.y, block.theta, local)
    image_pts = fine.project(np.column_stack([xy, np.full(4, block_size)]))
    if not np.all(np.isfinite(image_pts)):
        return
    tex_pts = np.array([[-0.5, -0.5], [n - 0.5, -0.5], [n - 0.5, n - 0.5], [-0.5, n - 0.5]])
    x0 = max(math.floor(image_pts[:, 0].min()) - 1, 0)
    y0 = max(math.floor(image_pts[:, 1].min()) - 1, 0)
    x1 = min(math.ceil(image_pts[:, 0].max()) + 2, canvas.shape[1])
    y1 = min(math.ceil(image_pts[:, 1].max()) + 2, canvas.shape[0])
    if x1 <= x0 or y1 <= y0:
        return
    hom = cv2.getPerspectiveTransform(tex_pts.astype(np.float32),
                                      (image_pts - [x0, y0]).astype(np.float32))
    size = (x1 - x0, y1 - y0)
    shade = style.black + (style.white - style.black) * texture
    warped = cv2.warpPerspective(shade, hom, size, flags=cv2.INTER_LINEAR,
                                 borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
    # Premultiplied alpha: the same bilinear sampling against a zero border gives shade x
    # coverage and the coverage itself, so the face's outline blends into what is below.
    coverage = cv2.warpPerspective(np.ones_like(texture), hom, size, flags=cv2.INTER_LINEAR,
                                   borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
    roi = canvas[y0:y1, x0:x1]
    roi[:] = warped + (1.0 - coverage) * roi
