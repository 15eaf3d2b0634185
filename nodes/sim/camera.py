"""The overhead camera: pinhole intrinsics and a pose <-> PyBullet view/projection matrices.

OpenCV conventions throughout: ``camera_optical_frame`` has z forward, x right, y down; pixel
(u, v) = (0, 0) is the *centre* of the top-left pixel; ``u = fx X/Z + cx``. PyBullet wants
OpenGL matrices (camera looking down -z, y up). TinyRenderer samples image column i at
NDC x = -1 + 2 i / W and image row r (top first) at NDC y = 1 - 2 (r + 1) / H (it rasterises
bottom-up at integer positions, then flips the rows), so ``projection_matrix`` places the
principal point accordingly; the camera test checks that a tag's projected centre lands on
the predicted pixel (measured bias < 0.1 px).

A real camera is not a pinhole with perfect pixels, so ``render_rgb`` images the scene the
way one does (values and their sources: sim_assets/README.md):

1. lens distortion (``distortion`` of ``distortion_model``: plumb_bob, rational_polynomial or
   equidistant): TinyRenderer only renders pinhole images, so the ideal image is rendered on
   a canvas large enough to hold every ideal pixel the lens brings into view, then warped
   into the distorted image (``nodes.common.lens``);
2. blur (``blur_sigma_px``): a Gaussian point spread of lens, diffraction and pixel area;
3. noise: photon shot noise (``full_well_e``: variance grows with the signal) plus a
   signal-independent read noise (``noise_std``), rounded to 8 bits.

Everything random comes from the caller's generator (the sim's ``seed``). What camera_info
publishes of it: ``intrinsics`` (``k``, ``d``, the model) and ``rectified`` (``p``: OpenCV's
optimal new camera matrix of ``k`` and ``d`` at ``rectify_alpha``, as a calibration has it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import cv2
import numpy as np
import pybullet

from msgs_py.camera import (
    DISTORTION_MODEL,
    EQUIDISTANT,
    NO_DISTORTION,
    PLUMB_BOB,
    RATIONAL_POLYNOMIAL,
    CameraIntrinsics,
)
from nodes.common.lens import distort_pixels, lens_warp, rectified_camera, undistort_pixels
from nodes.common.transforms import quaternion_to_matrix

#: The sim camera's lens (barrel, -2.4 % at the image corners; sim_assets/README.md) written
#: in each model: the rational and equidistant forms are least-squares fits of the plumb_bob
#: form's radial mapping out to 1.4 x the corners' radius (within 0.03 px at fx = 1400 px;
#: the equidistant model has no tangential terms).
LENS_COEFFICIENTS = {
    PLUMB_BOB: (-0.10, 0.08, 0.0002, -0.00015, 0.0),
    RATIONAL_POLYNOMIAL: (0.4003, 0.1268, 0.0002, -0.00015, 0.0392, 0.5, 0.1, 0.0),
    EQUIDISTANT: (0.2321, 0.1339, -0.0003, 0.3531),
}
#: The model config/sim.yaml writes it in (as real calibrations often do: 8 coefficients).
DEFAULT_LENS_MODEL = RATIONAL_POLYNOMIAL

#: Grey level of the full well: a saturated pixel reads 255.
FULL_SCALE_DN = 255.0

#: Optical frame -> OpenGL camera frame (y and z flipped).
OPTICAL_TO_GL = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class SimCamera:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    position: tuple[float, float, float]  #: optical frame origin in world (m)
    orientation_xyzw: tuple[float, float, float, float]  #: optical frame in world
    near: float = 0.1
    far: float = 3.0
    distortion: tuple[float, ...] = NO_DISTORTION  #: d of distortion_model (OpenCV order)
    blur_sigma_px: float = 0.0  #: Gaussian point-spread sigma, px
    full_well_e: float = 0.0  #: electrons at full scale (255); 0 = no shot noise
    distortion_model: str = DISTORTION_MODEL
    rectify_alpha: float = 0.0  #: free scaling of the rectified camera (p), 0-1

    def __post_init__(self) -> None:
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"camera size {self.width}x{self.height} must be positive")
        if self.fx <= 0 or self.fy <= 0:
            raise ValueError(f"focal lengths fx={self.fx}, fy={self.fy} must be positive")
        if not 0 < self.near < self.far:
            raise ValueError(f"need 0 < near < far, got {self.near}, {self.far}")
        if not self.blur_sigma_px >= 0.0 or not self.full_well_e >= 0.0:
            raise ValueError("blur_sigma_px and full_well_e must be >= 0")
        if not 0.0 <= self.rectify_alpha <= 1.0:
            raise ValueError(f"rectify_alpha must be in [0, 1], got {self.rectify_alpha}")
        object.__setattr__(self, "distortion", tuple(float(v) for v in self.distortion))
        self.intrinsics  # noqa: B018 - validates the distortion (raises MessageError)

    @property
    def rotation(self) -> np.ndarray:
        """Optical frame axes in world (columns)."""
        return quaternion_to_matrix(self.orientation_xyzw)

    @property
    def intrinsics(self) -> CameraIntrinsics:
        """What ``sensor_msgs/CameraInfo`` publishes of this camera: ``k``, ``d``, the model."""
        return CameraIntrinsics(self.width, self.height, self.fx, self.fy, self.cx, self.cy,
                                self.distortion, self.distortion_model)

    @property
    def rectified(self) -> CameraIntrinsics:
        """The rectified camera camera_info's ``p`` holds (computed once per camera)."""
        return rectified_camera(self.intrinsics, self.rectify_alpha)

    @property
    def k(self) -> np.ndarray:
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])

    def view_matrix(self) -> list[float]:
        """World -> OpenGL camera, column-major 16 floats (PyBullet's layout)."""
        r_gl = self.rotation @ OPTICAL_TO_GL
        view = np.eye(4)
        view[:3, :3] = r_gl.T
        view[:3, 3] = -r_gl.T @ np.asarray(self.position, dtype=float)
        return view.T.reshape(-1).tolist()

    def projection_matrix(self) -> list[float]:
        """OpenGL projection of these intrinsics, column-major 16 floats."""
        w, h, n, f = self.width, self.height, self.near, self.far
        proj = np.zeros((4, 4))
        proj[0, 0] = 2.0 * self.fx / w
        proj[0, 2] = 1.0 - 2.0 * self.cx / w
        proj[1, 1] = 2.0 * self.fy / h
        proj[1, 2] = (2.0 * self.cy + 2.0) / h - 1.0
        proj[2, 2] = -(f + n) / (f - n)
        proj[2, 3] = -2.0 * f * n / (f - n)
        proj[3, 2] = -1.0
        return proj.T.reshape(-1).tolist()

    def project(self, points_world) -> np.ndarray:
        """(N, 3) world points -> (N, 2) pixel coordinates (u, v) where the lens images them."""
        return distort_pixels(self.project_ideal(points_world), self.intrinsics)

    def project_ideal(self, points_world) -> np.ndarray:
        """(N, 3) world points -> (N, 2) pinhole pixel coordinates (no lens distortion)."""
        pts = np.atleast_2d(np.asarray(points_world, dtype=float))
        cam = (pts - np.asarray(self.position)) @ self.rotation  # R^T (p - t), row-wise
        uv = cam[:, :2] / cam[:, 2:3]
        return uv * [self.fx, self.fy] + [self.cx, self.cy]

    def ground_footprint(self, z: float = 0.0) -> np.ndarray:
        """(4, 2) world x, y of the image corners' rays hitting the plane at height z."""
        corners = undistort_pixels(np.array(
            [[0, 0], [self.width - 1, 0], [self.width - 1, self.height - 1],
             [0, self.height - 1]], dtype=float), self.intrinsics)
        rays = np.column_stack([(corners[:, 0] - self.cx) / self.fx,
                                (corners[:, 1] - self.cy) / self.fy, np.ones(4)])
        rays_w = rays @ self.rotation.T
        origin = np.asarray(self.position)
        scale = (z - origin[2]) / rays_w[:, 2]
        return (origin + rays_w * scale[:, None])[:, :2]

    def sees(self, points_world, margin_px: float = 0.0) -> np.ndarray:
        """Which world points project inside the image (``margin_px`` from the border)."""
        uv = self.project(points_world)
        return ((uv[:, 0] >= margin_px) & (uv[:, 0] <= self.width - 1 - margin_px)
                & (uv[:, 1] >= margin_px) & (uv[:, 1] <= self.height - 1 - margin_px))


#: TinyRenderer's depth where no surface is: the far plane, 1 normalised (0.99999994 as it
#: comes, in float32); a surface in the cell lies far short of it (the table top: 0.95).
FAR_DEPTH = 1.0 - 1e-6
#: The backdrop's colour is probed in an image this many times smaller than the camera's.
BACKDROP_PROBE_SCALE = 40


@dataclass(frozen=True)
class Backdrop:
    """A flat-coloured body that fills the camera's whole view behind everything else (the
    table): TinyRenderer shades it one colour, ``rgb``, yet rasterising it over every pixel
    took 180 of a frame's 210 ms. So a frame is rendered without it (its ``rgba`` alpha 0,
    which TinyRenderer skips) and ``rgb`` painted where no surface was: the same pixels."""

    body: int
    rgba: tuple[float, float, float, float]
    rgb: tuple[int, int, int]


def probe_backdrop(client, body: int, rgba: tuple[float, float, float, float],
                   camera: SimCamera) -> Backdrop | None:
    """``body`` as the ``camera``'s backdrop, when it is the only body and shows in one
    colour over the whole of a small image of the view; else None (render it as it is)."""
    if client.getNumBodies() != 1:
        return None
    k = BACKDROP_PROBE_SCALE
    view = canvas_camera(camera)
    small = replace(view, width=max(4, view.width // k), height=max(3, view.height // k),
                    fx=view.fx / k, fy=view.fy / k, cx=(view.cx + 0.5) / k - 0.5,
                    cy=(view.cy + 0.5) / k - 0.5)
    rgb, depth = render_pinhole(client, small)
    colours = np.unique(rgb.reshape(-1, 3), axis=0)
    if len(colours) != 1 or np.any(depth > FAR_DEPTH):
        return None
    return Backdrop(body, rgba, tuple(int(v) for v in colours[0]))


def render_pinhole(client, camera: SimCamera, backdrop: Backdrop | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(H, W, 3) uint8 RGB and (H, W) depth of the pinhole ``camera`` (TinyRenderer,
    headless), the ``backdrop`` painted in rather than rasterised."""
    if backdrop is not None:
        client.changeVisualShape(backdrop.body, -1, rgbaColor=(*backdrop.rgba[:3], 0.0))
    try:
        _, _, rgba, depth, _ = client.getCameraImage(
            camera.width, camera.height, camera.view_matrix(), camera.projection_matrix(),
            renderer=pybullet.ER_TINY_RENDERER, flags=pybullet.ER_NO_SEGMENTATION_MASK,
            shadow=0)
    finally:
        if backdrop is not None:
            client.changeVisualShape(backdrop.body, -1, rgbaColor=backdrop.rgba)
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(camera.height, camera.width, 4)[..., :3]
    depth = np.asarray(depth, dtype=np.float32).reshape(camera.height, camera.width)
    if backdrop is not None:
        rgb = np.where((depth > FAR_DEPTH)[..., None], np.uint8(backdrop.rgb), rgb)
    return rgb, depth


def render_rgb(client, camera: SimCamera, noise_std: float = 0.0,
               rng: np.random.Generator | None = None,
               backdrop: Backdrop | None = None) -> np.ndarray:
    """Render (H, W, 3) uint8 RGB as ``camera`` images the scene: through its lens
    (distortion), blurred, with shot noise and ``noise_std`` read noise (grey levels);
    the ``backdrop`` (``probe_backdrop``) painted in."""
    image = render_pinhole(client, canvas_camera(camera), backdrop)[0].astype(np.float32)
    if camera.intrinsics.distorted:
        image = lens_warp(camera.intrinsics).apply(image)
    return expose(image, camera, noise_std, rng)


def canvas_camera(camera: SimCamera) -> SimCamera:
    """The pinhole camera TinyRenderer renders for ``camera``: itself, or, through a lens,
    one on a canvas holding every ideal pixel the lens brings into view (``lens_warp``)."""
    if not camera.intrinsics.distorted:
        return camera
    c = lens_warp(camera.intrinsics).canvas
    return replace(camera, width=c.width, height=c.height, cx=c.cx, cy=c.cy,
                   distortion=NO_DISTORTION, distortion_model=DISTORTION_MODEL)


def expose(image: np.ndarray, camera: SimCamera, noise_std: float = 0.0,
           rng: np.random.Generator | None = None) -> np.ndarray:
    """The sensor's reading of a float image (grey levels 0-255): blur, shot noise from
    ``camera.full_well_e``, read noise ``noise_std``, rounding to uint8."""
    if camera.blur_sigma_px > 0.0:
        image = cv2.GaussianBlur(image, (0, 0), camera.blur_sigma_px,
                                 borderType=cv2.BORDER_REPLICATE)
    variance = np.float32(noise_std * noise_std)
    if camera.full_well_e > 0.0:  # Poisson electrons: var(DN) = DN * (255 / full well)
        variance = variance + np.clip(image, 0.0, None) * np.float32(
            FULL_SCALE_DN / camera.full_well_e)
    if np.any(variance > 0.0):
        rng = rng or np.random.default_rng()
        image = image + np.sqrt(variance) * rng.standard_normal(image.shape, np.float32)
    return np.ascontiguousarray(np.clip(np.rint(image), 0, 255).astype(np.uint8))
