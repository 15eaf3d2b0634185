"""The detector's projection (tag corners -> pixels -> rays) against the sim's camera and
OpenCV, for every lens model, and the rectified camera (camera_info's p)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from msgs_py.camera import CameraIntrinsics
from msgs_py.ros.image import camera_info_to_camera, intrinsics_to_camera_info
from nodes.common.camera_model import CameraModel
from nodes.common.lens import distort_pixels, rectified_camera, rectify, undistort_pixels
from nodes.detector.tag_geometry import tag_corners_world
from nodes.sim.config import CameraConfig
from tests.unit.detector.lenses import BLOCKS, MODELS, POINTS, sim_camera, sim_pose


def opencv_projection(camera: CameraModel, points: np.ndarray) -> np.ndarray:
    """OpenCV's own projection through the camera's lens (the reference)."""
    rvec, tvec = camera.rvec_tvec()
    i = camera.intrinsics
    if i.distortion_model == "equidistant":
        cam = camera.to_camera(points).reshape(-1, 1, 3)
        out, _ = cv2.fisheye.projectPoints(cam, np.zeros(3), np.zeros(3), camera.k,
                                           np.array(i.d))
    else:
        out, _ = cv2.projectPoints(points, rvec, tvec, camera.k, np.array(i.d))
    return out.reshape(-1, 2)


@pytest.mark.parametrize("model", MODELS)
def test_projection_is_opencvs_for_every_model(model):
    sim = sim_camera(model)
    camera = CameraModel.from_pose(sim.intrinsics, sim_pose(sim))
    np.testing.assert_allclose(camera.project(POINTS), opencv_projection(camera, POINTS),
                               atol=1e-8)
    # the lens moves the workspace's far corners by pixels: not a rounding error
    shift = np.linalg.norm(camera.project(POINTS) - camera.pinhole().project(POINTS), axis=1)
    assert shift.max() > 5.0


@pytest.mark.parametrize("model", MODELS)
def test_undistortion_inverts_the_lens_for_every_model(model):
    intrinsics = sim_camera(model).intrinsics
    ideal = np.array([[u, v] for u in np.linspace(-40, 1320, 9) for v in np.linspace(-30, 990, 7)])
    measured = distort_pixels(ideal, intrinsics)
    np.testing.assert_allclose(undistort_pixels(measured, intrinsics), ideal, atol=1e-7)


@pytest.mark.parametrize("model", MODELS)
def test_corner_rays_of_the_sims_camera_meet_the_tag_plane_at_the_corners(model):
    """The sim images a tag's corners (SimCamera.project); the detector, knowing the camera
    only from its camera_info message, casts them back onto the tag plane."""
    sim = sim_camera(model)
    corners = np.vstack([tag_corners_world(b) for b in BLOCKS])
    pixels = sim.project(corners)
    info = intrinsics_to_camera_info(sim.intrinsics, 0, rectified=sim.rectified)
    detector = CameraModel.from_pose(camera_info_to_camera(info, rectified=False), sim_pose(sim))
    np.testing.assert_allclose(detector.intersect_plane_z(pixels, corners[0, 2]), corners,
                               atol=1e-9)


@pytest.mark.parametrize("model", MODELS)
def test_a_rectified_image_is_read_with_p_and_no_distortion(model):
    """image_rect is imaged by p's pinhole: with image_rectified the detector casts rays from
    p; reading it as the raw image (k and d again) corrects twice, millimetres off."""
    sim = sim_camera(model)
    rect = sim.rectified
    corners = np.vstack([tag_corners_world(b) for b in BLOCKS])
    pixels = CameraModel.from_pose(rect, sim_pose(sim)).project(corners)  # in image_rect
    info = intrinsics_to_camera_info(sim.intrinsics, 0, rectified=rect)
    right = CameraModel.from_pose(camera_info_to_camera(info, rectified=True), sim_pose(sim))
    np.testing.assert_allclose(right.intersect_plane_z(pixels, corners[0, 2]), corners,
                               atol=1e-9)
    twice = CameraModel.from_pose(camera_info_to_camera(info, rectified=False), sim_pose(sim))
    error = np.linalg.norm(twice.intersect_plane_z(pixels, corners[0, 2]) - corners, axis=1)
    assert error.max() > 1e-3


@pytest.mark.parametrize("model", MODELS)
def test_p_is_not_k_and_alpha_chooses_what_the_rectified_image_keeps(model):
    sim = sim_camera(model)
    raw = sim.intrinsics
    cropped, whole = rectified_camera(raw, 0.0), rectified_camera(raw, 1.0)
    assert cropped.k != raw.k and whole.k != raw.k and not cropped.distorted
    assert whole.fx < cropped.fx  # keeping more of the raw image takes a wider view
    if model == "equidistant":
        return  # OpenCV's fisheye balance is set from the edges' midpoints: approximate
    w, h = raw.width - 1, raw.height - 1
    edges = np.array([[u, v] for u in np.linspace(0, w, 17) for v in (0, h)]
                     + [[u, v] for u in (0, w) for v in np.linspace(0, h, 13)])
    # alpha 0: every pixel of the rectified image shows a raw pixel (its edges map inside)
    inside = raw_pixels_of_rectified(edges, raw, cropped)
    assert np.all((inside >= -0.5) & (inside <= [w + 0.5, h + 0.5]))
    # alpha 1: every raw pixel lands in the rectified image
    kept = CameraModel(whole, np.eye(3), np.zeros(3)).project(
        np.column_stack([undistort_normalised(edges, raw), np.ones(len(edges))]))
    assert np.all((kept >= -0.5) & (kept <= [w + 0.5, h + 0.5]))


def undistort_normalised(pixels, intrinsics: CameraIntrinsics) -> np.ndarray:
    ideal = undistort_pixels(pixels, intrinsics)
    return (ideal - [intrinsics.cx, intrinsics.cy]) / [intrinsics.fx, intrinsics.fy]


def raw_pixels_of_rectified(pixels, raw: CameraIntrinsics, rect: CameraIntrinsics):
    normalised = (np.asarray(pixels, float) - [rect.cx, rect.cy]) / [rect.fx, rect.fy]
    return distort_pixels(normalised * [raw.fx, raw.fy] + [raw.cx, raw.cy], raw)


def test_rectify_resamples_the_raw_image_into_p():
    """A bright dot imaged through the lens appears, after rectify, where p's pinhole
    images the same ray (as image_proc's rectify node would put it)."""
    raw = sim_camera("plumb_bob").intrinsics
    rect = rectified_camera(raw, 0.0)
    ideal = np.array([[100.0, 80.0], [1180.0, 900.0], [640.0, 480.0]])
    image = np.zeros((raw.height, raw.width), np.uint8)
    for u, v in distort_pixels(ideal, raw):
        cv2.circle(image, (round(u * 16), round(v * 16)), 48, 255, -1, cv2.LINE_AA, 4)
    out = rectify(image, raw, rect).astype(float)
    for u, v in ideal:
        x, y = (np.array([u, v]) - [raw.cx, raw.cy]) / [raw.fx, raw.fy] * [rect.fx, rect.fy]
        x, y = x + rect.cx, y + rect.cy
        window = out[int(y) - 8:int(y) + 9, int(x) - 8:int(x) + 9]
        vv, uu = np.mgrid[int(y) - 8:int(y) + 9, int(x) - 8:int(x) + 9]
        centroid = np.array([(uu * window).sum(), (vv * window).sum()]) / window.sum()
        assert np.linalg.norm(centroid - [x, y]) < 0.05


def test_an_ideal_lens_has_p_equal_to_k():
    camera = CameraConfig(distortion=(0.0,) * 8).model()
    assert camera.rectified.k == camera.intrinsics.k and not camera.rectified.distorted
