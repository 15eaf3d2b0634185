"""A calibrated camera: project world points, cast pixel rays onto a plane.

The camera pose is that of ``camera_optical_frame`` in ``world`` (z forward, x right,
y down); intrinsics follow OpenCV (pixel centres at integer coordinates), with the lens's
distortion ``intrinsics.d`` of ``intrinsics.distortion_model`` (plumb_bob,
rational_polynomial or equidistant): ``project`` gives where a point is *imaged* (distorted
pixels, what the detector measures), ``undistort`` maps measured pixels to the ideal
pinhole pixels of the same camera, and ``rays`` / ``intersect_plane_z`` take measured
pixels (they undistort first). With ``d`` all zero every step is the pinhole's; a model of
a rectified image (camera_info's ``p``) is such a pinhole. The calibration
file is ROS ``--params-file`` YAML with ``camera_pose.position`` and
``camera_pose.orientation_xyzw``, read by the detector and written by densepack-calibrate.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from msgs_py import MessageError
from msgs_py.camera import EQUIDISTANT, CameraIntrinsics, CameraPose
from nodes.common.lens import camera_matrix, distort_normalized, undistort_pixels
from nodes.common.params import read_params_file
from nodes.common.transforms import matrix_to_quaternion, quaternion_to_matrix


def dist_coeffs(intrinsics: CameraIntrinsics) -> np.ndarray | None:
    """The distortion vector of OpenCV's standard model (plumb_bob: 5 values,
    rational_polynomial: 8), or None for an ideal lens.

    Raises:
        ValueError: a fisheye (equidistant) lens, which OpenCV's standard functions
            (projectPoints, solvePnP) cannot model: undistort its pixels first.
    """
    if not intrinsics.distorted:
        return None
    if intrinsics.distortion_model == EQUIDISTANT:
        raise ValueError("an equidistant (fisheye) lens has no standard-model distortion "
                         "vector; undistort its pixels first")
    return np.array(intrinsics.d, dtype=float)


@dataclass(frozen=True)
class CameraModel:
    """Intrinsics plus ``world`` <- ``camera_optical_frame`` rotation and camera position."""

    intrinsics: CameraIntrinsics
    rotation: np.ndarray  # 3 x 3, columns = camera axes in world
    position: np.ndarray  # 3, camera centre in world, m

    @classmethod
    def from_pose(cls, intrinsics: CameraIntrinsics, pose: CameraPose) -> CameraModel:
        return cls(intrinsics, quaternion_to_matrix(pose.orientation_xyzw),
                   np.asarray(pose.position, dtype=float))

    @classmethod
    def from_rvec_tvec(cls, intrinsics: CameraIntrinsics, rvec: np.ndarray,
                       tvec: np.ndarray) -> CameraModel:
        """From OpenCV's world -> camera (rvec, tvec), as solvePnP returns it."""
        r_cw, _ = cv2.Rodrigues(np.asarray(rvec, dtype=float).reshape(3, 1))
        t_cw = np.asarray(tvec, dtype=float).reshape(3)
        return cls(intrinsics, r_cw.T, -r_cw.T @ t_cw)

    @property
    def k(self) -> np.ndarray:
        return camera_matrix(self.intrinsics)

    def pinhole(self) -> CameraModel:
        """This camera with an ideal lens (what ``undistort``'s pixels are pixels of)."""
        return CameraModel(self.intrinsics.pinhole(), self.rotation, self.position)

    def undistort(self, pixels: np.ndarray) -> np.ndarray:
        """Measured pixels (N x 2) -> ideal pinhole pixels."""
        return undistort_pixels(pixels, self.intrinsics)

    @property
    def pose(self) -> CameraPose:
        quat = matrix_to_quaternion(self.rotation)
        return CameraPose(tuple(float(v) for v in self.position),
                          tuple(float(v) for v in quat))

    def rvec_tvec(self) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV's world -> camera transform (Rodrigues vector, translation)."""
        r_cw = self.rotation.T
        rvec, _ = cv2.Rodrigues(r_cw)
        return rvec.reshape(3), -r_cw @ self.position

    def to_camera(self, points_world: np.ndarray) -> np.ndarray:
        return (np.asarray(points_world, dtype=float) - self.position) @ self.rotation

    def project(self, points_world: np.ndarray) -> np.ndarray:
        """World points (N x 3, m) -> imaged pixels (N x 2, distorted by the lens); points
        behind the camera give NaN."""
        pc = self.to_camera(points_world)
        with np.errstate(divide="ignore", invalid="ignore"):
            z = np.where(pc[:, 2] > 0.0, pc[:, 2], np.nan)
            xy = pc[:, :2] / z[:, None]
        xy = distort_normalized(xy, self.intrinsics)
        i = self.intrinsics
        return np.column_stack([i.fx * xy[:, 0] + i.cx, i.fy * xy[:, 1] + i.cy])

    def rays(self, pixels: np.ndarray) -> np.ndarray:
        """Unit-free ray directions in world (N x 3) through measured pixels (N x 2)."""
        px = self.undistort(pixels)
        d_cam = np.column_stack([
            (px[:, 0] - self.intrinsics.cx) / self.intrinsics.fx,
            (px[:, 1] - self.intrinsics.cy) / self.intrinsics.fy,
            np.ones(len(px)),
        ])
        return d_cam @ self.rotation.T

    def intersect_plane_z(self, pixels: np.ndarray, z: float) -> np.ndarray:
        """Where the measured pixels' rays meet the horizontal plane at height ``z`` (N x 3, m).

        Rays parallel to or pointing away from the plane give NaN.
        """
        d = self.rays(pixels)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (z - self.position[2]) / d[:, 2]
        s = np.where(s > 0.0, s, np.nan)
        return self.position + s[:, None] * d

    def table_view(self, z: float) -> np.ndarray:
        """(4, 2) x, y where the image's corners look at the plane of height ``z`` (m)."""
        i = self.intrinsics
        corners = np.array([[0.0, 0.0], [i.width - 1.0, 0.0], [i.width - 1.0, i.height - 1.0],
                            [0.0, i.height - 1.0]])
        return self.intersect_plane_z(corners, z)[:, :2]

# --- the calibration file ------------------------------------------------------------------
#: What a calibration file holds: the camera pose, as the detector's parameters name it.
CALIBRATION_PARAMETERS = ("camera_pose.position", "camera_pose.orientation_xyzw")


def load_camera_pose(path: str | Path) -> CameraPose:
    """Read ``camera_pose.*`` from a ``/**: ros__parameters:`` YAML file.

    Raises:
        MessageError: the file lacks the keys or holds a bad pose.
        OSError: the file cannot be read.
    """
    try:
        params = read_params_file(path)
    except ValueError as err:
        raise MessageError(str(path), None, str(err)) from None
    unknown = sorted(set(params) - set(CALIBRATION_PARAMETERS))
    if unknown:
        raise MessageError(str(path), None, f"unknown parameter(s) {unknown}")
    try:
        return CameraPose(tuple(params["camera_pose.position"]),
                          tuple(params["camera_pose.orientation_xyzw"]))
    except KeyError as err:
        raise MessageError(str(path), None, f"missing parameter {err.args[0]}") from None
    except TypeError as err:
        raise MessageError(str(path), None, f"malformed camera pose: {err}") from None


def save_camera_pose(path: str | Path, pose: CameraPose, comment: str = "") -> None:
    """Write the calibration file the detector reads (ROS ``--params-file`` format)."""
    px, py, pz = pose.position
    qx, qy, qz, qw = pose.orientation_xyzw
    lines = [
        "# Pose of camera_optical_frame (z forward, x right, y down) in world, written by",
        f"# densepack-calibrate on {dt.datetime.now(dt.UTC).isoformat(timespec='seconds')}.",
    ]
    lines += [f"# {line}" for line in comment.splitlines()]
    lines += [
        "/**:",
        "  ros__parameters:",
        f"    camera_pose.position: [{px:.6f}, {py:.6f}, {pz:.6f}]  # m, camera centre in world",
        f"    camera_pose.orientation_xyzw: [{qx:.8f}, {qy:.8f}, {qz:.8f}, {qw:.8f}]"
        "  # unit quaternion, world <- camera_optical_frame",
    ]
    Path(path).write_text("\n".join(lines) + "\n")
