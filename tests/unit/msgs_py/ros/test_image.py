"""sensor_msgs Image / CameraInfo codecs: round trips (every lens model, p apart from k) and
refusals naming the field."""

from __future__ import annotations

import numpy as np
import pytest

from msgs_py import MessageError
from msgs_py.camera import CameraIntrinsics, UnsupportedLensModel
from msgs_py.ros import stamp_to_ns
from msgs_py.ros.image import (
    array_to_image,
    camera_info_to_camera,
    camera_info_to_intrinsics,
    camera_info_to_rectified,
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
RATIONAL = (0.4003, 0.1268, 0.0002, -0.00015, 0.0392, 0.5, 0.1, 0.0)
FISHEYE = (0.2321, 0.1339, -0.0003, 0.3531)
#: A rectified camera as getOptimalNewCameraMatrix gives one: p differs from k.
RECTIFIED = CameraIntrinsics(1280, 960, 1376.2, 1377.9, 641.3, 478.2)


@pytest.mark.parametrize("model,d", [("plumb_bob", (0.0,) * 5), ("plumb_bob", LENS),
                                     ("rational_polynomial", RATIONAL),
                                     ("equidistant", FISHEYE)])
def test_camera_info_round_trip(model, d):
    intr = CameraIntrinsics(1280, 960, 1100.0, 1101.0, 639.5, 479.5, d, model)
    msg = intrinsics_to_camera_info(intr, 5, "camera_optical_frame", rectified=RECTIFIED)
    assert list(msg.k)[:3] == [1100.0, 0.0, 639.5] and msg.header.frame_id == (
        "camera_optical_frame")
    assert list(msg.p) == [1376.2, 0.0, 641.3, 0.0, 0.0, 1377.9, 478.2, 0.0, 0.0, 0.0, 1.0, 0.0]
    assert msg.distortion_model == model and tuple(msg.d) == pytest.approx(d)
    assert camera_info_to_intrinsics(msg) == intr
    assert camera_info_to_intrinsics(msg).distorted == any(d)
    # the image_rect camera: p's intrinsics and no lens, never k and d again
    assert camera_info_to_rectified(msg) == RECTIFIED and not RECTIFIED.distorted
    assert camera_info_to_camera(msg, rectified=True) == RECTIFIED
    assert camera_info_to_camera(msg, rectified=False) == intr


def test_without_a_rectified_camera_p_is_k():
    intr = CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240)
    assert camera_info_to_rectified(intrinsics_to_camera_info(intr, 0)) == intr


@pytest.mark.parametrize("model", ["", "plumb_bob", "equidistant", "kannala_brandt"])
def test_an_empty_or_all_zero_d_is_an_ideal_lens_whatever_the_model(model):
    msg = intrinsics_to_camera_info(CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240), 0)
    for d in ([], [0.0] * 4):
        msg.d, msg.distortion_model = d, model
        assert camera_info_to_intrinsics(msg) == CameraIntrinsics(640, 480, 500.0, 500.0,
                                                                  320, 240)


def test_an_unknown_lens_model_is_refused_naming_it():
    msg = intrinsics_to_camera_info(CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240), 0)
    msg.distortion_model, msg.d = "kannala_brandt", [0.1, 0.0, 0.0, 0.0]
    with pytest.raises(UnsupportedLensModel, match="kannala_brandt") as err:
        camera_info_to_intrinsics(msg)
    assert err.value.model == "kannala_brandt" and "rational_polynomial" in str(err.value)
    assert isinstance(err.value, MessageError)


@pytest.mark.parametrize("model,d,field", [
    ("rational_polynomial", [0.1, 0.0, 0.0, 0.0, 0.0], "8 coefficients"),
    ("plumb_bob", [0.1, 0.0, 0.0, 0.0], "5 coefficients"),
    ("equidistant", [0.1, 0.0, 0.0, 0.0, 0.0], "4 coefficients"),
    ("plumb_bob", [0.1, 0.0, float("nan"), 0.0, 0.0], "finite"),
    # k1 = -0.9: r (1 + k1 r^2) turns back at r = 0.61, inside this image (corners 0.8)
    ("plumb_bob", [-0.9, 0.0, 0.0, 0.0, 0.0], "folds over"),
    # the denominator 1 - 2 r^2 crosses zero at r = 0.71, inside the image's 1.25 margin
    ("rational_polynomial", [0.0, 0.0, 0.0, 0.0, 0.0, -2.0, 0.0, 0.0], "folds over"),
    ("equidistant", [-0.6, 0.0, 0.0, 0.0], "folds over"),
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


@pytest.mark.parametrize("change,field", [
    ({"p": [0.0] * 12}, r"p not set"),
    ({"p": [500.0, 0.0, 320.0, -25.0, 0.0, 500.0, 240.0, 0.0, 0.0, 0.0, 1.0, 0.0]}, "stereo"),
    ({"r": [0.0, -1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]}, r"camera_info\.r"),
    ({"binning_x": 2}, "binning"),
])
def test_a_rectified_camera_it_cannot_use_is_refused(change, field):
    msg = intrinsics_to_camera_info(CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240), 0)
    for key, value in change.items():
        setattr(msg, key, value)
    with pytest.raises(MessageError, match=field):
        camera_info_to_rectified(msg)


def test_a_region_of_interest_is_refused():
    msg = intrinsics_to_camera_info(CameraIntrinsics(640, 480, 500.0, 500.0, 320, 240), 0)
    msg.roi.x_offset, msg.roi.width, msg.roi.height = 10, 320, 240
    with pytest.raises(MessageError, match="region of interest"):
        camera_info_to_intrinsics(msg)
