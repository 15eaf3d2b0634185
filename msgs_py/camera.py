"""Pinhole camera intrinsics and a camera pose: what the detector knows about its camera.

``CameraIntrinsics`` mirrors ``sensor_msgs/CameraInfo`` for an undistorted pinhole camera
(densepack's overhead camera: ``d`` all zero). ``CameraPose`` is the pose of
``camera_optical_frame`` (z forward, x right, y down) in ``world``, as written by
``densepack-calibrate`` to ``config/camera_calibration.yaml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from msgs_py.checks import finite_float, integer, positive_float
from msgs_py.errors import MessageError


@dataclass(frozen=True, slots=True)
class CameraIntrinsics:
    """Image size (px) and pinhole parameters (px); pixel centres at integer coordinates."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float

    def __post_init__(self) -> None:
        integer("camera_info.width", self.width, minimum=1)
        integer("camera_info.height", self.height, minimum=1)
        positive_float("camera_info.k[0] (fx)", self.fx)
        positive_float("camera_info.k[4] (fy)", self.fy)
        finite_float("camera_info.k[2] (cx)", self.cx)
        finite_float("camera_info.k[5] (cy)", self.cy)

    @property
    def k(self) -> tuple[float, ...]:
        """Row-major 3x3 camera matrix, as in ``CameraInfo.k``."""
        return (self.fx, 0.0, self.cx, 0.0, self.fy, self.cy, 0.0, 0.0, 1.0)

    def scaled(self, factor: float) -> CameraIntrinsics:
        """The intrinsics of the same camera imaged at ``factor`` times the resolution."""
        return CameraIntrinsics(
            round(self.width * factor), round(self.height * factor),
            self.fx * factor, self.fy * factor,
            (self.cx + 0.5) * factor - 0.5, (self.cy + 0.5) * factor - 0.5,
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
