"""sensor_msgs/CompressedImage codecs: image_transport's format string, JPEG and PNG."""

from __future__ import annotations

import numpy as np
import pytest
from sensor_msgs.msg import CompressedImage

from msgs_py import MessageError
from msgs_py.ros import stamp_to_ns
from msgs_py.ros.image import array_to_compressed_image, compressed_image_to_array


def gradient(h: int = 48, w: int = 64) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w]
    return np.stack([x * 4, y * 5, (x + y) * 2], axis=-1).astype(np.uint8)


def test_jpeg_is_the_default_and_keeps_the_picture():
    pixels = gradient()
    msg = array_to_compressed_image(pixels, 1_500_000_000, frame_id="cam")
    assert msg.format == "rgb8; jpeg compressed bgr8"
    assert bytes(msg.data[:2]) == b"\xff\xd8"  # a JPEG stream
    assert stamp_to_ns(msg.header.stamp) == 1_500_000_000 and msg.header.frame_id == "cam"
    back = compressed_image_to_array(msg)
    assert back.shape == pixels.shape
    assert np.abs(back.astype(int) - pixels).mean() < 2.0  # channels not swapped, little loss


def test_png_is_lossless():
    pixels = np.random.default_rng(0).integers(0, 256, (30, 40, 3), dtype=np.uint8)
    msg = array_to_compressed_image(pixels, 0, codec="png")
    assert msg.format == "rgb8; png compressed bgr8"
    assert np.array_equal(compressed_image_to_array(msg), pixels)


def test_refuses_what_it_cannot_encode_or_decode():
    with pytest.raises(MessageError, match="codec"):
        array_to_compressed_image(gradient(), 0, codec="webp")
    with pytest.raises(MessageError, match="shape"):
        array_to_compressed_image(np.zeros((4, 4), np.uint8), 0)
    with pytest.raises(MessageError, match="empty"):
        compressed_image_to_array(CompressedImage(format="jpeg"))
    with pytest.raises(MessageError, match="not a decodable image"):
        compressed_image_to_array(CompressedImage(format="jpeg", data=b"not a jpeg at all"))
