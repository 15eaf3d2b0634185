"""densepack-calibrate against a synthetic camera: frames in, camera pose file out."""

from __future__ import annotations

import math
import subprocess
import threading
import time

import cv2
import numpy as np
import pytest
from rclpy.parameter import Parameter
from sensor_msgs.msg import CameraInfo, Image

from msgs_py import load_scene
from msgs_py.ros.image import array_to_image, intrinsics_to_camera_info
from nodes.calibration.cli import CalibrateNode
from nodes.common.camera_model import CameraModel, load_camera_pose
from nodes.common.paths import config_path
from nodes.common.qos import CAMERA
from nodes.common.transforms import rotation_angle
from nodes.detector.synthetic import RenderStyle, overhead_camera, render_blocks
from tests.helpers import script

pytestmark = pytest.mark.ros

BOARD = load_scene(config_path("scenes/calibration.yaml")).blocks


def true_camera() -> CameraModel:
    nominal = overhead_camera()
    tilt = cv2.Rodrigues(np.array([-0.02, 0.025, 0.04]))[0]
    return CameraModel(nominal.intrinsics, tilt @ nominal.rotation,
                       nominal.position + np.array([-0.015, 0.02, 0.03]))


class Streamer:
    """Publishes frames of the board at ~5 Hz from a background thread until stopped."""

    def __init__(self, ros, camera: CameraModel) -> None:
        self.images = ros.publisher("/camera/image_raw", Image, CAMERA)
        self.infos = ros.publisher("/camera/camera_info", CameraInfo, CAMERA)
        self.frames = [render_blocks(camera, BOARD, RenderStyle(noise_std=2.0,
                                                                blur_sigma_px=0.6),
                                     rng=np.random.default_rng(k)) for k in range(3)]
        self.camera = camera
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.run, daemon=True)

    def run(self) -> None:
        k = 0
        while not self.stop.is_set():
            stamp = 1_000_000_000 + k * 200_000_000
            self.infos.publish(intrinsics_to_camera_info(self.camera.intrinsics, stamp))
            self.images.publish(array_to_image(self.frames[k % len(self.frames)], stamp))
            k += 1
            time.sleep(0.2)

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(5.0)


def assert_close(pose, camera: CameraModel) -> None:
    position_err = np.linalg.norm(np.asarray(pose.position) - camera.position)
    angle = CameraModel.from_pose(camera.intrinsics, pose).rotation
    assert position_err < 2e-3
    assert math.degrees(rotation_angle(angle, camera.rotation)) < 0.2


def test_calibrate_node_recovers_the_camera_pose(ros, tmp_path):
    camera = true_camera()
    out = tmp_path / "camera_calibration.yaml"
    node = ros.add(CalibrateNode(context=ros.context, parameter_overrides=[
        Parameter("frames", value=3), Parameter("output_file", value=str(out))]))
    with Streamer(ros, camera):
        assert node.done.wait(30.0)
    result = node.solve()
    assert result.rms_px < 0.2 and result.n_frames == 3
    node.write(result)
    assert_close(load_camera_pose(out), camera)


def test_calibrate_command_writes_the_file(ros, tmp_path):
    camera = true_camera()
    out = tmp_path / "cal.yaml"
    with Streamer(ros, camera):
        proc = subprocess.run(
            [script("densepack-calibrate"), "--ros-args", "-p", "frames:=2",
             "-p", f"output_file:={out}", "-p", "timeout_s:=30.0"],
            capture_output=True, text=True, timeout=90)
    assert proc.returncode == 0, proc.stderr
    assert "reprojection residual: RMS" in proc.stdout
    assert_close(load_camera_pose(out), camera)


def test_calibrate_command_fails_cleanly_without_a_camera(tmp_path):
    out = tmp_path / "cal.yaml"
    proc = subprocess.run(
        [script("densepack-calibrate"), "--ros-args", "-p", "timeout_s:=1.0",
         "-p", f"output_file:={out}"], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 1 and "no camera frame arrived" in proc.stderr
    assert not out.exists()
