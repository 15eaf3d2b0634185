"""Projection (pinhole and through a plumb_bob lens), ray-plane intersection and the
calibration file."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from msgs_py import MessageError
from msgs_py.camera import CameraIntrinsics, CameraPose
from nodes.common.camera_model import CameraModel, load_camera_pose, save_camera_pose
from nodes.detector.synthetic import overhead_camera


def test_overhead_camera_orientation_matches_the_contract():
    cam = overhead_camera()
    # image up (-v) is world +x, the long side (u) runs along world y, looking down
    centre = cam.project(np.array([[0.70, 0.0, 0.0]]))[0]
    up = cam.project(np.array([[0.80, 0.0, 0.0]]))[0]
    right = cam.project(np.array([[0.70, -0.1, 0.0]]))[0]
    assert centre == pytest.approx([cam.intrinsics.cx, cam.intrinsics.cy])
    assert up[1] < centre[1] and up[0] == pytest.approx(centre[0])
    assert right[0] > centre[0] and right[1] == pytest.approx(centre[1])


def test_rays_meet_the_plane_where_the_points_were():
    cam = overhead_camera()
    pts = np.array([[0.5, -0.3, 0.0508], [0.9, 0.25, 0.0508], [0.7, 0.0, 0.0508]])
    back = cam.intersect_plane_z(cam.project(pts), 0.0508)
    np.testing.assert_allclose(back, pts, atol=1e-12)


#: The sim camera's lens in its plumb_bob form.
LENS = (-0.10, 0.08, 0.0002, -0.00015, 0.0)
SPREAD = np.array([[x, y, z] for x in (0.42, 0.7, 0.98) for y in (-0.38, 0.0, 0.38)
                   for z in (0.0, 0.0508)])


def test_projection_through_the_lens_is_opencvs():
    cam = overhead_camera(focal_px=1400.0, distortion=LENS)
    rvec, tvec = cam.rvec_tvec()
    expected, _ = cv2.projectPoints(SPREAD, rvec, tvec, cam.k, np.array(LENS))
    np.testing.assert_allclose(cam.project(SPREAD), expected.reshape(-1, 2), atol=1e-9)
    # the lens moves the workspace's far corners by pixels: not a rounding error
    shift = np.linalg.norm(cam.project(SPREAD) - cam.pinhole().project(SPREAD), axis=1)
    assert shift.max() > 5.0


def test_undistort_inverts_the_lens_and_rays_use_it():
    cam = overhead_camera(focal_px=1400.0, distortion=LENS)
    measured = cam.project(SPREAD)
    np.testing.assert_allclose(cam.undistort(measured), cam.pinhole().project(SPREAD),
                               atol=1e-8)
    top = SPREAD[SPREAD[:, 2] > 0]
    np.testing.assert_allclose(cam.intersect_plane_z(cam.project(top), 0.0508), top,
                               atol=1e-10)


def test_rvec_tvec_round_trip():
    cam = overhead_camera()
    rvec, tvec = cam.rvec_tvec()
    again = CameraModel.from_rvec_tvec(cam.intrinsics, rvec, tvec)
    np.testing.assert_allclose(again.rotation, cam.rotation, atol=1e-12)
    np.testing.assert_allclose(again.position, cam.position, atol=1e-12)


def test_points_behind_the_camera_do_not_project():
    cam = overhead_camera()
    assert np.all(np.isnan(cam.project(np.array([[0.7, 0.0, 2.0]]))))


def test_calibration_file_round_trip(tmp_path):
    pose = CameraPose((0.71, -0.02, 1.28), (0.0, 0.0, math.sin(0.1), math.cos(0.1)))
    path = tmp_path / "cal.yaml"
    save_camera_pose(path, pose, comment="test")
    back = load_camera_pose(path)
    np.testing.assert_allclose(back.position, pose.position, atol=1e-6)
    np.testing.assert_allclose(back.orientation_xyzw, pose.orientation_xyzw, atol=1e-8)
    assert "/**:" in path.read_text() and "ros__parameters:" in path.read_text()


def test_calibration_file_without_the_pose_is_refused(tmp_path):
    path = tmp_path / "cal.yaml"
    path.write_text("/**:\n  ros__parameters:\n    camera_pose.position: [0, 0, 1]\n")
    with pytest.raises(MessageError, match=r"camera_pose\.orientation_xyzw"):
        load_camera_pose(path)


def test_bad_intrinsics_and_poses_are_refused():
    with pytest.raises(MessageError, match="fx"):
        CameraIntrinsics(640, 480, 0.0, 500.0, 320.0, 240.0)
    with pytest.raises(MessageError, match="unit quaternion"):
        CameraPose((0, 0, 1), (0, 0, 0, 2))


def test_nested_and_dotted_parameter_files_read_the_same(tmp_path):
    nested = tmp_path / "nested.yaml"
    nested.write_text("/**:\n  ros__parameters:\n    camera_pose:\n"
                      "      position: [0.7, 0.0, 1.25]\n"
                      "      orientation_xyzw: [0.7071068, -0.7071068, 0.0, 0.0]\n")
    pose = load_camera_pose(nested)
    assert pose.position == (0.7, 0.0, 1.25)
    np.testing.assert_allclose(
        CameraModel.from_pose(overhead_camera().intrinsics, pose).rotation,
        overhead_camera().rotation, atol=1e-6)  # q and -q: the nominal overhead camera
