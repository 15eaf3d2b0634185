"""``densepack-sim``: the simulated UR10e cell as a ROS 2 node.

The sim stands in for the cell's drivers, not for densepack: it speaks ur_robot_driver's,
the Robotiq driver's and a camera driver's names and types (``msgs_py.drivers``), and what only
a simulator has (clock, ground truth, events, faults, reset, render requests) lives under
``/sim/``. There is no IK here: the arm node (``densepack-arm``) turns setpoints into joint
trajectories, as it does for a real UR.

One thread (``sim-loop``) owns the PyBullet world: it steps physics, runs the UR's motion
controller, renders, and publishes. ROS callbacks never touch the world; they queue a command
that the loop applies between two physics steps (services wait for the loop's answer). So
rendering pauses physics, and nothing is half-applied: a malformed or refused command is
logged, as the driver logs it, and changes nothing.

Pacing (``nodes.sim.pacing``): in lockstep with the arm node's commands, moving or holding
still, as fast as the machine allows; at ``real_time_factor`` while none is in force (the
cell waits for a frame to be judged, or for a plan). A render costs no simulated time (a real
camera's exposure is milliseconds). Where the loop's wall time goes is logged now and then.
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

from densepack_interfaces.msg import BlockPoseArray, SimEvents
from densepack_interfaces.msg import ExecutorStatus as ExecutorStatusMsg
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_msgs.msg import Float64, Header
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import BlockSet, MessageError
from msgs_py import ros as msg_codecs
from msgs_py.ros import block_set_to_markers, ns_to_stamp, stamp_to_ns
from msgs_py.ros.image import (
    array_to_compressed_image,
    array_to_image,
    intrinsics_to_camera_info,
)
from msgs_py.sim import SimEvents as SimEventsRecord
from msgs_py.status import GRIPPER_OBJECT_STATES
from nodes.common.params import current_config, declare_config
from nodes.common.qos import LATCHED, RELIABLE, camera_qos
from nodes.common.runner import NodeSpec, run_node
from nodes.sim.config import SIM_PARAMETERS, CameraConfig, RandomSceneConfig, SimConfig
from nodes.sim.driver_side import DriverSide
from nodes.sim.fault_inputs import FaultInputs
from nodes.sim.layout import load_sim_scene, scene_problems
from nodes.sim.pacing import LoopTimes, Pacer, period_steps
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


#: Held at 0 (start_paused), the clock and the joint states go out this often (wall s).
PAUSED_STATE_S = 0.1
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
        self.pacer = Pacer(self.config.real_time_factor, self.config.lockstep_margin_s)
        self._frames_due: list[int] = []  # render requests (ns) the clock has not reached
        self._paused = self.config.start_paused  # until /sim/start
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
        """The scene of scene_file and random.* as they are now (set since start: a reset's)."""
        rnd = current_config(self, RandomSceneConfig, "random.")
        scene_file = current_config(self, SimConfig).scene_file
        scene = load_sim_scene(scene_file, rnd.n_blocks, rnd.density, rnd.seed)
        problems = scene_problems(scene, self.camera_config.model(), self.config.home_joints)
        if problems:
            raise ValueError("the scene does not fit the cell: " + "; ".join(problems))
        return scene

    def _make_interfaces(self) -> None:
        """The drivers' names and types (msgs_py.drivers), and the sim's own under /sim/."""
        group = ReentrantCallbackGroup()
        self.pub_clock = self.create_publisher(Clock, "/clock", CLOCK_QOS)
        # ur_robot_driver and the Robotiq driver (in its namespace)
        self.drivers = DriverSide(self, lambda: self.world, self._queue, self.pacer, group)
        camera = camera_qos(self.camera_config.reliability)
        # the camera: a driver's topics (frames at camera.rate_hz, and one per render request)
        self.pub_image = self.create_publisher(Image, "/camera/image_raw", camera)
        self.pub_info = self.create_publisher(CameraInfo, "/camera/camera_info", camera)
        # image_transport's compressed sibling (JPEG, ~115 kB): what viewers, best-effort
        # subscribers and bags take. Encoded only while someone listens.
        self.pub_compressed = self.create_publisher(CompressedImage,
                                                    "/camera/image_raw/compressed", camera)
        # what only a simulator has
        self.pub_truth = self.create_publisher(BlockPoseArray, "/sim/ground_truth", RELIABLE)
        self.pub_truth_markers = self.create_publisher(MarkerArray, "/sim/ground_truth/markers",
                                                       RELIABLE)
        self.pub_events = self.create_publisher(SimEvents, "/sim/events", LATCHED)
        self.create_subscription(Header, "/sim/render_request", self._on_render_request,
                                 RELIABLE, callback_group=group)
        self.create_subscription(Float64, "/sim/speed_slider", self._on_speed_slider, RELIABLE,
                                 callback_group=group)
        # Volatile on purpose: it matches the executor whether it latches its status or not.
        self.create_subscription(ExecutorStatusMsg, "/executor/status", self._on_status,
                                 RELIABLE, callback_group=group)
        self.faults = FaultInputs(self, lambda: self.world, self._queue, group)
        self.create_service(Trigger, "/sim/reset", self._on_reset, callback_group=group)
        self.create_service(Trigger, "/sim/start", self._on_start, callback_group=group)

    # --- callbacks (any executor thread): validate, then queue ----------------------------------
    def _queue(self, command: Callable[[], None]) -> None:
        """Hand ``command`` to the sim loop (the only thread that touches the world)."""
        self._commands.append(command)
        self._wake.set()

    def _on_speed_slider(self, msg: Float64) -> None:
        fraction = float(msg.data)
        if not (math.isfinite(fraction) and 0.0 <= fraction <= 1.0):
            self.get_logger().warning(f"/sim/speed_slider refused: {fraction} is not in [0, 1]")
            return
        self._queue(lambda: self.world.set_speed_slider(fraction))

    def _on_render_request(self, msg: Header) -> None:
        """A frame of the moment the header's stamp names, or now if it has passed (sim
        only: a real camera streams, and its frame of that moment is the first stamped
        after it); the frame's stamp says when it was taken."""
        try:
            at = stamp_to_ns(msg.stamp)
        except (MessageError, ValueError):
            at = 0  # a stamp that says nothing: now
        self._queue(lambda: self._frames_due.append(at))

    def _on_status(self, msg: ExecutorStatusMsg) -> None:
        try:
            status = msg_codecs.executor_status_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.get_logger().warning(f"ignoring a malformed /executor/status: {err}")
            return
        self._queue(lambda: self.world.set_manipulated(status.block))

    def _on_start(self, request, response):
        def apply() -> str:
            was, self._paused = self._paused, False
            self.pacer.restart(self.world.time_s)
            return "started" if was else "running already"
        return self._answer(apply, response)

    def _on_reset(self, request, response):
        def apply() -> str:
            scene = self._load_scene()
            (self.world.lay_out if self.config.reset_scene_only else self.world.reset)(scene)
            self.pacer.restart(self.world.time_s)
            self._frames_due.clear()
            self.scene = scene
            self._publish_events()
            return f"reset: {len(scene.blocks)} blocks at t = {self.world.time_s:.3f} s"
        return self._answer(apply, response)

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
        every = period_steps(cfg.physics_rate_hz, {
            "clock": cfg.clock_rate_hz, "state": cfg.state_rate_hz, "status": cfg.status_rate_hz,
            "truth": cfg.ground_truth_rate_hz, "events": cfg.events_rate_hz,
            "camera": self.camera_config.rate_hz})
        self.pacer.restart(self.world.time_s)
        shared = time.monotonic()  # when the loop last let go of the GIL
        times = LoopTimes()
        while not self._stop.is_set() and self.context.ok():
            try:
                t0 = time.monotonic()
                while self._commands:
                    self._commands.popleft()()
                self._render_due()
                now = time.monotonic()
                times.add("commands", now - t0)
                if self._paused:  # the clock held: its ticks and the drivers' states go on
                    self.pub_clock.publish(Clock(clock=ns_to_stamp(self.world.time_ns)))
                    self._publish_state()
                    self.drivers.publish_robot_state()
                    self._wake.wait(PAUSED_STATE_S)
                    self._wake.clear()
                    continue
                wait = self.pacer.wait_before_step(self.world.time_s, now)
                if wait > 0.0:
                    self._wake.wait(min(wait, MAX_IDLE_WAIT_S))
                    self._wake.clear()
                    shared = time.monotonic()
                    times.add(self.pacer.waiting, shared - now)
                    continue
                if now - shared > GIL_SHARE_EVERY_S:
                    time.sleep(GIL_SHARE_S)
                    shared = time.monotonic()
                self.world.step()
                t1 = time.monotonic()
                self._render_due()
                self._publish_due(every)
                self.drivers.publish_robot_state()
                t2 = time.monotonic()
                times.add("stepping", t1 - now)
                times.add("publishing", t2 - t1)
                line = times.report(self.world.time_s, t2)
                if line:
                    self.get_logger().info(line)
            except Exception as err:  # never let the loop die silently
                if not self.context.ok():
                    break  # shutting down: publishers are gone
                self.get_logger().error(f"sim loop error: {type(err).__name__}: {err}")

    def _render_due(self) -> None:
        """Render once for every requested moment the clock has reached."""
        due = [at for at in self._frames_due if at <= self.world.time_ns]
        if due:
            self._frames_due = [at for at in self._frames_due if at > self.world.time_ns]
            self._publish_camera()

    def _publish_due(self, every: dict[str, int]) -> None:
        k = self.world.step_count
        if k % every["clock"] == 0:
            self.pub_clock.publish(Clock(clock=ns_to_stamp(self.world.time_ns)))
        if k % every["state"] == 0:
            self._publish_state()
        if k % every["status"] == 0:
            self.drivers.publish_status(ns_to_stamp(self.world.time_ns))
        if k % every["truth"] == 0:
            self._publish_truth()
        if k % every["events"] == 0:
            self._publish_events()
        if every["camera"] and k % every["camera"] == 0:
            self._publish_camera()

    def _publish_state(self) -> None:
        self.drivers.publish_state(ns_to_stamp(self.world.time_ns))
        gap, requested, code = self.world.fingers.status()
        self._log_stalled_opening(code == STOPPED_OPENING, gap, requested)

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
                f"{requested * 1e3:.1f} mm): {self.world.fingers.contacts()}")

    def _publish_truth(self) -> None:
        truth = BlockSet(tuple(self.world.block_poses()), self.world.time_ns, "world",
                         self.scene.block_size)
        self.pub_truth.publish(msg_codecs.block_set_to_msg(truth))
        self.pub_truth_markers.publish(block_set_to_markers(truth))

    def _publish_events(self) -> None:
        summary = self.world.monitor.summary()
        try:
            events = SimEventsRecord.from_summary(summary, self.world.time_ns)
        except MessageError as err:  # an event kind the message layer does not know (yet)
            self.get_logger().error(f"/sim/events: {err}; publishing the counts only",
                                    throttle_duration_sec=10.0)
            events = SimEventsRecord(summary["unintended_contacts"], summary["blocks_lost"],
                                     stamp_ns=self.world.time_ns,
                                     raised=tuple(summary["blocks_raised"]))
        self.pub_events.publish(msg_codecs.sim_events_to_msg(events))

    def _publish_camera(self) -> int:
        stamp_ns = self.world.time_ns
        if stamp_ns < self.faults.blackout_until_ns:
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


TOPICS = """
A stand-in for ur_robot_driver, the Robotiq 2F-85 driver and a camera driver (their names
and types; docs/contracts.md), plus what only a simulator has, under /sim/:
subscribes: /scaled_joint_trajectory_controller/joint_trajectory (trajectory_msgs/
  JointTrajectory), /forward_position_controller/commands (std_msgs/Float64MultiArray; the
  active one of the two is motion_controller), /gripper/robotiq_position_controller/commands
  (std_msgs/Float64MultiArray, knuckle rad), /sim/render_request (std_msgs/Header: a frame
  now), /sim/speed_slider (std_msgs/Float64, fraction), /sim/fault, /sim/disturb,
  /sim/camera_blackout, /executor/status (who handles which block, for the event monitor)
publishes:  /clock, /joint_states (arm, driver order), /gripper/joint_states (knuckle),
  /tcp_pose_broadcaster/pose (frame base), /speed_scaling_state_broadcaster/speed_scaling
  (percent), /io_and_status_controller/{safety_mode, robot_mode, robot_program_running}
  (ur_dashboard_msgs, std_msgs/Bool; latched), /camera/image_raw, /camera/camera_info,
  /camera/image_raw/compressed, /sim/ground_truth (+ /markers), /sim/events (latched)
services:   /dashboard_client/{unlock_protective_stop, close_safety_popup, stop, play, pause,
  power_on, power_off, brake_release}, /sim/reset (std_srvs/Trigger)
"""

SPEC = NodeSpec(
    "sim",
    SimNode,
    "The simulated UR10e cell (PyBullet) behind the drivers' interfaces: the UR's motion "
    "controllers, safety system and dashboard, the 2F-85's knuckle joint, tagged blocks, an "
    "overhead camera, ground truth and an event monitor.",
    configs=SIM_PARAMETERS,
    topics=TOPICS,
    # Callbacks only validate and queue for the sim loop; a service waits for the loop's
    # answer, which needs no other callback, so one thread serves them all.
    threads=1,
    publishes_frames=True,
)


def main(args: Any = None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
