"""Codecs between ``sensor_msgs/Image`` / ``CompressedImage`` / ``CameraInfo`` and numpy /
``CameraIntrinsics``.

Like the rest of ``msgs_py.ros``, this module touches ROS message classes (not rclpy) and is
used at a node's edge only; ``msgs_py.ros`` itself does not import it (it needs OpenCV).
Decoding validates everything a detector relies on (encoding, sizes, step, buffer length, a
usable camera matrix) and raises ``MessageError`` naming the field.
"""

from __future__ import annotations

import cv2
import numpy as np
from sensor_msgs.msg import CameraInfo, CompressedImage, Image

from msgs_py.camera import DISTORTION_COEFFICIENTS, CameraIntrinsics, UnsupportedLensModel
from msgs_py.errors import MessageError
from msgs_py.ros.stamps import ns_to_stamp

IDENTITY_3X3 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
#: 8-bit encodings we read, with their channel counts.
CHANNELS = {"rgb8": 3, "bgr8": 3, "rgba8": 4, "bgra8": 4, "mono8": 1}


def image_to_array(msg: Image) -> np.ndarray:
    """The image's pixels as H x W x C (or H x W for mono8) uint8, without copying.

    Raises:
        MessageError: an empty image, an unsupported encoding, a step or buffer length that
            does not match width x height.
    """
    if msg.encoding not in CHANNELS:
        raise MessageError("image.encoding", msg.encoding,
                           f"unsupported encoding; expected one of {sorted(CHANNELS)}")
    if msg.width == 0 or msg.height == 0:
        raise MessageError("image.width x height", (msg.width, msg.height), "empty image")
    channels = CHANNELS[msg.encoding]
    row = msg.width * channels
    if msg.step < row:
        raise MessageError("image.step", msg.step, f"smaller than width x channels = {row}")
    if len(msg.data) != msg.step * msg.height:
        raise MessageError("image.data", f"<{len(msg.data)} bytes>",
                           f"expected step x height = {msg.step * msg.height} bytes")
    buffer = np.frombuffer(memoryview(msg.data), dtype=np.uint8)
    rows = buffer.reshape(msg.height, msg.step)[:, :row]
    if channels == 1:
        return rows
    return rows.reshape(msg.height, msg.width, channels)


def array_to_image(pixels: np.ndarray, stamp_ns: int, frame_id: str = "camera_optical_frame",
                   encoding: str = "rgb8") -> Image:
    """An 8-bit H x W x C (or H x W) array as a ``sensor_msgs/Image``."""
    pixels = np.ascontiguousarray(pixels, dtype=np.uint8)
    channels = 1 if pixels.ndim == 2 else pixels.shape[2]
    if CHANNELS.get(encoding) != channels:
        raise MessageError("encoding", encoding, f"does not fit {channels}-channel pixels")
    msg = Image()
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = frame_id
    msg.height, msg.width = int(pixels.shape[0]), int(pixels.shape[1])
    msg.encoding = encoding
    msg.is_bigendian = 0
    msg.step = msg.width * channels
    msg.data = pixels.tobytes()
    return msg


#: ``CompressedImage.format`` of our frames, as image_transport's ``compressed`` plugin writes
#: it for an rgb8 image ("<raw encoding>; <codec> compressed <encoded channel order>").
COMPRESSED_FORMATS = {"png": "rgb8; png compressed bgr8", "jpeg": "rgb8; jpeg compressed bgr8"}
#: JPEG quality of ``/camera/image_raw/compressed``. On the sim's noisy 1280x960 frames, 90 is
#: ~115 kB and 3 ms a frame and leaves the detector's errors as they are on the raw frame; 75
#: starts to lose tags; PNG is lossless but ~1.9 MB (sensor noise) and ~90 ms (docs/nodes.md).
JPEG_QUALITY = 90
#: zlib level of PNGs: 1, the fastest; 9 saves ~7% for 5x the time.
PNG_LEVEL = 1


def array_to_compressed_image(pixels: np.ndarray, stamp_ns: int, codec: str = "jpeg",
                              frame_id: str = "camera_optical_frame") -> CompressedImage:
    """An 8-bit H x W x 3 RGB array as a ``sensor_msgs/CompressedImage`` (``png`` or
    ``jpeg``), as image_transport's ``compressed`` plugin publishes it."""
    if codec not in COMPRESSED_FORMATS:
        raise MessageError("codec", codec, f"expected one of {sorted(COMPRESSED_FORMATS)}")
    if pixels.ndim != 3 or pixels.shape[2] != 3:
        raise MessageError("pixels.shape", pixels.shape, "expected H x W x 3 (rgb8)")
    bgr = cv2.cvtColor(np.ascontiguousarray(pixels, dtype=np.uint8), cv2.COLOR_RGB2BGR)
    params = ([cv2.IMWRITE_PNG_COMPRESSION, PNG_LEVEL] if codec == "png"
              else [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    ok, encoded = cv2.imencode(".png" if codec == "png" else ".jpg", bgr, params)
    if not ok:
        raise MessageError("pixels", pixels.shape, f"{codec} encoding failed")
    msg = CompressedImage()
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = frame_id
    msg.format = COMPRESSED_FORMATS[codec]
    msg.data = encoded.tobytes()
    return msg


def compressed_image_to_array(msg: CompressedImage) -> np.ndarray:
    """The pixels of a PNG or JPEG ``CompressedImage`` as H x W x 3 RGB uint8.

    Raises:
        MessageError: empty data, or bytes no decoder reads.
    """
    if not len(msg.data):
        raise MessageError("compressed_image.data", "<0 bytes>", "empty image")
    buffer = np.frombuffer(memoryview(msg.data), dtype=np.uint8)
    bgr = cv2.imdecode(buffer, cv2.IMREAD_COLOR)
    if bgr is None:
        raise MessageError("compressed_image.data", f"<{len(msg.data)} bytes>",
                           f"not a decodable image (format '{msg.format}')")
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)


def camera_info_to_intrinsics(msg: CameraInfo) -> CameraIntrinsics:
    """The raw image's camera: ``k``, and ``d`` of ``distortion_model`` (plumb_bob: 5
    coefficients, rational_polynomial: 8, equidistant: 4).

    An empty or all-zero ``d`` is an ideal lens, whatever the model's name (as ROS's
    image_geometry reads it); ``p`` and ``r`` describe the rectified image and are not read
    (``camera_info_to_rectified``).

    Raises:
        UnsupportedLensModel: non-zero ``d`` of a model densepack has no maths for.
        MessageError: zero size, a non-positive or non-finite focal length, a malformed
            ``k``, a ``d`` of the wrong length, one that folds the image over, binning or
            a region of interest (not supported).
    """
    k = [float(v) for v in msg.k]
    if len(k) != 9 or k[1] != 0.0 or k[3] != 0.0 or k[6:] != [0.0, 0.0, 1.0]:
        raise MessageError("camera_info.k", k, "expected [fx, 0, cx, 0, fy, cy, 0, 0, 1]")
    _check_full_frame(msg)
    d = tuple(float(v) for v in msg.d)
    if not any(d):
        return CameraIntrinsics(int(msg.width), int(msg.height), k[0], k[4], k[2], k[5])
    if msg.distortion_model not in DISTORTION_COEFFICIENTS:
        raise UnsupportedLensModel(msg.distortion_model)
    return CameraIntrinsics(int(msg.width), int(msg.height), k[0], k[4], k[2], k[5], d,
                            msg.distortion_model)


def camera_info_to_rectified(msg: CameraInfo) -> CameraIntrinsics:
    """The rectified image's camera (image_proc's ``image_rect``): ``p``'s fx, fy, cx, cy and
    an ideal lens (the rectification already undid ``d``: using ``k`` and ``d`` again would
    correct twice).

    Raises:
        MessageError: ``p`` unset or malformed, a stereo pair's ``p`` (Tx, Ty not zero) or
            ``r`` (not the identity: the rectified image would be turned), zero size,
            binning or a region of interest.
    """
    p = [float(v) for v in msg.p]
    if not any(p):
        raise MessageError("camera_info.p", p, "p not set (an uncalibrated camera?)")
    if len(p) != 12 or p[1] != 0.0 or p[4] != 0.0 or p[8:] != [0.0, 0.0, 1.0, 0.0]:
        raise MessageError("camera_info.p", p, "expected [fx', 0, cx', Tx, 0, fy', cy', Ty, "
                           "0, 0, 1, 0]")
    if not (p[0] > 0.0 and p[5] > 0.0):
        raise MessageError("camera_info.p", p, "fx' and fy' must be > 0")
    if p[3] != 0.0 or p[7] != 0.0:
        raise MessageError("camera_info.p", p, "Tx, Ty not zero: the second camera of a "
                           "stereo pair; densepack reads a monocular camera")
    r = [float(v) for v in msg.r]
    if len(r) != 9 or any(abs(a - b) > 1e-9 for a, b in zip(r, IDENTITY_3X3, strict=True)):
        raise MessageError("camera_info.r", r, "expected the identity: a stereo "
                           "rectification turns the image, densepack reads a monocular camera")
    _check_full_frame(msg)
    return CameraIntrinsics(int(msg.width), int(msg.height), p[0], p[5], p[2], p[6])


def camera_info_to_camera(msg: CameraInfo, rectified: bool) -> CameraIntrinsics:
    """The camera an image of this camera_info was taken with: the raw camera (``k``, ``d``)
    for ``image_raw``, the rectified one (``p``, no distortion) for ``image_rect``."""
    return camera_info_to_rectified(msg) if rectified else camera_info_to_intrinsics(msg)


def _check_full_frame(msg: CameraInfo) -> None:
    if msg.width == 0 or msg.height == 0:
        raise MessageError("camera_info.width x height", (msg.width, msg.height),
                           "image size not set")
    if msg.binning_x > 1 or msg.binning_y > 1:
        raise MessageError("camera_info.binning_x x binning_y", (msg.binning_x, msg.binning_y),
                           "binned images are not supported")
    roi = msg.roi
    if (roi.x_offset, roi.y_offset) != (0, 0) or roi.width not in (0, msg.width) or (
            roi.height not in (0, msg.height)):
        raise MessageError("camera_info.roi", (roi.x_offset, roi.y_offset, roi.width,
                                               roi.height), "a region of interest is not "
                           "supported (full frames only)")


def intrinsics_to_camera_info(intrinsics: CameraIntrinsics, stamp_ns: int,
                              frame_id: str = "camera_optical_frame",
                              rectified: CameraIntrinsics | None = None) -> CameraInfo:
    """``CameraInfo`` of a monocular camera: ``k``, ``d`` and ``distortion_model`` from the
    intrinsics, ``r`` the identity, ``p`` the ``rectified`` camera (the one of
    ``image_rect``; default ``k``, right for an ideal lens only)."""
    i = intrinsics
    rect = intrinsics if rectified is None else rectified
    msg = CameraInfo()
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = frame_id
    msg.width, msg.height = i.width, i.height
    msg.distortion_model = i.distortion_model
    msg.d = [float(v) for v in i.d]
    msg.k = [i.fx, 0.0, i.cx, 0.0, i.fy, i.cy, 0.0, 0.0, 1.0]
    msg.r = list(IDENTITY_3X3)
    msg.p = [rect.fx, 0.0, rect.cx, 0.0, 0.0, rect.fy, rect.cy, 0.0, 0.0, 0.0, 1.0, 0.0]
    return msg
