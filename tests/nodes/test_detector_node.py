"""densepack-detector spun in-process: synthetic frames in, BlockPoseArrays (and viewer
MarkerArrays) out, bad input survived."""

from __future__ import annotations

import math
import threading
import time

import numpy as np
import pytest
from densepack_interfaces.msg import BlockPoseArray
from rclpy.parameter import Parameter
from sensor_msgs.msg import CameraInfo, Image
from std_srvs.srv import Trigger
from visualization_msgs.msg import Marker, MarkerArray

from msgs_py import BlockPose
from msgs_py.ros import block_set_from_msg, ns_to_stamp, stamp_to_ns
from msgs_py.ros.image import array_to_image, intrinsics_to_camera_info
from nodes.common.camera_model import CameraModel
from nodes.common.lens import rectified_camera
from nodes.common.qos import CAMERA as CAMERA_QOS
from nodes.common.qos import camera_qos
from nodes.detector.node import DetectorNode
from nodes.detector.sync import Drop
from nodes.detector.synthetic import RenderStyle, overhead_camera, render_blocks

pytestmark = pytest.mark.ros

# A smaller frame than the cell's (640 x 480, same ground resolution) keeps DDS traffic light.
CAMERA = overhead_camera(width=640, height=480, focal_px=1100.0)
#: The sim camera's lens in its plumb_bob form (k1, k2, p1, p2, k3).
LENS = (-0.10, 0.08, 0.0002, -0.00015, 0.0)
BLOCKS = [BlockPose(i, 0.62 + 0.08 * (i % 3), -0.12 + 0.12 * (i // 3), 0.5 * i - 2.0)
          for i in range(6)]


def params(**extra) -> list[Parameter]:
    pose = CAMERA.pose
    values = {"camera_pose.position": list(pose.position),
              "camera_pose.orientation_xyzw": list(pose.orientation_xyzw),
              "allowed_ids": "0-24"}
    values.update(extra)
    return [Parameter(k, value=v) for k, v in values.items()]


def frame(blocks=BLOCKS, **kwargs) -> np.ndarray:
    return render_blocks(CAMERA, blocks, RenderStyle(noise_std=2.0, blur_sigma_px=0.6),
                         rng=np.random.default_rng(0), **kwargs)


class Camera:
    """Publishes image + camera_info pairs the way the sim does (same stamp)."""

    def __init__(self, ros, qos=CAMERA_QOS, topic="/camera/image_raw", info=None) -> None:
        self.ros = ros
        self.images = ros.publisher(topic, Image, qos)
        self.infos = ros.publisher("/camera/camera_info", CameraInfo, qos)
        self.info = info
        ros.wait_for_subscribers(self.images)
        ros.wait_for_subscribers(self.infos)
        self.stamp_ns = 1_000_000_000

    def send(self, pixels=None, stamp_ns=None, image=None, info=None, info_stamp_ns=None):
        if stamp_ns is None:
            self.stamp_ns += 100_000_000
            stamp_ns = self.stamp_ns
        info = info or self.info or intrinsics_to_camera_info(CAMERA.intrinsics, 0)
        info.header.stamp = ns_to_stamp(stamp_ns if info_stamp_ns is None else info_stamp_ns)
        image = image or array_to_image(pixels, 0)
        image.header.stamp = ns_to_stamp(stamp_ns)
        self.infos.publish(info)
        self.images.publish(image)
        return stamp_ns


def detection(ros, camera: Camera, pixels, timeout=15.0, topic="/blocks/detected",
              msg_type=BlockPoseArray):
    """Send the frame until a detection with its stamp comes back (sensor QoS may drop)."""
    def stamp_of(msg) -> int:
        header = msg.markers[0].header if msg_type is MarkerArray else msg.header
        return stamp_to_ns(header.stamp)

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        stamp = camera.send(pixels)
        try:
            return ros.wait_for_message(
                topic, msg_type, timeout=1.0,
                predicate=lambda m, s=stamp: (msg_type is not MarkerArray or bool(m.markers))
                and stamp_of(m) == s)
        except TimeoutError:
            continue
    raise TimeoutError("no detection for the frames sent")


def wait_for_warning(node, text: str, timeout=10.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if any(text in w for w in node.recent_warnings):
            return
        time.sleep(0.05)
    raise AssertionError(f"no warning containing '{text}' in {list(node.recent_warnings)}")


def collect(ros) -> list:
    """Every /blocks/detected message from now on (the subscription lives as long as the
    harness: destroying it while the executor spins would race)."""
    published: list = []
    ros.probe.create_subscription(BlockPoseArray, "/blocks/detected", published.append, 10)
    return published


@pytest.fixture
def setup(ros):
    node = ros.add(DetectorNode(context=ros.context, parameter_overrides=params()))
    return node, Camera(ros)


def test_a_frame_becomes_block_poses_with_the_right_ids(ros, setup):
    _node, camera = setup
    msg = detection(ros, camera, frame())
    blocks = block_set_from_msg(msg)
    assert blocks.ids == [b.id for b in BLOCKS] and blocks.frame_id == "world"
    for b in BLOCKS:
        got = blocks.by_id()[b.id]
        assert math.hypot(got.x - b.x, got.y - b.y) < 1e-3
        assert abs(math.remainder(got.theta - b.theta, 2 * math.pi)) < math.radians(0.5)
    assert set(blocks.reprojection_px) == set(blocks.ids)


def test_a_hidden_block_is_missing_and_a_delete_marker(ros, setup):
    _node, camera = setup
    detection(ros, camera, frame())
    h = BLOCKS[2]
    arm = np.array([[h.x - 0.04, h.y - 0.04, 0.4], [h.x + 0.04, h.y - 0.04, 0.4],
                    [h.x + 0.04, h.y + 0.04, 0.4], [h.x - 0.04, h.y + 0.04, 0.4]])
    hidden = frame(occluders=[arm])
    assert block_set_from_msg(detection(ros, camera, hidden)).missing == (h.id,)
    markers = detection(ros, camera, hidden, topic="/blocks/detected/markers",
                        msg_type=MarkerArray)
    assert [m.id for m in markers.markers if m.action == Marker.DELETE] == [h.id]
    assert sorted(m.id for m in markers.markers if m.action == Marker.ADD) == sorted(
        b.id for b in BLOCKS if b.id != h.id)
    reply = ros.call_service("/detector/reset", Trigger)
    assert reply.success
    assert block_set_from_msg(detection(ros, camera, hidden)).missing == ()


def test_duplicate_and_unknown_ids_are_dropped(ros, setup):
    node, camera = setup
    blocks = [BlockPose(1, 0.62, -0.1, 0.0), BlockPose(1, 0.78, 0.1, 0.3),
              BlockPose(30, 0.7, 0.12, 0.0), BlockPose(2, 0.7, -0.12, 0.5)]
    msg = detection(ros, camera, frame(blocks))
    assert block_set_from_msg(msg).ids == [2]
    wait_for_warning(node, "more than once")
    wait_for_warning(node, "outside allowed_ids")


def _bad_images():
    good = array_to_image(frame(), 0)
    wrong_encoding = array_to_image(frame(), 0)
    wrong_encoding.encoding = "16UC1"
    truncated = array_to_image(frame(), 0)
    truncated.data = bytes(truncated.data[:1000])
    small = array_to_image(frame()[:240, :320].copy(), 0)
    empty = Image(encoding="rgb8")
    return good, {"16UC1": wrong_encoding, "image.data": truncated, "differs from camera_info":
                  small, "empty image": empty}


def test_bad_frames_are_skipped_with_a_warning_and_nothing_stale_is_published(ros, setup):
    node, camera = setup
    detection(ros, camera, frame())
    _, bad = _bad_images()
    published = collect(ros)
    for text, image in bad.items():
        camera.send(image=image)
        wait_for_warning(node, text)
    bad_info = intrinsics_to_camera_info(CAMERA.intrinsics, 0)
    bad_info.k = [0.0] * 9
    camera.send(frame(), info=bad_info)
    wait_for_warning(node, "camera_info.k")
    time.sleep(0.3)
    assert published == []  # not one message for a bad frame
    assert block_set_from_msg(detection(ros, camera, frame())).ids == [0, 1, 2, 3, 4, 5]


def test_images_without_matching_camera_info_are_not_processed(ros, setup):
    node, camera = setup
    published = collect(ros)
    pixels = frame()
    for _ in range(8):
        camera.stamp_ns += 100_000_000
        camera.send(pixels, stamp_ns=camera.stamp_ns, info_stamp_ns=camera.stamp_ns + 1)
        time.sleep(0.1)
    wait_for_warning(node, "no camera_info")
    assert published == [] and node.frames == 0


def test_a_frame_older_than_the_last_one_is_not_published(ros, setup):
    node, camera = setup
    detection(ros, camera, frame())
    old = camera.stamp_ns - 50_000_000
    frames_before = node.frames
    camera.send(frame(), stamp_ns=old)
    wait_for_warning(node, "not newer than the last frame")
    assert node.frames == frames_before


def test_without_a_camera_pose_the_node_refuses_to_start(ros, tmp_path):
    overrides = [Parameter("calibration_file", value=str(tmp_path / "none.yaml"))]
    with pytest.raises(ValueError, match="densepack-calibrate"):
        DetectorNode(context=ros.context, parameter_overrides=overrides)


def test_a_simulation_reset_restarts_the_stamps_without_losing_frames(ros):
    from rosgraph_msgs.msg import Clock

    node = ros.add(DetectorNode(context=ros.context,
                                parameter_overrides=params(use_sim_time=True)))
    camera = Camera(ros)
    clock = ros.publisher("/clock", Clock)
    ros.wait_for_subscribers(clock)
    clock.publish(Clock(clock=ns_to_stamp(800_000_000)))
    camera.stamp_ns = 800_000_000
    first = stamp_to_ns(detection(ros, camera, frame()).header.stamp)
    # the sim restarts its time at 0: frames stamped 0.1 s are new frames, not stale ones
    # (a jump back this small is told from a late frame only by /clock)
    clock.publish(Clock(clock=ns_to_stamp(50_000_000)))
    time.sleep(0.2)
    camera.stamp_ns = 0
    msg = detection(ros, camera, frame())
    assert stamp_to_ns(msg.header.stamp) < first
    wait_for_warning(node, "the clock jumped back")


def test_a_best_effort_camera_driver_is_heard_with_best_effort_subscriptions(ros):
    """A driver's sensor-data QoS: a reliable subscription would never match it."""
    ros.add(DetectorNode(context=ros.context,
                         parameter_overrides=params(image_reliability="best_effort")))
    camera = Camera(ros, qos=camera_qos("best_effort"))
    blocks = block_set_from_msg(detection(ros, camera, frame()))
    assert blocks.ids == [b.id for b in BLOCKS]


def wait_until(condition, what: str, timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(0.01)


def test_frames_faster_than_detection_leave_only_the_newest_and_are_counted(ros, setup):
    """While the worker detects one frame, three more complete: only the newest of them is
    processed next, the two others are counted as superseded, nothing goes back in time."""
    node, camera = setup
    published = collect(ros)
    gate, busy = threading.Event(), threading.Event()
    detect = node.detector.process

    def slow_detect(*args, **kwargs):
        busy.set()
        assert gate.wait(20.0)
        return detect(*args, **kwargs)

    node.detector.process = slow_detect
    pixels = frame()
    first = camera.send(pixels)
    assert busy.wait(10.0)
    later = []
    for _ in range(3):
        later.append(camera.send(pixels))
        wait_until(lambda: node.inbox.pairer.last_ns == later[-1], "the frame to complete")
    gate.set()
    wait_until(lambda: len(published) == 2, "two detections")
    time.sleep(0.3)
    assert [stamp_to_ns(m.header.stamp) for m in published] == [first, later[-1]]
    assert node.inbox.snapshot()[0] == {Drop.SUPERSEDED: 2} and node.frames == 2


def test_rectified_images_are_read_with_p_and_no_distortion(ros):
    """image_proc's image_rect: the detector subscribes to it with image_rectified and takes
    p's camera, not k and d (which would correct the lens twice)."""
    lens = overhead_camera(width=640, height=480, focal_px=1100.0, distortion=LENS)
    rect = rectified_camera(lens.intrinsics, 0.0)
    assert rect.k != lens.intrinsics.k
    ros.add(DetectorNode(context=ros.context,
                         parameter_overrides=params(image_rectified=True)))
    info = intrinsics_to_camera_info(lens.intrinsics, 0, rectified=rect)
    camera = Camera(ros, topic="/camera/image_rect", info=info)
    image = render_blocks(CameraModel(rect, lens.rotation, lens.position), BLOCKS,
                          RenderStyle(noise_std=2.0, blur_sigma_px=0.6),
                          rng=np.random.default_rng(0))
    blocks = block_set_from_msg(detection(ros, camera, image)).by_id()
    for b in BLOCKS:
        assert math.hypot(blocks[b.id].x - b.x, blocks[b.id].y - b.y) < 1e-3


def test_a_lens_model_it_has_no_maths_for_is_refused_once_naming_it(ros, setup):
    node, camera = setup
    published = collect(ros)
    info = intrinsics_to_camera_info(CAMERA.intrinsics, 0)
    info.distortion_model, info.d = "kannala_brandt", [0.1, 0.01, 0.0, 0.0]
    for _ in range(3):
        camera.send(frame(), info=info)
        wait_until(lambda: node.refused >= 1, "a refused frame")
    wait_until(lambda: node.refused == 3, "three refused frames")
    said = [w for w in node.recent_warnings if "kannala_brandt" in w]
    assert len(said) == 1 and "not supported" in said[0]
    assert published == [] and node.frames == 0


def test_a_frame_whose_detection_fails_is_skipped_and_the_next_is_detected(ros, setup):
    node, camera = setup
    detect = node.detector.process
    failures = []

    def fail_once(*args, **kwargs):
        if not failures:
            failures.append(args[2])
            raise RuntimeError("a bug in detection")
        return detect(*args, **kwargs)

    node.detector.process = fail_once
    assert block_set_from_msg(detection(ros, camera, frame())).ids == [b.id for b in BLOCKS]
    assert len(failures) == 1 and node.refused == 1


def test_a_frame_complete_long_after_its_stamp_is_counted_and_named(ros, setup):
    """A frame whose image comes seconds after its stamp (a slow link from the camera) is
    warned about, naming the message that came last; frames in time are not."""
    node, camera = setup
    detection(ros, camera, frame())  # stamped 1 s after the epoch: clocks apart, not late
    assert node.late_frames == 0
    camera.send(frame(), stamp_ns=node.get_clock().now().nanoseconds - 3_000_000_000)
    wait_for_warning(node, " s after its stamp (its ")  # image or camera_info: either order
    assert node.late_frames == 1
    # ... and its detection, published seconds after the stamp, says how long detecting took
    wait_for_warning(node, "detection published ")
    said = [w for w in node.recent_warnings if "detection published" in w]
    assert "detecting took" in said[-1]
