"""``densepack-calibrate``: the overhead camera's pose in ``world`` from tags at known poses.

Blocks stand at poses listed in a scene file (a tag board on the table, or blocks the robot
placed): ``config/scenes/calibration.yaml`` by default, the same file the sim can load as
its scene. The tool pools the tag corners of ``frames`` camera frames, solves the camera
pose (PnP over all corners, Levenberg-Marquardt refined, outlier tags dropped), prints the
residuals and uncertainties, and writes ``config/camera_calibration.yaml`` for the detector.
It exits 0 on success, 1 when it saw too few tags or the residual is above ``max_rms_px``.
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from dataclasses import dataclass

from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, Image
from std_srvs.srv import Trigger

from msgs_py import MessageError, load_scene
from msgs_py.cell import BLOCK_SIZE, TAG_SIZE
from msgs_py.image_codecs import camera_info_to_intrinsics, image_to_array
from msgs_py.ros_codecs import stamp_to_ns
from nodes.common.params import declare_config, describe_config, param
from nodes.common.paths import config_path
from nodes.common.qos import CAMERA
from nodes.common.runner import split_ros_args
from nodes.detector.calibration import CalibrationResult, calibrate_camera
from nodes.detector.camera_model import save_camera_pose
from nodes.detector.pipeline import to_gray
from nodes.detector.sync import StampPairer
from nodes.detector.tags import REFINEMENTS, FinderSettings, TagFinder


@dataclass(frozen=True)
class CalibrateConfig:
    known_poses_file: str = param(
        "scenes/calibration.yaml", "scene file whose blocks stand at known poses (relative "
        "paths are under config/)")
    frames: int = param(10, "camera frames whose tag corners are pooled")
    timeout_s: float = param(60.0, "give up if the frames have not arrived by then", unit="s")
    output_file: str = param("camera_calibration.yaml", "calibration file written (relative "
                             "paths are under config/)")
    max_rms_px: float = param(0.5, "refuse to write a result whose RMS residual is above this",
                              unit="px")
    refinement: str = param("edges", "corner refinement (as the detector's)")
    block_size: float = param(BLOCK_SIZE, "cube side; tags lie in the plane z = block_size",
                              unit="m")
    tag_size: float = param(TAG_SIZE, "side of the tag's black square", unit="m")
    trigger: bool = param(False, "ask for each frame on /camera/trigger (std_srvs/Trigger) "
                          "instead of waiting for the camera's own rate")

    def __post_init__(self) -> None:
        if self.frames < 1:
            raise ValueError("parameter 'frames': must be >= 1")
        if self.refinement not in REFINEMENTS:
            raise ValueError(f"parameter 'refinement': '{self.refinement}' is not one of "
                             f"{sorted(REFINEMENTS)}")


class CalibrateNode(Node):
    """Collects ``frames`` frames of tag detections; ``solve()`` turns them into a pose."""

    def __init__(self, **kwargs) -> None:
        super().__init__("calibrate", **kwargs)
        self.config = declare_config(self, CalibrateConfig)
        scene = load_scene(config_path(self.config.known_poses_file))
        self.known = {b.id: b for b in scene.blocks}
        self.finder = TagFinder(FinderSettings(self.config.refinement))
        self.pairer = StampPairer()
        self.frames: list[list] = []
        self.intrinsics = None
        self.done = threading.Event()
        self.problems: list[str] = []
        group = MutuallyExclusiveCallbackGroup()
        self.create_subscription(Image, "/camera/image_raw", self.on_image, CAMERA,
                                 callback_group=group)
        self.create_subscription(CameraInfo, "/camera/camera_info", self.on_info, CAMERA,
                                 callback_group=group)
        self.trigger_client = self.create_client(Trigger, "/camera/trigger") \
            if self.config.trigger else None
        if self.trigger_client is not None:
            self.create_timer(0.5, self.request_frame)
        self.get_logger().info(
            f"calibrating from {len(self.known)} known blocks in "
            f"{config_path(self.config.known_poses_file)}; waiting for "
            f"{self.config.frames} frames")

    def request_frame(self) -> None:
        if not self.done.is_set() and self.trigger_client.service_is_ready():
            self.trigger_client.call_async(Trigger.Request())

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
        self.intrinsics = intrinsics
        self.frames.append(self.finder.find(to_gray(pixels, image_msg.encoding)))
        if len(self.frames) >= self.config.frames:
            self.done.set()

    def solve(self) -> CalibrationResult:
        """Raises ValueError when no frame arrived or too few known tags were seen."""
        if not self.frames or self.intrinsics is None:
            raise ValueError("no camera frame arrived on /camera/image_raw + camera_info"
                             + (f" ({self.problems[-1]})" if self.problems else ""))
        return calibrate_camera(self.frames, self.intrinsics, self.known,
                                self.config.block_size, self.config.tag_size)

    def write(self, result: CalibrationResult) -> str:
        path = config_path(self.config.output_file)
        source = (f"from the tags of {len(self.known)} blocks at the poses of "
                  f"{self.config.known_poses_file}:\n")
        save_camera_pose(path, result.camera.pose, comment=source + result.report())
        return str(path)


def main(args=None) -> int:
    import rclpy
    from rclpy.executors import MultiThreadedExecutor

    argv = list(sys.argv if args is None else ["densepack-calibrate", *args])
    user_args, ros_argv = split_ros_args(argv)
    rows = describe_config(CalibrateConfig)
    parser = argparse.ArgumentParser(
        prog="densepack-calibrate", formatter_class=argparse.RawDescriptionHelpFormatter,
        description=(__doc__ or "").strip() + "\n\nparameters (--ros-args -p NAME:=VALUE):\n"
        + "\n".join(f"  {r['name']:<18} {r['default']}{' [' + r['unit'] + ']' if r['unit'] else ''}"
                    f"  {r['description']}" for r in rows))
    parser.add_argument("--dry-run", action="store_true",
                        help="print the result, do not write the calibration file")
    opts = parser.parse_args(user_args)
    rclpy.init(args=ros_argv)
    node = None
    try:
        node = CalibrateNode()
        executor = MultiThreadedExecutor(num_threads=2)
        executor.add_node(node)
        deadline = time.monotonic() + node.config.timeout_s
        while rclpy.ok() and not node.done.is_set() and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.1)
        result = node.solve()
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
