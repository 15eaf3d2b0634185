"""``densepack-sim``: the simulated UR10e cell as a ROS 2 node.

One thread (``sim-loop``) owns the PyBullet world: it steps physics, runs the arm
controller, renders, and publishes. ROS callbacks never touch the world; they validate their
message and queue a command that the loop applies between two physics steps (services wait
for the loop's answer). So rendering pauses physics, and nothing is half-applied: a
malformed message is refused in its callback with a warning.

Pacing (``Pacer``): while the executor streams setpoints, the sim runs as fast as the
machine allows but never more than ``lockstep_lead_s`` of simulated time ahead of the
newest setpoint (lockstep: the executor is never outrun, however loaded the machine);
when nothing streams (the cell waits for a camera frame to be judged, or for a plan), time
passes at ``real_time_factor``, as it would for a real robot waiting. Rendering a frame is
not charged to simulated time (a real camera's exposure is milliseconds).
"""

from __future__ import annotations

import collections
import concurrent.futures
import math
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

from densepack_interfaces.msg import (
    BlockPoseArray,
    Disturbance,
    GripperStatus,
    SafetyMode,
    SimEvents,
    SimFault,
)
from densepack_interfaces.msg import ExecutorStatus as ExecutorStatusMsg
from geometry_msgs.msg import PoseStamped
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, JointState
from std_msgs.msg import Float64
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import BlockSet, MessageError
from msgs_py import interface_codecs as ic
from msgs_py.image_codecs import (
    array_to_compressed_image,
    array_to_image,
    intrinsics_to_camera_info,
)
from msgs_py.ros_codecs import block_set_to_markers, ns_to_stamp, stamp_to_ns
from msgs_py.sim import SimEvents as SimEventsRecord
from msgs_py.status import GRIPPER_OBJECT_STATES
from msgs_py.status import GripperStatus as GripperStatusRecord
from msgs_py.status import SafetyMode as SafetyModeRecord
from nodes.common.params import declare_config
from nodes.common.qos import LATCHED, RELIABLE, camera_qos
from nodes.common.runner import NodeSpec, run_node
from nodes.sim.config import SIM_PARAMETERS, CameraConfig, RandomSceneConfig, SimConfig
from nodes.sim.layout import load_sim_scene, scene_problems
from nodes.sim.messages import joint_state_msg, pose_from_msg, pose_stamped_msg
from nodes.sim.pacing import Pacer
from nodes.sim.world import SimWorld

CLOCK_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
SERVICE_TIMEOUT_S = 60.0
#: Longest the loop sleeps between two looks at its command queue (s).
MAX_IDLE_WAIT_S = 0.005
#: A loop that steps without waiting (free-running, lockstep, behind the real-time floor)
#: sleeps GIL_SHARE_S after every GIL_SHARE_EVERY_S of stepping. A PyBullet step holds the GIL,
#: so without it the node's own callbacks and the process's other threads get the GIL back
#: only at the interpreter's 5 ms forced switches, once per blocking call they make: a thread
#: that makes many (rclpy's logger looks up its caller's source file, stat by stat) took
#: minutes for what takes milliseconds (the sim-node tests: 290 s for one).
GIL_SHARE_EVERY_S = 0.002
GIL_SHARE_S = 0.0002


#: gOBJ code of fingers that stopped on something while opening: logged with what they touch.
STOPPED_OPENING = GRIPPER_OBJECT_STATES.index("stopped_opening")
STALL_LOG_S = 0.2


class SimNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("sim", **kwargs)
        self.config = declare_config(self, SimConfig)
        self.camera_config = declare_config(self, CameraConfig, "camera.")
        self.random_config = declare_config(self, RandomSceneConfig, "random.")
        self.scene = self._load_scene()
        self.world = SimWorld(self.config, self.camera_config.model(), self.scene,
                              noise_std=self.camera_config.noise_std)
        self._commands: collections.deque[Callable[[], None]] = collections.deque()
        self._stop = threading.Event()
        self._wake = threading.Event()  # a command came: the loop may step again
        self.pacer = Pacer(self.config.real_time_factor, self.config.lockstep_lead_s)
        self._blackout_until_ns = 0
        self._stopped_opening_since: float | None = None  # sim s; -1: logged
        self._make_interfaces()
        self._thread = threading.Thread(target=self._loop, name="sim-loop", daemon=True)
        self._thread.start()
        self.get_logger().info(
            f"sim running: {len(self.scene.blocks)} blocks, physics {self.config.physics_rate_hz}"
            f" Hz, real_time_factor {self.config.real_time_factor}, camera "
            f"{self.camera_config.width}x{self.camera_config.height} at "
            f"{self.camera_config.rate_hz} Hz")

    def _load_scene(self):
        rnd = self.random_config
        scene = load_sim_scene(self.config.scene_file, rnd.n_blocks, rnd.density, rnd.seed)
        problems = scene_problems(scene, self.camera_config.model(), self.config.home_joints)
        if problems:
            raise ValueError("the scene does not fit the cell: " + "; ".join(problems))
        return scene

    def _make_interfaces(self) -> None:
        group = ReentrantCallbackGroup()
        self.pub_clock = self.create_publisher(Clock, "/clock", CLOCK_QOS)
        self.pub_joints = self.create_publisher(JointState, "/joint_states", RELIABLE)
        self.pub_tcp = self.create_publisher(PoseStamped, "/tcp_pose", RELIABLE)
        self.pub_gripper = self.create_publisher(GripperStatus, "/gripper/status", RELIABLE)
        self.pub_truth = self.create_publisher(BlockPoseArray, "/sim/ground_truth", RELIABLE)
        self.pub_truth_markers = self.create_publisher(MarkerArray, "/sim/ground_truth/markers",
                                                       RELIABLE)
        self.pub_events = self.create_publisher(SimEvents, "/sim/events", LATCHED)
        camera = camera_qos(self.camera_config.reliability)
        self.pub_image = self.create_publisher(Image, "/camera/image_raw", camera)
        self.pub_info = self.create_publisher(CameraInfo, "/camera/camera_info", camera)
        # image_transport's compressed sibling (JPEG, ~115 kB): what viewers, best-effort
        # subscribers and bags take. Encoded only while someone listens.
        self.pub_compressed = self.create_publisher(CompressedImage,
                                                    "/camera/image_raw/compressed", camera)
        self.create_subscription(PoseStamped, "/arm/cartesian_setpoint", self._on_setpoint,
                                 RELIABLE, callback_group=group)
        self.create_subscription(Float64, "/gripper/command", self._on_gripper, RELIABLE,
                                 callback_group=group)
        # Volatile on purpose: it matches the executor whether it latches its status or not.
        self.create_subscription(ExecutorStatusMsg, "/executor/status", self._on_status,
                                 RELIABLE, callback_group=group)
        self.create_subscription(SimFault, "/sim/fault", self._on_fault, RELIABLE,
                                 callback_group=group)
        self.create_subscription(Disturbance, "/sim/disturb", self._on_disturb, RELIABLE,
                                 callback_group=group)
        self.create_subscription(Float64, "/sim/camera_blackout", self._on_blackout, RELIABLE,
                                 callback_group=group)
        self.pub_safety = self.create_publisher(SafetyMode, "/arm/safety_mode", LATCHED)
        self._safety_published: str | None = None  # the stop reason last published
        self.create_service(Trigger, "/arm/unlock_protective_stop", self._on_unlock,
                            callback_group=group)
        self.create_service(Trigger, "/sim/reset", self._on_reset, callback_group=group)
        self.create_service(Trigger, "/camera/trigger", self._on_trigger, callback_group=group)

    # --- callbacks (any executor thread): validate, then queue ----------------------------------
    def _queue(self, command: Callable[[], None]) -> None:
        """Hand ``command`` to the sim loop (the only thread that touches the world)."""
        self._commands.append(command)
        self._wake.set()

    def _on_setpoint(self, msg: PoseStamped) -> None:
        try:
            position, quat, frame = pose_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.get_logger().warning(f"/arm/cartesian_setpoint refused: {err}")
            return
        stamp = stamp_to_ns(msg.header.stamp) * 1e-9 or None

        def apply() -> None:
            if stamp is not None:
                self.pacer.on_setpoint(stamp)
            result = self.world.set_setpoint(position, quat, frame, stamp)
            if not result.accepted:
                self.get_logger().warning(
                    f"setpoint {[round(v, 4) for v in position]} rejected, arm holds: "
                    f"{result.reason}", throttle_duration_sec=1.0)
        self._queue(apply)

    def _on_gripper(self, msg: Float64) -> None:
        gap = float(msg.data)
        if not math.isfinite(gap):
            self.get_logger().warning(f"/gripper/command refused: {gap} is not finite")
            return
        self._queue(lambda: self.world.set_gripper(gap))

    def _on_status(self, msg: ExecutorStatusMsg) -> None:
        try:
            status = ic.executor_status_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.get_logger().warning(f"ignoring a malformed /executor/status: {err}")
            return
        self._queue(lambda: self.world.set_manipulated(status.block))

    def _on_disturb(self, msg: Disturbance) -> None:
        try:
            nudge = ic.disturbance_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.get_logger().warning(f"/sim/disturb refused: {err}")
            return

        def apply() -> None:
            try:
                self.world.disturb(nudge.block, nudge.dx, nudge.dy)
            except ValueError as err:
                self.get_logger().warning(f"/sim/disturb refused: {err}")
        self._queue(apply)

    def _on_fault(self, msg: SimFault) -> None:
        """Fault injection: arm a drop, slip or miss for the next action, take a block out,
        put one in, or change the camera's noise."""
        try:
            fault = ic.sim_fault_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.get_logger().warning(f"/sim/fault refused: {err}")
            return

        def apply() -> None:
            try:
                self.world.inject(fault)
            except ValueError as err:
                self.get_logger().warning(f"/sim/fault refused: {err}")
                return
            self.get_logger().warning(f"fault injected: {fault.kind} "
                                      f"{'' if fault.block is None else fault.block}")
        self._queue(apply)

    def _on_blackout(self, msg: Float64) -> None:
        """Fault injection: drop every camera frame for the next ``msg.data`` sim seconds."""
        seconds = float(msg.data)
        if not math.isfinite(seconds) or seconds < 0:
            self.get_logger().warning(f"/sim/camera_blackout refused: {seconds} s")
            return

        def apply() -> None:
            self._blackout_until_ns = self.world.time_ns + round(seconds * 1e9)
            self.get_logger().warning(f"camera frames dropped for {seconds:.1f} s (fault)")
        self._queue(apply)

    def _on_reset(self, request, response):
        def apply() -> str:
            scene = self._load_scene()
            self.world.reset(scene)
            self.pacer.restart(self.world.time_s)
            self.scene = scene
            self._publish_events()
            return f"reset: {len(scene.blocks)} blocks at t = {self.world.time_s:.3f} s"
        return self._answer(apply, response)

    def _on_unlock(self, request, response):
        """Like the UR dashboard's unlock: the arm follows setpoints again."""
        return self._answer(lambda: "unlocked" if self.world.unlock_protective_stop()
                            else "not in a protective stop", response)

    def _on_trigger(self, request, response):
        return self._answer(lambda: str(self._publish_camera()), response)

    def _answer(self, fn: Callable[[], str], response):
        future: concurrent.futures.Future = concurrent.futures.Future()

        def apply() -> None:
            try:
                future.set_result(fn())
            except Exception as err:  # reported to the caller, the loop carries on
                future.set_exception(err)
        self._queue(apply)
        try:
            response.message = future.result(timeout=SERVICE_TIMEOUT_S)
            response.success = True
        except Exception as err:
            response.success = False
            response.message = f"{type(err).__name__}: {err}"
        return response

    # --- the sim loop (the only thread that touches the world) ----------------------------------
    def _loop(self) -> None:
        cfg = self.config
        every = {
            "clock": _period_steps(cfg.physics_rate_hz, cfg.clock_rate_hz),
            "state": _period_steps(cfg.physics_rate_hz, cfg.state_rate_hz),
            "truth": _period_steps(cfg.physics_rate_hz, cfg.ground_truth_rate_hz),
            "events": _period_steps(cfg.physics_rate_hz, cfg.events_rate_hz),
            "camera": (_period_steps(cfg.physics_rate_hz, self.camera_config.rate_hz)
                       if self.camera_config.rate_hz > 0 else 0),
        }
        self.pacer.restart(self.world.time_s)
        shared = time.monotonic()  # when the loop last let go of the GIL
        while not self._stop.is_set() and self.context.ok():
            try:
                while self._commands:
                    self._commands.popleft()()
                now = time.monotonic()
                wait = self.pacer.wait_before_step(self.world.time_s, now)
                if wait > 0.0:
                    self._wake.wait(min(wait, MAX_IDLE_WAIT_S))
                    self._wake.clear()
                    shared = time.monotonic()
                    continue
                if now - shared > GIL_SHARE_EVERY_S:
                    time.sleep(GIL_SHARE_S)
                    shared = time.monotonic()
                self.world.step()
                self._publish_due(every)
                self._publish_safety_mode()
            except Exception as err:  # never let the loop die silently
                if not self.context.ok():
                    break  # shutting down: publishers are gone
                self.get_logger().error(f"sim loop error: {type(err).__name__}: {err}")

    def _publish_due(self, every: dict[str, int]) -> None:
        k = self.world.step_count
        if k % every["clock"] == 0:
            self.pub_clock.publish(Clock(clock=ns_to_stamp(self.world.time_ns)))
        if k % every["state"] == 0:
            self._publish_state()
        if k % every["truth"] == 0:
            self._publish_truth()
        if k % every["events"] == 0:
            self._publish_events()
        if every["camera"] and k % every["camera"] == 0:
            self._publish_camera()

    def _publish_safety_mode(self) -> None:
        """On a change only (latched): NORMAL, or PROTECTIVE_STOP with its reason."""
        stopped = self.world.controller.stopped
        if stopped == self._safety_published:
            return
        self._safety_published = stopped
        mode = SafetyModeRecord("protective_stop" if stopped else "normal", stopped,
                                self.world.time_ns)
        self.pub_safety.publish(ic.safety_mode_to_msg(mode))
        if stopped:
            self.get_logger().warning(f"protective stop: {stopped}")

    def _publish_state(self) -> None:
        stamp = ns_to_stamp(self.world.time_ns)
        names, q, v = self.world.joint_state()
        self.pub_joints.publish(joint_state_msg(stamp, names, q, v))
        position, quat = self.world.tcp_pose()
        self.pub_tcp.publish(pose_stamped_msg(stamp, position, quat))
        gap, requested, code = self.world.gripper_status()
        self._log_stalled_opening(code == STOPPED_OPENING, gap, requested)
        self.pub_gripper.publish(ic.gripper_status_to_msg(GripperStatusRecord(
            gap, requested, GRIPPER_OBJECT_STATES[code], self.world.time_ns)))

    def _log_stalled_opening(self, stopped: bool, gap: float, requested: float) -> None:
        """Fingers that stay stopped while opening for STALL_LOG_S: log once what they touch
        (the executor recovers; the log says why it had to)."""
        now = self.world.time_s
        if not stopped:
            self._stopped_opening_since = None
            return
        since = self._stopped_opening_since
        if since is None:
            self._stopped_opening_since = now
        elif since >= 0.0 and now - since >= STALL_LOG_S:
            self._stopped_opening_since = -1.0  # logged
            self.get_logger().warning(
                f"fingers stopped opening at {gap * 1e3:.1f} mm (asked for "
                f"{requested * 1e3:.1f} mm): {self.world.finger_contacts()}")

    def _publish_truth(self) -> None:
        truth = BlockSet(tuple(self.world.block_poses()), self.world.time_ns, "world",
                         self.scene.block_size)
        self.pub_truth.publish(ic.block_set_to_msg(truth))
        self.pub_truth_markers.publish(block_set_to_markers(truth))

    def _publish_events(self) -> None:
        summary = self.world.monitor.summary()
        try:
            events = SimEventsRecord.from_summary(summary, self.world.time_ns)
        except MessageError as err:  # an event kind the message layer does not know (yet)
            self.get_logger().error(f"/sim/events: {err}; publishing the counts only",
                                    throttle_duration_sec=10.0)
            events = SimEventsRecord(summary["unintended_contacts"], summary["blocks_lost"],
                                     stamp_ns=self.world.time_ns)
        self.pub_events.publish(ic.sim_events_to_msg(events))

    def _publish_camera(self) -> int:
        stamp_ns = self.world.time_ns
        if stamp_ns < self._blackout_until_ns:
            return stamp_ns  # a dropped frame: nothing rendered, nothing published
        rgb = self.world.render()
        self.pacer.restart(self.world.time_s)  # the render's wall time is not simulated time
        self.pub_image.publish(array_to_image(rgb, stamp_ns))
        if self.pub_compressed.get_subscription_count():
            self.pub_compressed.publish(array_to_compressed_image(rgb, stamp_ns))
        self.pub_info.publish(intrinsics_to_camera_info(
            self.world.camera.intrinsics, stamp_ns, rectified=self.world.camera.rectified))
        return stamp_ns

    def destroy_node(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=10.0)
        self.world.close()
        super().destroy_node()


def _period_steps(physics_hz: float, rate_hz: float) -> int:
    return max(1, round(physics_hz / rate_hz))


TOPICS = """
subscribes: /arm/cartesian_setpoint (geometry_msgs/PoseStamped, world), /gripper/command
  (std_msgs/Float64, gap m), /executor/status (densepack_interfaces/ExecutorStatus),
  /sim/disturb (densepack_interfaces/Disturbance), /sim/camera_blackout (std_msgs/Float64, s:
  drop camera frames, fault injection)
publishes:  /clock, /joint_states, /tcp_pose, /gripper/status (densepack_interfaces/
  GripperStatus), /camera/image_raw (rgb8), /camera/camera_info, /sim/ground_truth
  (densepack_interfaces/BlockPoseArray; MarkerArray on /sim/ground_truth/markers),
  /sim/events (densepack_interfaces/SimEvents, latched)
services:   /sim/reset, /camera/trigger (std_srvs/Trigger)
"""

SPEC = NodeSpec(
    "sim",
    SimNode,
    "The simulated UR10e cell (PyBullet): arm controller with IK, 2F-85 gripper, tagged "
    "blocks, overhead camera, event monitor.",
    configs=SIM_PARAMETERS,
    topics=TOPICS,
    # Callbacks only validate and queue for the sim loop; a service waits for the loop's
    # answer, which needs no other callback, so one thread serves them all.
    threads=1,
)


def main(args: Any = None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
