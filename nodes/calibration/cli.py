"""``densepack-calibrate``: the overhead camera's pose in ``world`` from tags at known poses.

Two modes (``mode``):

* ``scene``: blocks stand at poses listed in a scene file (a tag board on the table):
  ``config/scenes/calibration.yaml`` by default, the same file the sim can load as its
  scene. The tool pools the tag corners of ``frames`` camera frames.
* ``arm``: the arm itself sets one block down at ``arm.placements`` spread over the
  workspace (``nodes.calibration.arm_routine``: it first re-grips the block with the
  closing axis turned 90 degrees, so the block sits on the TCP), takes ``arm.frames`` frames
  at each with the arm out of view, and pools those. It streams the executor's own step
  scripts on ``/arm/cartesian_setpoint`` and ``/gripper/command`` (stamped on ROS time: run
  it with ``use_sim_time:=true`` against the sim) and reads ``/tcp_pose`` and
  ``/joint_states``; the current calibration (``calibration_file``) only finds the block.

Both solve the camera pose through the lens of ``camera_info`` (PnP over all corners,
Levenberg-Marquardt refined, outlier tags or placements dropped), print the residuals and
uncertainties, and write ``config/camera_calibration.yaml`` for the detector. The tool exits
0 on success, 1 when it saw too few tags, the routine failed or the residual is above
``max_rms_px``.
"""

from __future__ import annotations

import argparse
import math
import sys
import threading
import time
from dataclasses import dataclass

import rclpy
from densepack_interfaces.msg import GripperStatus
from geometry_msgs.msg import PoseStamped
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image
from std_msgs.msg import Float64, Header

from msgs_py import MessageError, load_scene
from msgs_py.cell import BLOCK_SIZE, TAG_SIZE
from msgs_py.ros import stamp_to_ns
from msgs_py.ros.image import camera_info_to_intrinsics, image_to_array
from nodes.calibration.arm_routine import ArmCalibration, ArmRoutineConfig
from nodes.common.camera_model import load_camera_pose, save_camera_pose
from nodes.common.params import declare_config, describe_config, param
from nodes.common.paths import config_path
from nodes.common.qos import CAMERA, RELIABLE
from nodes.common.runner import split_ros_args
from nodes.common.standard_msgs import pose_stamped_msg, tool_pose_values
from nodes.common.transforms import tool_down_quaternion
from nodes.detector.calibration import CalibrationResult, calibrate_camera, calibrate_views
from nodes.detector.config import DetectorConfig
from nodes.detector.pipeline import BlockDetector, to_gray
from nodes.detector.sync import StampPairer
from nodes.detector.tags import REFINEMENTS, FinderSettings, TagFinder
from nodes.executor.motion import ToolPose

MODES = ("scene", "arm")


@dataclass(frozen=True)
class CalibrateConfig:
    mode: str = param("scene", "scene: blocks stand at the poses of known_poses_file; arm: "
                      "the arm sets one block down at arm.placements")
    known_poses_file: str = param(
        "scenes/calibration.yaml", "scene mode: scene file whose blocks stand at known poses "
        "(relative paths are under config/)")
    frames: int = param(10, "scene mode: camera frames whose tag corners are pooled")
    timeout_s: float = param(60.0, "scene mode: give up if the frames have not arrived by "
                             "then (arm mode: arm.timeout_s)", unit="s")
    calibration_file: str = param(
        "camera_calibration.yaml", "arm mode: the current calibration, which finds the block "
        "(relative paths are under config/)")
    output_file: str = param("camera_calibration.yaml", "calibration file written (relative "
                             "paths are under config/)")
    max_rms_px: float = param(0.5, "refuse to write a result whose RMS residual is above this",
                              unit="px")
    refinement: str = param("edges", "corner refinement (as the detector's)")
    block_size: float = param(BLOCK_SIZE, "cube side; tags lie in the plane z = block_size",
                              unit="m")
    tag_size: float = param(TAG_SIZE, "side of the tag's black square", unit="m")
    request_frames: bool = param(
        False, "ask the sim for each frame on /sim/render_request (std_msgs/Header; only a "
        "sim listens: a real camera streams) instead of waiting for the camera's own rate")

    def __post_init__(self) -> None:
        if self.mode not in MODES:
            raise ValueError(f"parameter 'mode': '{self.mode}' is not one of {list(MODES)}")
        if self.frames < 1:
            raise ValueError("parameter 'frames': must be >= 1")
        if self.refinement not in REFINEMENTS:
            raise ValueError(f"parameter 'refinement': '{self.refinement}' is not one of "
                             f"{sorted(REFINEMENTS)}")


class CalibrateNode(Node):
    """Collects frames of tag detections (scene mode: ``frames`` of them; arm mode: the
    routine's); ``solve()`` turns them into a pose."""

    def __init__(self, **kwargs) -> None:
        super().__init__("calibrate", **kwargs)
        self.config = declare_config(self, CalibrateConfig)
        self.arm_config = declare_config(self, ArmRoutineConfig, "arm.")
        self.arm = self.config.mode == "arm"
        self.finder = TagFinder(FinderSettings(self.config.refinement))
        self.pairer = StampPairer()
        self.frames: list[list] = []
        self.intrinsics = None
        self.done = threading.Event()
        self.problems: list[str] = []
        self.lock = threading.Lock()
        group = MutuallyExclusiveCallbackGroup()
        self.create_subscription(Image, "/camera/image_raw", self.on_image, CAMERA,
                                 callback_group=group)
        self.create_subscription(CameraInfo, "/camera/camera_info", self.on_info, CAMERA,
                                 callback_group=group)
        self.render_pub = self.create_publisher(Header, "/sim/render_request", RELIABLE) \
            if self.config.request_frames or self.arm else None
        if self.arm:
            self._start_arm()
            return
        scene = load_scene(config_path(self.config.known_poses_file))
        self.known = {b.id: b for b in scene.blocks}
        if self.render_pub is not None:
            self.create_timer(0.5, self.request_frame)
        self.get_logger().info(
            f"calibrating from {len(self.known)} known blocks in "
            f"{config_path(self.config.known_poses_file)}; waiting for "
            f"{self.config.frames} frames")

    def _start_arm(self) -> None:
        """Arm mode: the routine, the current calibration to find the block with, and the
        executor's topics."""
        executor = self.arm_config.executor_config()
        self.routine = ArmCalibration(self.arm_config, executor)
        pose = load_camera_pose(config_path(self.config.calibration_file))
        self.detector = BlockDetector(DetectorConfig(
            refinement=self.config.refinement, block_size=self.config.block_size,
            tag_size=self.config.tag_size), pose)
        self.setpoint_pub = self.create_publisher(PoseStamped, "/arm/cartesian_setpoint",
                                                  RELIABLE)
        self.gripper_pub = self.create_publisher(Float64, "/gripper/command", RELIABLE)
        arm_group = MutuallyExclusiveCallbackGroup()  # never waits for a detection
        self.create_subscription(PoseStamped, "/arm/tcp_pose", self.on_tcp, RELIABLE,
                                 callback_group=arm_group)
        self.create_subscription(GripperStatus, "/gripper/status", self.on_gripper, RELIABLE,
                                 callback_group=arm_group)
        self.create_timer(1.0 / executor.rate_hz, self.on_tick, callback_group=arm_group)
        self.get_logger().info(
            f"arm calibration: one block at {len(self.arm_config.poses)} placements, "
            f"{self.arm_config.frames} frames each; the block is found with "
            f"{config_path(self.config.calibration_file)}")

    def request_frame(self) -> None:
        if not self.done.is_set():
            self.render_pub.publish(Header(stamp=self.get_clock().now().to_msg()))

    def on_image(self, msg: Image) -> None:
        self._take(self.pairer.add_image(stamp_to_ns(msg.header.stamp), msg))

    def on_info(self, msg: CameraInfo) -> None:
        self._take(self.pairer.add_info(stamp_to_ns(msg.header.stamp), msg))

    def _take(self, result) -> None:
        if result.pair is None or self.done.is_set():
            return
        stamp_ns, image_msg, info_msg = result.pair
        try:
            intrinsics = camera_info_to_intrinsics(info_msg)
            pixels = image_to_array(image_msg)
            if pixels.shape[1::-1] != (intrinsics.width, intrinsics.height):
                raise MessageError("image.width x height", pixels.shape[1::-1],
                                   "differs from camera_info")
        except MessageError as err:
            self.problems.append(str(err))
            self.get_logger().warning(f"frame {stamp_ns} ns skipped: {err}")
            return
        if self.intrinsics is not None and intrinsics != self.intrinsics:
            self.get_logger().warning("camera_info changed during calibration: starting over")
            self.frames.clear()
            if self.arm:
                self.problems.append("camera_info changed during the routine")
                self.done.set()
                return
        self.intrinsics = intrinsics
        if self.arm:
            seen = self.detector.process(pixels, intrinsics, stamp_ns, image_msg.encoding)
            with self.lock:
                self.routine.on_frame(stamp_ns * 1e-9, seen.detections, seen.blocks.by_id())
            return
        self.frames.append(self.finder.find(to_gray(pixels, image_msg.encoding)))
        if len(self.frames) >= self.config.frames:
            self.done.set()

    # --- arm mode ---------------------------------------------------------------------------
    def on_tcp(self, msg: PoseStamped) -> None:
        try:
            pose = ToolPose(*tool_pose_values(msg))
        except ValueError as err:
            self.get_logger().warning(f"ignoring a malformed /arm/tcp_pose: {err}")
            return
        with self.lock:
            self.routine.on_tcp(pose, stamp_to_ns(msg.header.stamp) * 1e-9 or None)

    def on_gripper(self, msg: GripperStatus) -> None:
        """The pads' gap, as the gripper node measures it."""
        gap = float(msg.gap)
        if math.isfinite(gap):
            with self.lock:
                self.routine.on_finger_gap(gap, stamp_to_ns(msg.header.stamp) * 1e-9)

    def on_tick(self) -> None:
        now = self.get_clock().now()
        with self.lock:
            out = self.routine.tick(now.nanoseconds * 1e-9)
            finished = self.routine.finished
        for line in out.log:
            self.get_logger().info(line)
        if out.setpoint is not None:
            q = tool_down_quaternion(out.setpoint.yaw)
            p = out.setpoint
            self.setpoint_pub.publish(pose_stamped_msg(now.to_msg(), (p.x, p.y, p.z), q))
        if out.gripper is not None:
            self.gripper_pub.publish(Float64(data=float(out.gripper)))
        if out.want_frame:
            self.render_pub.publish(Header(stamp=now.to_msg()))
        if finished:
            self.done.set()

    # --- results ----------------------------------------------------------------------------
    def solve(self) -> CalibrationResult:
        """Raises ValueError when no frame arrived, the routine failed or too few known tags
        (placements) were seen."""
        if self.arm:
            with self.lock:
                routine = self.routine
                if routine.error:
                    raise ValueError(f"the arm routine failed: {routine.error}")
                if not routine.finished:
                    raise ValueError(f"the arm routine did not finish (at {routine.phase.value}"
                                     f", {len(routine.views())} frames)")
                views = routine.views()
            return calibrate_views(views, self.intrinsics, self.config.block_size,
                                   self.config.tag_size, group_by="placement")
        if not self.frames or self.intrinsics is None:
            raise ValueError("no camera frame arrived on /camera/image_raw + camera_info"
                             + (f" ({self.problems[-1]})" if self.problems else ""))
        return calibrate_camera(self.frames, self.intrinsics, self.known,
                                self.config.block_size, self.config.tag_size)

    def write(self, result: CalibrationResult) -> str:
        path = config_path(self.config.output_file)
        if self.arm:
            placed = sum(1 for p in self.routine.placements if p.views)
            source = (f"from one block the arm set down at {placed} placements (mode arm):\n"
                      + self.routine.report() + "\n")
        else:
            source = (f"from the tags of {len(self.known)} blocks at the poses of "
                      f"{self.config.known_poses_file}:\n")
        save_camera_pose(path, result.camera.pose, comment=source + result.report())
        return str(path)


def main(args=None) -> int:
    argv = list(sys.argv if args is None else ["densepack-calibrate", *args])
    user_args, ros_argv = split_ros_args(argv)
    rows = describe_config(CalibrateConfig) + describe_config(ArmRoutineConfig, "arm.")
    parser = argparse.ArgumentParser(
        prog="densepack-calibrate", formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(__doc__ or "").strip() + "\n\nparameters (--ros-args -p NAME:=VALUE):\n"
        + "\n".join(f"  {r['name']:<22} {r['default']}{' [' + r['unit'] + ']' if r['unit'] else ''}"
                    f"  {r['description']}" for r in rows))
    parser.add_argument("--dry-run", action="store_true",
                        help="print the result, do not write the calibration file")
    opts = parser.parse_args(user_args)
    rclpy.init(args=ros_argv)
    node = None
    try:
        node = CalibrateNode()
        # One thread: a MultiThreadedExecutor's spin_once returns while the callback it
        # started still runs, so a spin_once loop can spin at 100 % CPU and starve the
        # callbacks (the arm routine's setpoint stream, which paces the sim). The routine
        # takes frames only with the arm at rest, so a detection never delays a motion.
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        deadline = time.monotonic() + (node.arm_config.timeout_s if node.arm
                                       else node.config.timeout_s)
        while rclpy.ok() and not node.done.is_set() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        result = node.solve()
        if node.arm:
            print(node.routine.report(), flush=True)
        print(result.report(), flush=True)
        if result.rms_px > node.config.max_rms_px:
            print(f"densepack-calibrate: RMS residual {result.rms_px:.3f} px is above "
                  f"max_rms_px {node.config.max_rms_px}: not written", file=sys.stderr)
            return 1
        if not opts.dry_run:
            print(f"wrote {node.write(result)}", flush=True)
        return 0
    except KeyboardInterrupt:
        return 1
    except (ValueError, OSError) as err:
        print(f"densepack-calibrate: {err}", file=sys.stderr)
        return 1
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    sys.exit(main())
