"""``densepack-executor``: streams a plan to the arm as Cartesian setpoints, closing the loop.

Subscriptions: ``/plan`` (Plan, latched), ``/blocks/detected`` (BlockPoseArray),
``/planner/status`` (PlannerStatus, latched), ``/arm/tcp_pose`` (PoseStamped) and
``/arm/status`` (ArmStatus) from the arm node, ``/gripper/status`` from the gripper node,
``/camera/camera_info`` (when a frame was taken). Publications: ``/arm/cartesian_setpoint``
(PoseStamped, world, gripper down), ``/gripper/command`` (Float64, m), ``/executor/status``
(ExecutorStatus, latched), ``/goal_layout`` (GoalLayout, latched: a Rearrange goal's layout),
``/sim/render_request`` (a frame now, in the sim only: a real camera streams). Services:
``/executor/start``, ``/executor/stop`` (Trigger). Action: ``/rearrange`` (Rearrange,
``nodes/executor/rearrange.py``). Clients: ``/planner/replan``,
``/arm/unlock_protective_stop``, ``/arm/lease`` and ``/gripper/lease`` (it holds both while a
run goes and commands on their private topics: ``nodes.common.lease_ros``). Typed messages
are ``densepack_interfaces``. All the behaviour lives in ``ExecutorCore``; this node only
converts and forwards.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import threading
from collections.abc import Callable
from typing import Any

from densepack_interfaces.msg import ArmStatus, BlockPoseArray, GripperStatus, Placement
from densepack_interfaces.msg import ExecutorStatus as ExecutorStatusMsg
from densepack_interfaces.msg import Plan as PlanMsg
from densepack_interfaces.msg import PlannerStatus as PlannerStatusMsg
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, JointState
from std_msgs.msg import Float64, Header
from std_srvs.srv import Trigger

from msgs_py import ExecutorStatus, MessageError, drivers
from msgs_py.camera import CameraIntrinsics, CameraPose
from msgs_py.ros import (
    arm_status_from_msg,
    block_set_from_msg,
    executor_status_to_msg,
    gripper_status_from_msg,
    placement_to_msg,
    plan_from_msg,
    planner_status_from_msg,
    stamp_to_ns,
)
from msgs_py.ros.fields import set_world_header
from msgs_py.ros.image import camera_info_to_intrinsics
from nodes.common.camera_model import CameraModel, load_camera_pose
from nodes.common.joints import values_by_name
from nodes.common.lease_ros import LeaseClient
from nodes.common.params import declare_config
from nodes.common.paths import config_path
from nodes.common.qos import CAMERA, LATCHED, RELIABLE
from nodes.common.runner import NodeSpec, run_node
from nodes.common.standard_msgs import joint_state_values, stamp_seconds, tool_pose_values
from nodes.common.transforms import tool_down_quaternion
from nodes.executor.arm_watch import ArmWatch
from nodes.executor.config import ExecutorConfig
from nodes.executor.core import ExecutorCore
from nodes.executor.motion import ToolPose
from nodes.executor.rearrange import RearrangeServer
from nodes.executor.states import CONTROL_STATES
from nodes.executor.visibility import View
from nodes.robot import ur10e

TOPICS = """\
subscribes: /plan (densepack_interfaces/Plan, latched),
            /blocks/detected (densepack_interfaces/BlockPoseArray),
            /planner/status (densepack_interfaces/PlannerStatus, latched),
            /arm/tcp_pose (geometry_msgs/PoseStamped: the arm node's, from the joints),
            /arm/status (densepack_interfaces/ArmStatus, latched: can the arm move),
            /joint_states (sensor_msgs/JointState, the arm driver's: its IK branch, to
            predict what it covers; with look_while_moving),
            /gripper/status (densepack_interfaces/GripperStatus: grasp supervision),
            /camera/camera_info (sensor_msgs/CameraInfo: a frame was taken; the lens, to
            predict what the arm covers), /detector/calibration (diagnostic_msgs/
            DiagnosticStatus, latched: checked recently, the camera check is skipped)
publishes:  /arm/cartesian_setpoint (geometry_msgs/PoseStamped),
            /gripper/command (std_msgs/Float64): during a run, on the private topics of the
            arm's and the gripper's leases instead (/arm/lease/<token>/cartesian_setpoint,
            /gripper/lease/<token>/command),
            /executor/status (densepack_interfaces/ExecutorStatus, latched),
            /executor/placements (densepack_interfaces/Placement: blocks set down),
            /goal_layout (densepack_interfaces/GoalLayout, latched: a /rearrange goal's layout),
            /sim/render_request (std_msgs/Header: a frame now; only a sim listens)
action:     /rearrange (densepack_interfaces/action/Rearrange)
services:   /executor/start, /executor/stop (std_srvs/Trigger)
calls:      /planner/replan, /arm/unlock_protective_stop (std_srvs/Trigger),
            /arm/lease, /gripper/lease (densepack_interfaces/ControlLease)"""


def tool_pose_from_msg(msg: PoseStamped) -> ToolPose:
    """The measured TCP; MessageError names a non-finite field."""
    return ToolPose(*tool_pose_values(msg))


class ExecutorNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("executor", **kwargs)
        self.config = declare_config(self, ExecutorConfig)
        self.core = ExecutorCore(self.config)
        self.lock = threading.Lock()
        # the public command topics, or the private ones of the leases held during a run
        self.arm_control = LeaseClient(self, "arm", "cartesian_setpoint", PoseStamped)
        # the fingers' command is a state (where they should be): it goes again at every switch
        # to a new lease, however old (a gripper node that restarted while the executor let go
        # of a block lost the open sent meanwhile, and the arm parked with the block in hand)
        self.gripper_control = LeaseClient(self, "gripper", "command", Float64,
                                           resend_s=math.inf)
        self._want_control = False  # the leases wanted at the last tick
        self.arm_watch = ArmWatch.at_rate(self.config.rate_hz)
        self.status_pub = self.create_publisher(ExecutorStatusMsg, "/executor/status", LATCHED)
        self.create_subscription(PlanMsg, "/plan", self.on_plan, LATCHED)
        self.create_subscription(BlockPoseArray, "/blocks/detected", self.on_detection, RELIABLE)
        self.create_subscription(PoseStamped, "/arm/tcp_pose", self.on_tcp, RELIABLE)
        self.create_subscription(GripperStatus, "/gripper/status", self.on_gripper, RELIABLE)
        self.create_subscription(ArmStatus, "/arm/status", self.on_arm_status, LATCHED)
        self.create_subscription(CameraInfo, "/camera/camera_info", self.on_camera_info, CAMERA)
        self.create_subscription(DiagnosticStatus, "/detector/calibration", self.on_calibration,
                                 LATCHED)
        self.render_pub = self.create_publisher(Header, "/sim/render_request", RELIABLE)
        self._frame_after_ns: int | None = None  # a frame taken since then is the look's
        self._camera_pose = self._load_camera_pose() if self.config.look_while_moving else None
        self._joint_state: JointState | None = None
        if self.config.look_while_moving:
            self.create_subscription(JointState, drivers.JOINT_STATES, self.on_joint_state,
                                     RELIABLE)
        self._intrinsics: CameraIntrinsics | None = None
        self.placement_pub = self.create_publisher(Placement, "/executor/placements", RELIABLE)
        self.create_subscription(PlannerStatusMsg, "/planner/status", self.on_planner_status,
                                 LATCHED)
        self.create_service(Trigger, "/executor/start", self.on_start)
        self.create_service(Trigger, "/executor/stop", self.on_stop)
        self.replanner = self.create_client(Trigger, "/planner/replan")
        self.unlocker = self.create_client(Trigger, "/arm/unlock_protective_stop")
        self._last_status: ExecutorStatus | None = None
        self._last_status_time = 0.0
        self.rearrange = RearrangeServer(self, self.core, self.lock, self.config)
        self.create_timer(1.0 / self.config.rate_hz, self.on_tick)
        self.get_logger().info(f"streaming at {self.config.rate_hz:.0f} Hz; waiting for /plan")

    # --- inputs -----------------------------------------------------------------------------------
    def _decoded(self, msg: Any, decode: Callable[[Any], Any], topic: str,
                 errors: tuple[type[Exception], ...] = (MessageError,)) -> Any:
        """``decode(msg)``, or None after a warning naming the topic: a malformed message
        never reaches the core."""
        try:
            return decode(msg)
        except errors as err:
            self.get_logger().warning(f"ignoring a malformed {topic}: {err}")
            return None

    def on_plan(self, msg: PlanMsg) -> None:
        plan = self._decoded(msg, plan_from_msg, "/plan")
        if plan is not None:
            with self.lock:
                self.core.on_plan(plan)

    def on_detection(self, msg: BlockPoseArray) -> None:
        detection = self._decoded(msg, block_set_from_msg, "/blocks/detected")
        if detection is not None:
            with self.lock:
                self.core.on_detection(detection)
            self.rearrange.on_detection(detection)

    def on_tcp(self, msg: PoseStamped) -> None:
        pose = self._decoded(msg, tool_pose_from_msg, "/arm/tcp_pose", (ValueError,))
        if pose is None:
            return
        stamp = stamp_seconds(msg.header.stamp)
        with self.lock:
            self.arm_watch.on_tcp()
            self.core.on_tcp(pose, stamp if stamp > 0.0 else None)

    def on_joint_state(self, msg: JointState) -> None:
        """The arm driver's joint states, kept for the next tick to read (ur_robot_driver
        publishes them at 500 Hz: only the latest is decoded, its posture and the rates since
        the one before)."""
        self._joint_state = msg

    def _take_joint_state(self) -> None:
        """The latest joint state since the last tick (any order, by name; other joints'
        are ignored) to the core."""
        msg, self._joint_state = self._joint_state, None
        values = None if msg is None else self._decoded(msg, joint_state_values,
                                                        drivers.JOINT_STATES)
        q = None if values is None else values_by_name(values[0], values[1], ur10e.ARM_JOINTS)[0]
        if q is not None:
            self.core.on_arm_joints(q, values[2])

    def on_planner_status(self, msg: PlannerStatusMsg) -> None:
        status = self._decoded(msg, planner_status_from_msg, "/planner/status")
        if status is None:
            return
        self.rearrange.on_planner_status(status)
        with self.lock:
            self.core.on_planner_waiting(status.wants_detection, status.last_error)
        if status.state == "failed":
            with self.lock:
                self.core.on_planner_failed(status.last_error)

    def on_gripper(self, msg: GripperStatus) -> None:
        """The gripper's status; while the executor wants the fingers, a gripper that does not
        take its commands yet (a node that restarted: its lease not yet taken again, or the
        commands not yet on the new lease's topic) reports nothing about them: not judged
        (its request, where the fingers stood, would read as a stray command)."""
        status = self._decoded(msg, gripper_status_from_msg, "/gripper/status")
        if status is None:
            return
        self.gripper_control.on_device_status(status.lease_holder)
        if self._want_control and not self.gripper_control.takes_my_commands(status.lease_holder):
            return
        with self.lock:
            self.core.on_gripper(status)

    def on_arm_status(self, msg: ArmStatus) -> None:
        status = self._decoded(msg, arm_status_from_msg, "/arm/status", (MessageError,
                                                                         ValueError))
        if status is not None:
            self.arm_control.on_device_status(status.lease_holder)
            with self.lock:
                self.arm_watch.on_status(status.lease_holder)
                self.core.on_arm_status(status)

    def on_calibration(self, msg: DiagnosticStatus) -> None:
        checked = {DiagnosticStatus.OK: True, DiagnosticStatus.ERROR: False}.get(msg.level)
        with self.lock:
            self.core.on_calibration(checked)

    def on_camera_info(self, msg: CameraInfo) -> None:
        """The camera as the executor knows it (to look on the way); the first frame stamped
        at or after the executor asked for one: the look's frame is taken, the arm may move
        on (a streaming camera's later frames change nothing)."""
        self._know_camera(msg)
        wanted = self._frame_after_ns
        stamp = stamp_to_ns(msg.header.stamp)
        if wanted is None or stamp < wanted:
            return
        self._frame_after_ns = None
        with self.lock:
            self.core.on_frame_taken(stamp)

    def _know_camera(self, msg: CameraInfo) -> None:
        """The first camera_info (and any that changes the lens) with the calibration's pose
        makes the camera model the executor predicts the arm's silhouette with."""
        if self._camera_pose is None:
            return
        intrinsics = self._decoded(msg, camera_info_to_intrinsics, "/camera/camera_info",
                                   (MessageError, ValueError))
        if intrinsics is None or intrinsics == self._intrinsics:
            return
        self._intrinsics = intrinsics
        view = View(CameraModel.from_pose(intrinsics, self._camera_pose),
                    self.core.belief.geo.block_size)
        with self.lock:
            self.core.view = view

    def _load_camera_pose(self) -> CameraPose | None:
        path = config_path(self.config.calibration_file)
        try:
            return load_camera_pose(path)
        except (OSError, MessageError) as err:
            self.get_logger().warning(f"no camera pose ({path}: {err}): every action is "
                                      "looked at from the look pose")
            return None

    def on_start(self, request: Trigger.Request, response: Trigger.Response):
        with self.lock:
            response.message = self.core.request_start()
        response.success = True
        return response

    def on_stop(self, request: Trigger.Request, response: Trigger.Response):
        with self.lock:
            response.message = self.core.request_stop()
        response.success = True
        return response

    # --- the streaming loop ----------------------------------------------------------------
    def on_tick(self) -> None:
        now = self.get_clock().now()
        with self.lock:
            self._take_joint_state()
            self.core.on_arm_lost(self.arm_watch.on_tick(self._want_control,
                                                         self.arm_control.takes_my_commands,
                                                         self.arm_control.inherited))
            out = self.core.tick(now.nanoseconds * 1e-9)
            status = self.core.status()
            scripted = self.core.player.busy  # streaming, or held until the arm takes it
        # a run holds the leases; so does any motion outside one (a respawned executor parks
        # the arm before its goal comes back: the arm still holds the lease of the executor
        # that died, under the same name, so the public topic stays closed to it, and the
        # park is held until the lease is taken again)
        commanding = out.setpoint is not None or out.gripper is not None or scripted
        want = self.config.take_control and (status.state in CONTROL_STATES or commanding)
        self._want_control = want
        resends = self.gripper_control.resends
        for line in [*out.log, *self.arm_control.update(want),
                     *self.gripper_control.update(want)]:
            self.get_logger().info(line)
        if self.gripper_control.resends != resends:
            with self.lock:
                self.core.on_gripper_command_resent()
        for stamp_s, missed in out.missed:  # the ticks that came late, in their order
            self.arm_control.publish(self._setpoint_msg(missed, round(stamp_s * 1e9)))
        if out.setpoint is not None:
            self.arm_control.publish(self._setpoint_msg(out.setpoint, now.nanoseconds))
        if out.gripper is not None:
            self.gripper_control.publish(Float64(data=float(out.gripper)))
        if out.placement is not None:
            self.placement_pub.publish(placement_to_msg(out.placement))
        if out.trigger_camera:
            self._frame_after_ns = now.nanoseconds
            self.render_pub.publish(Header(stamp=now.to_msg()))
        if out.request_replan:
            self._call(self.replanner, "/planner/replan")
        if out.unlock_arm:
            self._call(self.unlocker, "/arm/unlock_protective_stop")
        self._publish_status(status, now)

    def _setpoint_msg(self, pose: ToolPose, stamp_ns: int) -> PoseStamped:
        msg = PoseStamped()
        set_world_header(msg, stamp_ns)
        msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = pose.x, pose.y, pose.z
        q = tool_down_quaternion(pose.yaw)
        o = msg.pose.orientation
        o.x, o.y, o.z, o.w = (float(v) for v in q)
        return msg

    def _call(self, client, name: str, on_success: Callable[[str], None] | None = None) -> None:
        if not client.service_is_ready():
            self.get_logger().warning(f"{name} is not available; the executor will retry")
            return
        future = client.call_async(Trigger.Request())
        future.add_done_callback(lambda f: self._answered(name, f, on_success))

    def _answered(self, name: str, future, on_success: Callable[[str], None] | None) -> None:
        try:
            answer = future.result()
        except Exception as err:  # a dying server: the core's timeouts retry
            self.get_logger().warning(f"{name} failed: {err}")
            return
        if answer is None:
            return
        if not answer.success:
            self.get_logger().warning(f"{name} refused: {answer.message}")
        elif on_success is not None:
            on_success(answer.message)

    def _publish_status(self, status: ExecutorStatus, now) -> None:
        """On every change of state/progress, and once a second with fresh metrics."""
        summary = dataclasses.replace(status, metrics={})
        now_s = now.nanoseconds * 1e-9
        if summary != self._last_status or now_s - self._last_status_time >= 1.0:
            try:
                msg = executor_status_to_msg(status, now.nanoseconds)
            except MessageError as err:
                self.get_logger().error(f"/executor/status not sent: {err}",
                                        throttle_duration_sec=5.0)
                return
            self.status_pub.publish(msg)
            self._last_status = summary
            self._last_status_time = now_s

    def destroy_node(self) -> None:
        self.rearrange.close()
        for control in (self.arm_control, self.gripper_control):
            try:
                control.close()
            except Exception as err:  # the context is down: the leases end with the graph
                self.get_logger().debug(f"lease not given back: {err}")
        super().destroy_node()


SPEC = NodeSpec(
    "executor",
    ExecutorNode,
    "Streams a plan's actions to the arm as Cartesian setpoints and closes the loop on "
    "perception (observe after each action, replan on drift, verify the goal).",
    configs=(("", ExecutorConfig),),
    topics=TOPICS,
    threads=1,  # every callback is short; the timer, inputs and service answers take turns
)


def main(args=None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
