"""sensor_msgs Image / CameraInfo codecs: round trips and refusals naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from msgs_py import MessageError
from msgs_py.camera import CameraIntrinsics
from msgs_py.ros import stamp_to_ns
from msgs_py.ros.image import (
    array_to_image,
    camera_info_to_intrinsics,
    image_to_array,
    intrinsics_to_camera_info,
)


def test_image_round_trip_keeps_pixels_and_stamp():
    pixels = np.random.default_rng(0).integers(0, 255, (6, 8, 3), dtype=np.uint8)
    msg = array_to_image(pixels, 1_500_000_123)
    assert msg.encoding == "rgb8" and msg.step == 24 and stamp_to_ns(msg.header.stamp) == (
        1_500_000_123)
    np.testing.assert_array_equal(image_to_array(msg), pixels)


def test_padded_rows_are_cropped():
    msg = array_to_image(np.zeros((4, 5), np.uint8), 0, encoding="mono8")
    msg.step = 8
    msg.data = bytes(range(32))
    assert image_to_array(msg).shape == (4, 5)


@pytest.mark.parametrize("change,field", [
    ({"encoding": "32FC1"}, "image.encoding"),
    ({"width": 0, "height": 0, "step": 0, "data": b""}, "empty image"),
    ({"data": bytes(10)}, "image.data"),
    ({"step": 3}, "image.step"),
])
def test_bad_images_are_refused(change, field):
    msg = array_to_image(np.zeros((4, 5, 3), np.uint8), 0)
    for key, value in change.items():
        setattr(msg, key, value)
    with pytest.raises(MessageError, match=field):
        image_to_array(msg)


LENS = (-0.10, 0.08, 0.0002, -0.00015, 0.0)


@pytest.mark.parametrize("d", [(0.0,) * 5, LENS])
def test_camera_info_round_trip(d):
    intr = CameraIntrinsics(1280, 960, 1100.0, 1101.0, 639.5, 479.5, d)
    msg = intrinsics_to_camera_info(intr, 5, "camera_optical_frame")
    assert list(msg.p)[:3] == [1100.0, 0.0, 639.5] and msg.header.frame_id == (
        "camera_optical_frame")
    assert msg.distortion_model == "plumb_bob" and tuple(msg.d) == pytest.approx(d)
    assert camera_info_to_intrinsics(msg) == intr
    assert camera_info_to_intrinsics(msg).distorted == any(d)


def test_an_empty_d_is_an_ideal_lens():
    msg = intrinsics_to_camera_info(CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240), 0)
    msg.d, msg.distortion_model = [], ""
    assert camera_info_to_intrinsics(msg).d == (0.0,) * 5


@pytest.mark.parametrize("model,d,field", [
    ("rational_polynomial", [0.1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], "distortion_model"),
    ("plumb_bob", [0.1, 0.0, 0.0, 0.0], "5 coefficients"),
    ("plumb_bob", [0.1, 0.0, float("nan"), 0.0, 0.0], "finite"),
    # k1 = -0.9: r (1 + k1 r^2) turns back at r = 0.61, inside this image (corners 0.8)
    ("plumb_bob", [-0.9, 0.0, 0.0, 0.0, 0.0], "folds over"),
])
def test_bad_distortion_is_refused(model, d, field):
    msg = intrinsics_to_camera_info(CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240), 0)
    msg.distortion_model, msg.d = model, d
    with pytest.raises(MessageError, match=field):
        camera_info_to_intrinsics(msg)


def test_bad_camera_info_is_refused():
    msg = intrinsics_to_camera_info(CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240), 0)
    msg.k = [0.0] * 9
    with pytest.raises(MessageError, match=r"camera_info\.k"):
        camera_info_to_intrinsics(msg)

