"""Camera pose from tags at known poses: recovers a perturbed camera within the issue's bound."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from msgs_py import BlockPose, load_scene
from nodes.bench.perception_frames import LENSES
from nodes.common.camera_model import CameraModel
from nodes.common.paths import config_path
from nodes.common.transforms import rotation_angle
from nodes.detector.calibration import View, calibrate_camera, calibrate_views
from nodes.detector.synthetic import RenderStyle, overhead_camera, render_blocks
from nodes.detector.tags import TagFinder

BOARD = load_scene(config_path("scenes/calibration.yaml")).blocks


def tilted_camera() -> CameraModel:
    nominal = overhead_camera()
    tilt = cv2.Rodrigues(np.array([0.03, -0.02, 0.05]))[0]
    return CameraModel(nominal.intrinsics, tilt @ nominal.rotation,
                       nominal.position + np.array([0.012, -0.025, 0.04]))


def detect_frames(camera, blocks, n_frames=3):
    finder = TagFinder()
    style = RenderStyle(noise_std=2.0, blur_sigma_px=0.6)
    return [finder.find(cv2.cvtColor(render_blocks(camera, blocks, style,
                                                   rng=np.random.default_rng(k)),
                                     cv2.COLOR_RGB2GRAY)) for k in range(n_frames)]


@pytest.fixture(scope="module")
def true_camera():
    return tilted_camera()


def test_recovers_the_camera_within_2_mm_and_0_2_degrees(true_camera):
    frames = detect_frames(true_camera, BOARD)
    result = calibrate_camera(frames, true_camera.intrinsics, {b.id: b for b in BOARD})
    assert np.linalg.norm(result.camera.position - true_camera.position) < 0.5e-3
    assert math.degrees(rotation_angle(result.camera.rotation, true_camera.rotation)) < 0.05
    assert result.rms_px < 0.2 and result.n_frames == 3
    assert len(result.per_tag_px) == len(BOARD) and not result.dropped_tags
    assert max(result.position_sigma_m) < 1e-3 and "RMS" in result.report()


def test_the_lens_distortion_is_used():
    nominal = tilted_camera()
    lens = CameraModel(overhead_camera(focal_px=1400.0, distortion=(
        -0.10, 0.08, 0.0002, -0.00015, 0.0)).intrinsics, nominal.rotation, nominal.position)
    frames = detect_frames(lens, BOARD, n_frames=2)
    known = {b.id: b for b in BOARD}
    result = calibrate_camera(frames, lens.intrinsics, known)
    assert np.linalg.norm(result.camera.position - lens.position) < 0.5e-3
    assert math.degrees(rotation_angle(result.camera.rotation, lens.rotation)) < 0.05
    assert result.rms_px < 0.2
    # the same corners read as a pinhole camera's: pixels of residual, centimetres off
    naive = calibrate_camera(frames, lens.intrinsics.pinhole(), known)
    assert naive.rms_px > 0.5 or naive.dropped_tags
    assert np.linalg.norm(naive.camera.position - lens.position) > 5e-3


@pytest.mark.parametrize("model", ["rational_polynomial", "equidistant"])
def test_calibration_solves_through_every_lens_model(model):
    """OpenCV's PnP takes the rational lens's 8 coefficients as they are; a fisheye lens's
    corners are undistorted first. Either way the residual is measured on the image."""
    nominal = tilted_camera()
    lens = CameraModel(overhead_camera(focal_px=1400.0, distortion=LENSES[model].d,
                                       distortion_model=model).intrinsics,
                       nominal.rotation, nominal.position)
    frames = detect_frames(lens, BOARD, n_frames=2)
    result = calibrate_camera(frames, lens.intrinsics, {b.id: b for b in BOARD})
    assert np.linalg.norm(result.camera.position - lens.position) < 0.5e-3
    assert math.degrees(rotation_angle(result.camera.rotation, lens.rotation)) < 0.05
    assert result.rms_px < 0.2 and not result.dropped_tags
    assert max(result.position_sigma_m) < 1e-3


def test_one_block_at_several_placements_is_a_calibration(true_camera):
    """The arm-based routine's input: one block, one known pose per view."""
    views = []
    for k, b in enumerate(BOARD[::3]):
        block = BlockPose(7, b.x, b.y, b.theta)
        views += [View(f, {7: block}, placement=k)
                  for f in detect_frames(true_camera, [block], n_frames=1)]
    result = calibrate_views(views, true_camera.intrinsics, group_by="placement")
    assert np.linalg.norm(result.camera.position - true_camera.position) < 1e-3
    assert sorted(result.per_tag_px) == list(range(len(views)))
    assert "placements" in result.report()


def test_a_block_off_its_listed_pose_is_dropped(true_camera):
    moved = [b if b.id != 12 else BlockPose(12, b.x + 0.01, b.y, b.theta) for b in BOARD]
    frames = detect_frames(true_camera, moved, n_frames=1)
    result = calibrate_camera(frames, true_camera.intrinsics, {b.id: b for b in BOARD})
    assert result.dropped_tags == (12,)
    assert np.linalg.norm(result.camera.position - true_camera.position) < 1e-3


def test_too_few_known_tags_are_refused(true_camera):
    frames = detect_frames(true_camera, BOARD[:3], n_frames=1)
    with pytest.raises(ValueError, match="at least 4"):
        calibrate_camera(frames, true_camera.intrinsics, {b.id: b for b in BOARD})
