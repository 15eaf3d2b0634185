"""``densepack-detector``: overhead camera images -> block poses on ``/blocks/detected``.

Subscribes ``/camera/image_raw`` (sensor_msgs/Image, rgb8) and ``/camera/camera_info``
(sensor_msgs/CameraInfo), pairs them by identical stamp, detects the 36h11 tags and
publishes one ``densepack_interfaces/BlockPoseArray`` per frame (msgs_py ``BlockSet``: the seen
blocks' poses in ``world``, stamp = image stamp, the known blocks not seen in ``missing_ids``)
and the same as a MarkerArray for viewers on ``/blocks/detected/markers``. A bad
frame (empty, wrongly encoded, size mismatch, no or bad camera_info) is logged and skipped:
nothing is published for it, so no old poses ever go out under a new stamp.
"""

from __future__ import annotations

import sys
import time
from collections import deque

from densepack_interfaces.msg import BlockPoseArray, Placement
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import MessageError
from msgs_py.ros import block_set_to_markers, block_set_to_msg, placement_from_msg, stamp_to_ns
from msgs_py.ros.image import camera_info_to_intrinsics, image_to_array
from nodes.common.params import declare_config
from nodes.common.paths import config_path
from nodes.common.qos import RELIABLE, camera_subscription_qos
from nodes.common.runner import NodeSpec, run_node
from nodes.detector.camera_model import load_camera_pose
from nodes.detector.config import DetectorConfig
from nodes.detector.handeye import HandEye
from nodes.detector.pipeline import BlockDetector
from nodes.detector.sync import StampPairer

WATCHDOG_PERIOD_S = 1.0
NO_FRAME_WARN_S = 2.0  # images arriving but no complete frame for this long -> warn
WARN_EVERY_S = 5.0  # the same kind of warning at most this often


class DetectorNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("detector", **kwargs)
        self.config = declare_config(self, DetectorConfig)
        pose = self.config.camera_pose_from_parameters()
        source = "parameters camera_pose.*"
        if pose is None:
            path = config_path(self.config.calibration_file)
            try:
                pose = load_camera_pose(path)
            except (OSError, MessageError) as err:
                raise ValueError(
                    f"no camera pose: camera_pose.* parameters unset and {path} unusable "
                    f"({err}); run densepack-calibrate or pass --params-file "
                    "config/camera_calibration.yaml") from None
            source = str(path)
        self.detector = BlockDetector(self.config, pose)
        self.pairer = StampPairer()
        self.recent_warnings: deque[str] = deque(maxlen=100)
        self._last_warned: dict[str, float] = {}
        self.frames = 0
        self._last_image_wall = 0.0
        self._last_frame_wall = time.monotonic()
        group = MutuallyExclusiveCallbackGroup()
        self.publisher = self.create_publisher(BlockPoseArray, "/blocks/detected", RELIABLE)
        self.markers = self.create_publisher(MarkerArray, "/blocks/detected/markers", RELIABLE)
        camera_qos = camera_subscription_qos(self.config.image_reliability)
        self.create_subscription(Image, "/camera/image_raw", self.on_image, camera_qos,
                                 callback_group=group)
        self.create_subscription(CameraInfo, "/camera/camera_info", self.on_info, camera_qos,
                                 callback_group=group)
        self.create_service(Trigger, "~/reset", self.on_reset, callback_group=group)
        self.hand_eye: HandEye | None = None  # made with the first frame (the camera's view)
        if self.config.correct_from_placements:
            self.create_subscription(Placement, "/executor/placements", self.on_placement,
                                     RELIABLE, callback_group=group)
        self.create_timer(WATCHDOG_PERIOD_S, self.watchdog, callback_group=group)
        # A sim reset restarts simulated time: frames then carry older stamps, yet are new.
        self._clock_jumped = False
        self._jump_handle = self.get_clock().create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1),
                          on_clock_change=False), post_callback=self._on_clock_jump)
        self.get_logger().info(
            f"camera pose from {source}: position {pose.position}; "
            f"{self.detector.describe()}")

    # --- inputs ---------------------------------------------------------------------------
    def on_image(self, msg: Image) -> None:
        self._last_image_wall = time.monotonic()
        self._follow_clock_jump()
        self._handle(self.pairer.add_image(stamp_to_ns(msg.header.stamp), msg))

    def on_info(self, msg: CameraInfo) -> None:
        self._follow_clock_jump()
        self._handle(self.pairer.add_info(stamp_to_ns(msg.header.stamp), msg))

    def on_placement(self, msg: Placement) -> None:
        try:
            placement = placement_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.warn("placement", f"ignoring a malformed /executor/placements: {err}")
            return
        if self.hand_eye is not None:
            self.hand_eye.on_placement(placement)

    def on_reset(self, request: Trigger.Request, response: Trigger.Response):
        self.detector.reset()
        response.success = True
        response.message = "forgot the blocks seen so far"
        return response

    def _on_clock_jump(self, jump) -> None:
        self._clock_jumped = True  # handled in the camera callbacks' thread

    def _follow_clock_jump(self) -> None:
        if self._clock_jumped:
            self._clock_jumped = False
            self.pairer.reset()
            self.detector.reset()
            self.warn("clock", "the clock jumped back (simulation reset?): starting afresh, "
                      "known blocks forgotten")

    # --- processing -----------------------------------------------------------------------
    def _handle(self, result) -> None:
        if result.clock_reset:
            self.detector.reset()
            self.warn("clock", "image stamps jumped back (simulation reset?): starting afresh, "
                      "known blocks forgotten")
        for stamp_ns, reason in result.dropped:
            self.warn("dropped", f"frame {stamp_ns} ns skipped: {reason}")
        if result.pair is not None:
            self.process(*result.pair)

    def process(self, stamp_ns: int, image_msg: Image, info_msg: CameraInfo) -> None:
        """Detect and publish one frame; a malformed frame is logged and skipped."""
        try:
            intrinsics = camera_info_to_intrinsics(info_msg)
            pixels = image_to_array(image_msg)
            height, width = pixels.shape[:2]
            if (width, height) != (intrinsics.width, intrinsics.height):
                raise MessageError("image.width x height", (width, height),
                                   f"differs from camera_info ({intrinsics.width} x "
                                   f"{intrinsics.height})")
            result = self.detector.process(pixels, intrinsics, stamp_ns, image_msg.encoding)
            blocks = self._corrected(result.blocks, intrinsics)
            detected = block_set_to_msg(blocks)
        except (MessageError, ValueError) as err:
            self.warn("frame", f"frame {stamp_ns} ns skipped: {err}")
            return
        for text in result.warnings:
            self.warn(text.split(":")[0], f"frame {stamp_ns} ns: {text}")
        self.publisher.publish(detected)
        self.markers.publish(block_set_to_markers(blocks))
        self.frames += 1
        self._last_frame_wall = time.monotonic()
        self.get_logger().debug(
            f"frame {stamp_ns} ns: {len(result.blocks.blocks)} blocks, missing "
            f"{list(result.blocks.missing)}, {1000 * result.detect_s:.1f} ms")

    def _corrected(self, raw, intrinsics):
        """The frame's blocks through the hand-eye correction (when enabled)."""
        if not self.config.correct_from_placements:
            return raw
        if self.hand_eye is None:
            view = self.detector.camera(intrinsics).table_view(self.config.block_size)
            self.hand_eye = HandEye(view, tuple(view.mean(axis=0)))
        blocks = self.hand_eye.correct(raw)
        for line in self.hand_eye.log:
            self.get_logger().warning(line)
        self.hand_eye.log.clear()
        return blocks

    def watchdog(self) -> None:
        now = time.monotonic()
        images_flowing = now - self._last_image_wall < NO_FRAME_WARN_S
        if images_flowing and now - self._last_frame_wall > NO_FRAME_WARN_S:
            self.warn("no frame", f"images arrive on /camera/image_raw but none was paired "
                      f"with a /camera/camera_info of the same stamp for "
                      f"{now - self._last_frame_wall:.0f} s")

    def warn(self, kind: str, text: str) -> None:
        """Log a warning, each kind at most every WARN_EVERY_S; keep it for tests."""
        self.recent_warnings.append(text)
        now = time.monotonic()
        if now - self._last_warned.get(kind, -1e9) >= WARN_EVERY_S:
            self._last_warned[kind] = now
            self.get_logger().warning(text)


TOPICS = """subscribes: /camera/image_raw (sensor_msgs/Image rgb8), /camera/camera_info
            (sensor_msgs/CameraInfo), paired by identical stamp
publishes:  /blocks/detected (densepack_interfaces/BlockPoseArray: poses in world, missing ids),
            /blocks/detected/markers (visualization_msgs/MarkerArray: a CUBE per block, for viewers)
services:   ~/reset (std_srvs/Trigger): forget the blocks seen so far"""

SPEC = NodeSpec(
    "detector",
    DetectorNode,
    "Detects the AprilTag 36h11 tags on the blocks in overhead images and publishes the "
    "block poses in world.",
    configs=(("", DetectorConfig),),
    topics=TOPICS,
    threads=2,
)


def main(args=None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
