"""Camera intrinsics and a camera pose: what the detector knows about its camera.

``CameraIntrinsics`` mirrors ``sensor_msgs/CameraInfo``: the pinhole matrix ``k`` and the
lens distortion ``d`` of the ``plumb_bob`` model (k1, k2, p1, p2, k3; OpenCV's order and
meaning: a point at normalised ideal coordinates (x, y), r^2 = x^2 + y^2, is imaged at
x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2), likewise for y, then
through ``k``). ``CameraPose`` is the pose of
``camera_optical_frame`` (z forward, x right, y down) in ``world``, as written by
``densepack-calibrate`` to ``config/camera_calibration.yaml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from msgs_py.checks import finite_float, integer, positive_float
from msgs_py.errors import MessageError

#: The distortion model ``d`` follows, as ``CameraInfo.distortion_model`` names it.
DISTORTION_MODEL = "plumb_bob"
NO_DISTORTION = (0.0, 0.0, 0.0, 0.0, 0.0)
#: ``d`` must keep the radial mapping increasing this far beyond the image corners' radius
#: (an ideal point just outside the image must not fold back into it).
RADIAL_CHECK_MARGIN = 1.25


@dataclass(frozen=True, slots=True)
class CameraIntrinsics:
    """Image size (px), pinhole parameters (px; pixel centres at integer coordinates) and
    plumb_bob distortion ``d`` = (k1, k2, p1, p2, k3), all zero for an ideal lens."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    d: tuple[float, ...] = NO_DISTORTION

    def __post_init__(self) -> None:
        integer("camera_info.width", self.width, minimum=1)
        integer("camera_info.height", self.height, minimum=1)
        positive_float("camera_info.k[0] (fx)", self.fx)
        positive_float("camera_info.k[4] (fy)", self.fy)
        finite_float("camera_info.k[2] (cx)", self.cx)
        finite_float("camera_info.k[5] (cy)", self.cy)
        d = tuple(self.d)
        if len(d) != 5:
            raise MessageError("camera_info.d", d,
                               f"{DISTORTION_MODEL} needs 5 coefficients (k1, k2, p1, p2, k3)")
        d = tuple(finite_float("camera_info.d", v) for v in d)
        object.__setattr__(self, "d", d)
        self._check_radial()

    def _check_radial(self) -> None:
        """The radial mapping r -> r (1 + k1 r^2 + k2 r^4 + k3 r^6) must increase over the
        image (with a margin): otherwise two ideal points land on one pixel and no
        undistortion exists."""
        k1, k2, _, _, k3 = self.d
        if k1 == k2 == k3 == 0.0:
            return
        r_max = RADIAL_CHECK_MARGIN * max(
            math.hypot((u - self.cx) / self.fx, (v - self.cy) / self.fy)
            for u in (-0.5, self.width - 0.5) for v in (-0.5, self.height - 0.5))
        for i in range(1, 201):
            r2 = (r_max * i / 200) ** 2
            slope = 1.0 + 3.0 * k1 * r2 + 5.0 * k2 * r2 * r2 + 7.0 * k3 * r2 ** 3
            if slope <= 0.0:
                raise MessageError(
                    "camera_info.d", self.d,
                    f"the radial distortion folds over at r = {math.sqrt(r2):.3f} (normalised;"
                    f" the image corners reach {r_max / RADIAL_CHECK_MARGIN:.3f})")

    @property
    def distorted(self) -> bool:
        """Whether the lens distorts (any coefficient of ``d`` non-zero)."""
        return any(v != 0.0 for v in self.d)

    def pinhole(self) -> CameraIntrinsics:
        """The same camera with an ideal lens."""
        return CameraIntrinsics(self.width, self.height, self.fx, self.fy, self.cx, self.cy)

    @property
    def k(self) -> tuple[float, ...]:
        """Row-major 3x3 camera matrix, as in ``CameraInfo.k``."""
        return (self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)

    def scaled(self, factor: float) -> CameraIntrinsics:
        """The intrinsics of the same camera imaged at ``factor`` times the resolution
        (``d`` acts on normalised coordinates: unchanged)."""
        return CameraIntrinsics(
            round(self.width * factor), round(self.height * factor),
            self.fx * factor, self.fy * factor,
            (self.cx + 0.5) * factor - 0.5, (self.cy + 0.5) * factor - 0.5, self.d,
        )


@dataclass(frozen=True, slots=True)
class CameraPose:
    """Pose of ``camera_optical_frame`` in ``world``: position (m), unit quaternion x, y, z, w."""

    position: tuple[float, float, float]
    orientation_xyzw: tuple[float, float, float, float]

    def __post_init__(self) -> None:
        position = tuple(self.position)
        quat = tuple(self.orientation_xyzw)
        if len(position) != 3:
            raise MessageError("camera_pose.position", position, "expected [x, y, z]")
        if len(quat) != 4:
            raise MessageError("camera_pose.orientation_xyzw", quat, "expected [x, y, z, w]")
        position = tuple(finite_float("camera_pose.position", v) for v in position)
        quat = tuple(finite_float("camera_pose.orientation_xyzw", v) for v in quat)
        norm = math.sqrt(sum(v * v for v in quat))
        if abs(norm - 1.0) > 1e-3:
            raise MessageError("camera_pose.orientation_xyzw", quat, "must be a unit quaternion")
        object.__setattr__(self, "position", position)
        object.__setattr__(self, "orientation_xyzw", tuple(v / norm for v in quat))
