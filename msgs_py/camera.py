"""Camera intrinsics and a camera pose: what the detector knows about its camera.

``CameraIntrinsics`` mirrors the raw camera of ``sensor_msgs/CameraInfo``: the pinhole
matrix ``k``, the lens's distortion coefficients ``d`` and the model they belong to
(``distortion_model``), with OpenCV's order and meaning. For ideal normalised coordinates
(x, y), r^2 = x^2 + y^2:

* ``plumb_bob`` (k1, k2, p1, p2, k3): x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y +
  p2 (r^2 + 2 x^2), likewise for y;
* ``rational_polynomial`` (k1, k2, p1, p2, k3, k4, k5, k6): the radial factor becomes
  (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6), tangential as plumb_bob;
* ``equidistant`` (k1, k2, k3, k4; OpenCV's fisheye): the angle theta = atan(r) from the axis
  is imaged at radius theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8).

then through ``k``. All-zero coefficients are an ideal lens, whatever the model (as ROS's
image_geometry reads them). The rectified camera of ``CameraInfo.p`` (what image_proc's
``image_rect`` is imaged by) is a ``CameraIntrinsics`` too, with an ideal lens.
``CameraPose`` is the pose of ``camera_optical_frame`` (z forward, x right, y down) in
``world``, as written by ``densepack-calibrate`` to ``config/camera_calibration.yaml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from msgs_py.checks import finite_float, integer, positive_float
from msgs_py.errors import MessageError

PLUMB_BOB = "plumb_bob"
RATIONAL_POLYNOMIAL = "rational_polynomial"
EQUIDISTANT = "equidistant"
#: The ``CameraInfo.distortion_model`` names densepack reads, with their coefficients.
DISTORTION_COEFFICIENTS = {
    PLUMB_BOB: ("k1", "k2", "p1", "p2", "k3"),
    RATIONAL_POLYNOMIAL: ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"),
    EQUIDISTANT: ("k1", "k2", "k3", "k4"),
}
#: The model an ideal lens is published with (and ``d`` of it).
DISTORTION_MODEL = PLUMB_BOB
NO_DISTORTION = (0.0, 0.0, 0.0, 0.0, 0.0)
#: ``d`` must keep the radial mapping increasing this far beyond the image corners' radius
#: (an ideal point just outside the image must not fold back into it).
RADIAL_CHECK_MARGIN = 1.25
RADIAL_CHECK_STEPS = 200
#: QoS reliability a camera's topics may have, as parameters name it (a real driver often
#: publishes best effort, the sensor-data QoS); ``nodes.common.qos`` builds the profiles.
CAMERA_RELIABILITIES = ("reliable", "best_effort")


class UnsupportedLensModel(MessageError):
    """A ``distortion_model`` densepack has no maths for (its ``d`` is not all zero)."""

    def __init__(self, model: str) -> None:
        self.model = model
        super().__init__("camera_info.distortion_model", model,
                         f"unsupported lens model; supported: {sorted(DISTORTION_COEFFICIENTS)}")


def coefficients_reason(model: str) -> str:
    """'plumb_bob needs 5 coefficients (k1, k2, p1, p2, k3)' for an error message."""
    names = DISTORTION_COEFFICIENTS[model]
    return f"{model} needs {len(names)} coefficients ({', '.join(names)})"


@dataclass(frozen=True, slots=True)
class CameraIntrinsics:
    """Image size (px), pinhole parameters (px; pixel centres at integer coordinates) and
    the lens: ``d`` of ``distortion_model``, all zero for an ideal lens."""

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    d: tuple[float, ...] = NO_DISTORTION
    distortion_model: str = DISTORTION_MODEL

    def __post_init__(self) -> None:
        integer("camera_info.width", self.width, minimum=1)
        integer("camera_info.height", self.height, minimum=1)
        positive_float("camera_info.k[0] (fx)", self.fx)
        positive_float("camera_info.k[4] (fy)", self.fy)
        finite_float("camera_info.k[2] (cx)", self.cx)
        finite_float("camera_info.k[5] (cy)", self.cy)
        if self.distortion_model not in DISTORTION_COEFFICIENTS:
            raise UnsupportedLensModel(self.distortion_model)
        d = tuple(self.d)
        if len(d) != len(DISTORTION_COEFFICIENTS[self.distortion_model]):
            raise MessageError("camera_info.d", d, coefficients_reason(self.distortion_model))
        d = tuple(finite_float("camera_info.d", v) for v in d)
        object.__setattr__(self, "d", d)
        if self.distorted:
            self._check_radial()

    def _check_radial(self) -> None:
        """The radial mapping (ideal radius -> imaged radius) must increase over the image
        (with a margin): otherwise two ideal points land on one pixel and no undistortion
        exists."""
        reach = RADIAL_CHECK_MARGIN * self.corner_radius()
        if self.distortion_model == EQUIDISTANT:
            _check_equidistant(self.d, reach)
        else:
            _check_polynomial(self.d, reach)

    def corner_radius(self) -> float:
        """The farthest normalised radius of the image's outer pixel edges (through ``k``)."""
        return max(math.hypot((u - self.cx) / self.fx, (v - self.cy) / self.fy)
                   for u in (-0.5, self.width - 0.5) for v in (-0.5, self.height - 0.5))

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
            self.distortion_model,
        )


def _radial_polynomial(d: tuple[float, ...], r2: float) -> tuple[float, float]:
    """(numerator, denominator) of the plumb_bob / rational radial factor at r^2."""
    k1, k2, _, _, k3 = d[:5]
    k4, k5, k6 = d[5:8] if len(d) == 8 else (0.0, 0.0, 0.0)
    return (1.0 + r2 * (k1 + r2 * (k2 + r2 * k3)), 1.0 + r2 * (k4 + r2 * (k5 + r2 * k6)))


def _check_polynomial(d: tuple[float, ...], reach: float) -> None:
    """r -> r * radial(r^2) increases on (0, reach] and its denominator stays positive."""
    previous = 0.0
    for i in range(1, RADIAL_CHECK_STEPS + 1):
        r = reach * i / RADIAL_CHECK_STEPS
        numerator, denominator = _radial_polynomial(d, r * r)
        imaged = r * numerator / denominator if denominator > 0.0 else -math.inf
        if imaged <= previous:
            raise MessageError(
                "camera_info.d", d, f"the radial distortion folds over at r = {r:.3f} "
                f"(normalised; the image corners reach {reach / RADIAL_CHECK_MARGIN:.3f})")
        previous = imaged


def _check_equidistant(d: tuple[float, ...], reach: float) -> None:
    """theta -> theta_d increases until it passes ``reach`` (before 90 degrees: a ray at or
    beyond the image plane has no pinhole pixel)."""
    k1, k2, k3, k4 = d
    previous = 0.0
    for i in range(1, RADIAL_CHECK_STEPS + 1):
        theta = 0.5 * math.pi * i / (RADIAL_CHECK_STEPS + 1)
        t2 = theta * theta
        imaged = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
        if imaged <= previous:
            raise MessageError("camera_info.d", d, "the equidistant distortion folds over at "
                               f"{math.degrees(theta):.1f} deg from the axis")
        if imaged >= reach:
            return
        previous = imaged
    raise MessageError("camera_info.d", d, "the image corners look 90 degrees or more off "
                       "the axis: no pinhole pixel exists for them")


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
