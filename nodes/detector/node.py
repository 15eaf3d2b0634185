"""``densepack-detector``: overhead camera images -> block poses on ``/blocks/detected``.

Subscribes ``/camera/image_raw`` (or, with ``image_rectified``, image_proc's
``/camera/image_rect``) and ``/camera/camera_info``, pairs them by identical stamp, detects
the 36h11 tags and publishes one ``densepack_interfaces/BlockPoseArray`` per frame processed
(msgs_py ``BlockSet``: the seen blocks' poses in ``world``, stamp = image stamp, the known
blocks not seen in ``missing_ids``) and the same as a MarkerArray for viewers on
``/blocks/detected/markers``.

A camera streams; detection runs on a worker thread of its own and always takes the newest
complete frame, so frames that come faster than it can process are skipped (counted and
logged as counts, never a warning per frame) and none is older than one already processed.
A bad frame (empty, wrongly encoded, size mismatch, bad camera_info, a lens model without
maths here) is logged and skipped: nothing is published for it, so no old poses ever go out
under a new stamp.
"""

from __future__ import annotations

import sys
import threading
import time
from collections import Counter, deque

from densepack_interfaces.msg import BlockPoseArray, Placement
from diagnostic_msgs.msg import DiagnosticStatus
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import BlockPose, MessageError, drivers
from msgs_py.camera import CameraPose, UnsupportedLensModel
from msgs_py.ros import block_set_to_markers, block_set_to_msg, placement_from_msg, stamp_to_ns
from msgs_py.ros.image import camera_info_to_camera, image_to_array
from nodes.common.camera_model import load_camera_pose
from nodes.common.params import declare_config
from nodes.common.paths import config_path
from nodes.common.qos import LATCHED, RELIABLE, camera_qos
from nodes.common.runner import NodeSpec, run_node
from nodes.common.standard_msgs import joint_state_values
from nodes.detector.calibration_check import CheckKeeper, default_record_path
from nodes.detector.config import DetectorConfig
from nodes.detector.handeye import HandEye
from nodes.detector.pipeline import BlockDetector
from nodes.detector.robot_view import RobotPoses
from nodes.detector.sync import Drop, FrameInbox, PairResult
from nodes.detector.warning_kinds import WarningKind

WATCHDOG_PERIOD_S = 1.0
NO_FRAME_WARN_S = 2.0  # images arriving but no complete frame for this long -> warn
WARN_EVERY_S = 5.0  # the same kind of warning at most this often
#: A frame complete (image and camera_info in) this long after its stamp (s, on the node's
#: clock) came late: a render takes a fraction of a second; a reliable frame whose lost
#: fragment waits for the DDS writer's next heartbeat (3 s by default) takes longer.
LATE_FRAME_S = 1.5
#: ... but one stamped this much (s) before the node's clock says nothing of the link: the
#: camera's clock and the node's are apart (a driver on an unsynced host, a test's stamps).
CLOCKS_APART_S = 60.0
COUNTS_LOG_S = 10.0  # skipped frames are summed up in the log at most this often
TAKE_TIMEOUT_S = 0.5  # the worker looks at its stop flag at least this often
#: Drops worth a warning (something is wrong); the others are a stream's normal losses.
WARNED_DROPS = {Drop.STALE: WarningKind.STALE_FRAME, Drop.UNPAIRED: WarningKind.UNPAIRED}
IMAGE_TOPICS = {False: "/camera/image_raw", True: "/camera/image_rect"}


class DetectorNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("detector", **kwargs)
        self.config = declare_config(self, DetectorConfig)
        pose, source = self._camera_pose()
        self.detector = BlockDetector(self.config, pose)
        self.inbox = FrameInbox()
        self.recent_warnings: deque[str] = deque(maxlen=100)
        self._last_warned: dict[WarningKind, float] = {}
        self._refused_models: set[str] = set()
        self.frames = 0  # frames processed and published
        self.refused = 0  # frames skipped as malformed
        self.late_frames = 0  # frames complete LATE_FRAME_S or more after their stamp
        self._logged: Counter[Drop] = Counter()  # the drop counts as last logged
        self._last_counts_log = time.monotonic()
        self._last_image_wall = 0.0
        self._last_frame_wall = time.monotonic()
        self._state = threading.Lock()  # the detector and hand-eye state: worker vs services
        self._forget = threading.Event()  # the clock went back: forget the blocks seen
        self.hand_eye: HandEye | None = None  # made with the first frame (the camera's view)
        self.check = CheckKeeper(default_record_path(), pose,
                                 self.config.calibration_check_max_age_h * 3600.0, time.time())
        self.robot = RobotPoses()  # the robot's joint states, for what it covers in a frame
        self._robot_lock = threading.Lock()
        self._make_interfaces()
        # A sim reset restarts simulated time: frames then carry older stamps, yet are new.
        self._clock_jumped = False
        self._jump_handle = self.get_clock().create_jump_callback(
            JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1),
                          on_clock_change=False), post_callback=self._on_clock_jump)
        self._stop = threading.Event()
        self._worker = threading.Thread(target=self._work, name="detector-worker", daemon=True)
        self._worker.start()
        self._publish_calibration()
        self.get_logger().info(
            f"camera pose from {source}: position {pose.position}; images on "
            f"{self.image_topic}; {self.detector.describe()}")

    def _camera_pose(self) -> tuple[CameraPose, str]:
        pose = self.config.camera_pose_from_parameters()
        if pose is not None:
            return pose, "parameters camera_pose.*"
        path = config_path(self.config.calibration_file)
        try:
            return load_camera_pose(path), str(path)
        except (OSError, MessageError) as err:
            raise ValueError(
                f"no camera pose: camera_pose.* parameters unset and {path} unusable "
                f"({err}); run densepack-calibrate or pass --params-file "
                "config/camera_calibration.yaml") from None

    @property
    def image_topic(self) -> str:
        return IMAGE_TOPICS[self.config.image_rectified]

    def _make_interfaces(self) -> None:
        camera_group = MutuallyExclusiveCallbackGroup()
        control_group = MutuallyExclusiveCallbackGroup()
        self.publisher = self.create_publisher(BlockPoseArray, "/blocks/detected", RELIABLE)
        self.calibration_pub = self.create_publisher(DiagnosticStatus, "/detector/calibration",
                                                     LATCHED)
        self.markers = self.create_publisher(MarkerArray, "/blocks/detected/markers", RELIABLE)
        camera = camera_qos(self.config.image_reliability)
        self.create_subscription(Image, self.image_topic, self.on_image, camera,
                                 callback_group=camera_group)
        self.create_subscription(CameraInfo, "/camera/camera_info", self.on_info, camera,
                                 callback_group=camera_group)
        self.create_service(Trigger, "~/reset", self.on_reset, callback_group=control_group)
        if self.config.robot_occlusion:
            for topic in (drivers.JOINT_STATES, drivers.GRIPPER_JOINT_STATES):
                self.create_subscription(JointState, topic, self.on_joint_state, RELIABLE,
                                         callback_group=control_group)
        if self.config.correct_from_placements or self.config.robot_occlusion:
            self.create_subscription(Placement, "/executor/placements", self.on_placement,
                                     RELIABLE, callback_group=control_group)
        self.create_timer(WATCHDOG_PERIOD_S, self.watchdog, callback_group=control_group)

    # --- inputs (the camera callbacks only pair; the worker detects) ------------------------
    def on_image(self, msg: Image) -> None:
        self._last_image_wall = time.monotonic()
        self._follow_clock_jump()
        self._handle(self.inbox.add_image(stamp_to_ns(msg.header.stamp), msg), "image")

    def on_info(self, msg: CameraInfo) -> None:
        self._follow_clock_jump()
        self._handle(self.inbox.add_info(stamp_to_ns(msg.header.stamp), msg), "camera_info")

    def on_joint_state(self, msg: JointState) -> None:
        try:
            names, positions, stamp = joint_state_values(msg)
        except MessageError as err:
            self.warn(WarningKind.JOINT_STATE, f"ignoring a malformed joint state: {err}")
            return
        with self._robot_lock:
            self.robot.on_joint_state(names, positions, stamp)

    def on_placement(self, msg: Placement) -> None:
        try:
            placement = placement_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.warn(WarningKind.PLACEMENT, f"ignoring a malformed /executor/placements: {err}")
            return
        with self._state:
            self.detector.on_placed(BlockPose(placement.block, placement.pose.x,
                                              placement.pose.y, placement.pose.theta),
                                    placement.stamp_ns)
            if self.hand_eye is not None:
                self.hand_eye.on_placement(placement)

    def on_reset(self, request: Trigger.Request, response: Trigger.Response):
        with self._state:
            self.detector.reset()
        response.success = True
        response.message = "forgot the blocks seen so far"
        return response

    def _on_clock_jump(self, jump) -> None:
        self._clock_jumped = True  # handled in the camera callbacks' thread

    def _follow_clock_jump(self) -> None:
        if self._clock_jumped:
            self._clock_jumped = False
            self.inbox.reset()
            self._forget.set()
            self.warn(WarningKind.CLOCK, "the clock jumped back (simulation reset?): starting "
                      "afresh, known blocks forgotten")

    def _handle(self, result: PairResult, came: str) -> None:
        """``result`` of pairing the ``came`` (image or camera_info) just received."""
        if result.clock_reset:
            self._forget.set()
            self.warn(WarningKind.CLOCK, "image stamps jumped back (simulation reset?): "
                      "starting afresh, known blocks forgotten")
        for stamp_ns, why in result.dropped:
            if why in WARNED_DROPS:
                self.warn(WARNED_DROPS[why], f"frame {stamp_ns} ns skipped: {why.value}")
        if result.pair is not None:
            self._last_frame_wall = time.monotonic()
            self._note_late(result.pair[0], came)

    def _late_s(self, stamp_ns: int) -> float | None:
        """How long after ``stamp_ns`` it is now, if LATE_FRAME_S or more (and the clocks
        not far apart: a reset); else None."""
        late_s = (self.get_clock().now().nanoseconds - stamp_ns) * 1e-9
        return late_s if LATE_FRAME_S <= late_s < CLOCKS_APART_S else None

    def _note_late(self, stamp_ns: int, came: str) -> None:
        """Count and log a frame complete LATE_FRAME_S or more after its stamp, naming the
        message that came last: in a long run, a slow link from the camera shows here."""
        if (late_s := self._late_s(stamp_ns)) is not None:
            self.late_frames += 1
            self.warn(WarningKind.LATE_FRAME, f"frame {stamp_ns} ns complete {late_s:.1f} s "
                      f"after its stamp (its {came} came last; {self.late_frames} late so far)")

    def _note_slow(self, stamp_ns: int, detect_s: float) -> None:
        """Log a detection published LATE_FRAME_S or more after its frame's stamp, with the
        detection's own time: with ``_note_late`` (the frame's arrival) it tells a late
        detection's wait apart from the way to its readers."""
        if (late_s := self._late_s(stamp_ns)) is not None:
            self.warn(WarningKind.LATE_FRAME, f"frame {stamp_ns} ns: detection published "
                      f"{late_s:.1f} s after its stamp (detecting took {detect_s:.2f} s)")

    # --- processing (the worker thread) ----------------------------------------------------
    def _work(self) -> None:
        while not self._stop.is_set():
            frame = self.inbox.take(TAKE_TIMEOUT_S)
            if frame is None or self._stop.is_set():
                continue
            try:
                with self._state:
                    self.process(*frame)
            except Exception as err:  # the worker must outlive any one frame
                self.refused += 1
                self.get_logger().error(f"frame {frame[0]} ns: detection failed ({err!r}); "
                                        "skipped, the next frame is tried")

    def process(self, stamp_ns: int, image_msg: Image, info_msg: CameraInfo) -> None:
        """Detect and publish one frame; a malformed frame is logged and skipped."""
        if self._forget.is_set():
            self._forget.clear()
            self.detector.reset()
        try:
            intrinsics = camera_info_to_camera(info_msg, self.config.image_rectified)
            pixels = image_to_array(image_msg)
            height, width = pixels.shape[:2]
            if (width, height) != (intrinsics.width, intrinsics.height):
                raise MessageError("image.width x height", (width, height),
                                   f"differs from camera_info ({intrinsics.width} x "
                                   f"{intrinsics.height})")
            with self._robot_lock:
                robot = self.robot.at(stamp_ns * 1e-9)
            result = self.detector.process(pixels, intrinsics, stamp_ns, image_msg.encoding,
                                           robot)
            blocks = self._corrected(result.blocks, intrinsics)
            detected = block_set_to_msg(blocks)
        except UnsupportedLensModel as err:
            self._refuse_lens(err)
            return
        except (MessageError, ValueError) as err:
            self.refused += 1
            self.warn(WarningKind.BAD_FRAME, f"frame {stamp_ns} ns skipped: {err}")
            return
        for warning in result.warnings:
            self.warn(warning.kind, f"frame {stamp_ns} ns: {warning.text}")
        self.publisher.publish(detected)
        self.markers.publish(block_set_to_markers(blocks))
        self._note_slow(stamp_ns, result.detect_s)
        self.frames += 1
        self.get_logger().debug(
            f"frame {stamp_ns} ns: {len(result.blocks.blocks)} blocks, missing "
            f"{list(result.blocks.missing)}, occluded {list(result.blocks.occluded)}, "
            f"{1000 * result.detect_s:.1f} ms")

    def _refuse_lens(self, err: UnsupportedLensModel) -> None:
        """A lens model without maths here: said once per model, every frame skipped."""
        self.refused += 1
        if err.model not in self._refused_models:
            self._refused_models.add(err.model)
            text = (f"camera_info distortion_model '{err.model}' is not supported ({err.reason})"
                    f": every frame with it is skipped")
            self.recent_warnings.append(text)
            self.get_logger().error(text)

    def _corrected(self, raw, intrinsics):
        """The frame's blocks through the hand-eye correction (when enabled)."""
        if not self.config.correct_from_placements:
            return raw
        if self.hand_eye is None:
            view = self.detector.camera(intrinsics).table_view(self.config.block_size)
            record = self.check.record
            self.hand_eye = HandEye(view, tuple(view.mean(axis=0)),
                                    None if record is None else record.correction)
        samples = len(self.hand_eye.samples)
        blocks = self.hand_eye.correct(raw)
        for line in self.hand_eye.log:
            self.get_logger().warning(line)
        self.hand_eye.log.clear()
        if len(self.hand_eye.samples) != samples and self.check.on_verdict(
                self.hand_eye.verdict(), self.hand_eye.correction, len(self.hand_eye.samples),
                time.time()):
            self._publish_calibration()
        if self.check.error:
            self.warn(WarningKind.CHECK_RECORD, f"camera check record: {self.check.error}")
        return blocks

    def _publish_calibration(self) -> None:
        """What the detector says of its calibration (latched): checked against the arm
        recently, or not (the executor then makes its camera check)."""
        checked, words = self.check.status(time.time())
        level = (DiagnosticStatus.OK if checked else
                 DiagnosticStatus.ERROR if self.check.disagrees else DiagnosticStatus.WARN)
        self.calibration_pub.publish(DiagnosticStatus(
            level=level,
            name="densepack/camera_calibration", message=words, hardware_id="camera"))
        self.get_logger().info(f"calibration: {words}")

    # --- health -------------------------------------------------------------------------------
    def watchdog(self) -> None:
        now = time.monotonic()
        images_flowing = now - self._last_image_wall < NO_FRAME_WARN_S
        if images_flowing and now - self._last_frame_wall > NO_FRAME_WARN_S:
            self.warn(WarningKind.NO_FRAME, f"images arrive on {self.image_topic} but none was "
                      f"paired with a /camera/camera_info of the same stamp for "
                      f"{now - self._last_frame_wall:.0f} s")
        if now - self._last_counts_log >= COUNTS_LOG_S:
            self._log_counts(now)

    def _log_counts(self, now: float) -> None:
        """Frames skipped since the last report, by why: a sum, not a line per frame."""
        counts, received = self.inbox.snapshot()
        new = counts - self._logged
        if not new:
            return
        self._logged, self._last_counts_log = counts, now
        parts = ", ".join(f"{n} {why.name.lower()}" for why, n in sorted(
            new.items(), key=lambda kv: kv[0].name))
        self.get_logger().info(
            f"skipped since the last report: {parts} ({self.frames} frames processed, "
            f"{received} images received in all; superseded: a newer frame was "
            "complete first, incomplete: its camera_info or image was lost)")

    def warn(self, kind: WarningKind, text: str) -> None:
        """Log a warning, each kind at most every WARN_EVERY_S; keep it for tests."""
        self.recent_warnings.append(text)
        now = time.monotonic()
        if now - self._last_warned.get(kind, -1e9) >= WARN_EVERY_S:
            self._last_warned[kind] = now
            self.get_logger().warning(text)

    def destroy_node(self) -> None:
        self._stop.set()
        self.inbox.close()
        if self._worker.is_alive():
            self._worker.join(timeout=10.0)
        super().destroy_node()


TOPICS = """subscribes: /camera/image_raw (sensor_msgs/Image rgb8; /camera/image_rect with
            image_rectified), /camera/camera_info (sensor_msgs/CameraInfo), paired by
            identical stamp; /executor/placements (densepack_interfaces/Placement);
            /joint_states, /gripper/joint_states (sensor_msgs/JointState, by name: what the
            robot covers in a frame)
publishes:  /detector/calibration (diagnostic_msgs/DiagnosticStatus, latched: OK checked
            against the arm's placements recently, WARN not yet, ERROR they disagree),
            /blocks/detected (densepack_interfaces/BlockPoseArray: poses in world, missing
            and occluded ids),
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
