"""The detector and the calibration on frames rendered by the sim's own world (no ROS), with
the sim's realistic camera (lens distortion, blur, noise): every lens model, raw and
rectified as image_proc would, the camera known only from its camera_info message."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from msgs_py import load_scene
from msgs_py.camera import CameraIntrinsics
from msgs_py.ros.image import camera_info_to_camera, intrinsics_to_camera_info
from nodes.common.camera_model import load_camera_pose
from nodes.common.lens import rectify
from nodes.common.paths import config_path
from nodes.common.transforms import quaternion_to_matrix, rotation_angle
from nodes.detector.calibration import calibrate_camera
from nodes.detector.config import DetectorConfig
from nodes.detector.pipeline import BlockDetector
from nodes.detector.tags import TagFinder
from nodes.sim.camera import render_rgb
from nodes.sim.config import load_sim_configs
from nodes.sim.world import SimWorld
from tests.unit.detector.lenses import MODELS, sim_camera


def sim_world(scene_file: str) -> SimWorld:
    sim, camera, _ = load_sim_configs()
    world = SimWorld(sim, camera.model(),
                     load_scene(config_path(scene_file)), noise_std=camera.noise_std)
    world.step(60)
    return world


def intrinsics(world: SimWorld) -> CameraIntrinsics:
    """What the sim publishes on /camera/camera_info: k and the lens's d."""
    assert world.camera.intrinsics.distorted  # the realistic camera is the default
    return world.camera.intrinsics


@pytest.fixture(scope="module")
def board():
    world = sim_world("scenes/calibration.yaml")
    yield world
    world.close()


def test_calibration_recovers_the_true_camera_within_2_mm_and_0_2_degrees(board):
    finder = TagFinder()
    frames = [finder.find(cv2.cvtColor(board.render(), cv2.COLOR_RGB2GRAY)) for _ in range(3)]
    known = {b.id: b for b in load_scene(config_path("scenes/calibration.yaml")).blocks}
    result = calibrate_camera(frames, intrinsics(board), known)
    true_rotation = quaternion_to_matrix(board.camera.orientation_xyzw)
    assert np.linalg.norm(result.camera.position - board.camera.position) < 2e-3
    assert math.degrees(rotation_angle(result.camera.rotation, true_rotation)) < 0.2
    assert result.rms_px < 0.5 and not result.dropped_tags


def assert_exact(result, truth) -> None:
    got = result.blocks.by_id()
    assert sorted(got) == sorted(truth) and result.warnings == ()
    for block_id, b in truth.items():
        assert math.hypot(got[block_id].x - b.x, got[block_id].y - b.y) < 1e-3
        assert abs(math.degrees(math.remainder(got[block_id].theta - b.theta, 2 * math.pi))) < 0.5


@pytest.fixture(scope="module")
def default_scene():
    world = sim_world("scenes/default.yaml")
    yield world
    world.close()


def test_rendered_default_scene_gives_exact_ids_and_poses(default_scene):
    world = default_scene
    truth = {b.id: b for b in world.block_poses()}
    detector = BlockDetector(DetectorConfig(),
                             load_camera_pose(config_path("camera_calibration.yaml")))
    assert_exact(detector.process(world.render(), intrinsics(world), world.time_ns), truth)


@pytest.mark.parametrize("rectified", [False, True], ids=["raw", "rectified"])
@pytest.mark.parametrize("model", MODELS)
def test_every_lens_model_raw_or_rectified_gives_exact_poses(default_scene, model, rectified):
    """The sim's camera through each lens model; the detector reads the camera from the
    camera_info the sim publishes: k and d for the raw frame, p for the frame rectified as
    image_proc does it (``image_rectified``)."""
    world = default_scene
    camera = sim_camera(model)
    image = render_rgb(world.client, camera, 0.23, np.random.default_rng(1))
    info = intrinsics_to_camera_info(camera.intrinsics, 0, rectified=camera.rectified)
    if rectified:
        image = rectify(image, camera.intrinsics, camera.rectified)
    detector = BlockDetector(DetectorConfig(),
                             load_camera_pose(config_path("camera_calibration.yaml")))
    result = detector.process(image, camera_info_to_camera(info, rectified), world.time_ns)
    assert_exact(result, {b.id: b for b in world.block_poses()})
