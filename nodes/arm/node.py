"""``densepack-arm``: Cartesian tool setpoints in, ur_robot_driver's joint commands out.

The executor streams ``/arm/cartesian_setpoint`` (tool pose in ``world``, the UR's base
frame); this node solves the UR10e's IK, plays the stream back like a UR's servoj and sends the
joint commands to ur_robot_driver: short JointTrajectory snippets to its
``scaled_joint_trajectory_controller`` (default), or positions to its
``forward_position_controller``. It reads ``/joint_states`` by joint name, publishes the tool
pose computed from the measured joints (``/arm/tcp_pose``), follows the speed slider, and
turns the driver's safety mode, robot mode and program state into ``/arm/status``; on
``/arm/unlock_protective_stop`` it gets a UR out of a protective stop the way one must
(``nodes.arm.unlock``). Like a UR with its one external control client, it takes one
commander at a time: a node holding ``/arm/lease`` streams on its private topic and the
public one is refused, its publishers named (``nodes.common.lease_ros``). The same node
drives the sim, which serves the driver's interfaces.
"""

from __future__ import annotations

import dataclasses
import sys
import threading
from typing import Any

from densepack_interfaces.msg import ArmStatus
from geometry_msgs.msg import PoseStamped
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory
from ur_dashboard_msgs.msg import RobotMode, SafetyMode

from msgs_py import MessageError, drivers
from msgs_py import ros as msg_codecs
from msgs_py.ros import ns_to_stamp
from nodes.arm.commands import setpoint_tick_gap
from nodes.arm.config import ARM_PARAMETERS, ArmConfig
from nodes.arm.core import ArmCore, ArmOutputs
from nodes.common.lease import LeaseConfig
from nodes.common.lease_ros import LeaseServer
from nodes.common.params import declare_config
from nodes.common.qos import LATCHED, RELIABLE
from nodes.common.runner import NodeSpec, run_node
from nodes.common.standard_msgs import (
    joint_state_values,
    pose_from_msg,
    pose_stamped_msg,
    stamp_seconds,
    trajectory_msg,
)
from nodes.common.transforms import matrix_to_quaternion
from nodes.robot import ur10e


class ArmNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("arm", **kwargs)
        self.config: ArmConfig = declare_config(self, ArmConfig)
        lease_config = declare_config(self, LeaseConfig, "lease.")
        self.core = ArmCore(self.config)
        self.lock = threading.Lock()  # the core is touched by callbacks of several threads
        self._status_sent: tuple | None = None
        self._status_at = 0.0
        self._ticked_at = -1.0  # node clock (s) of the last tick
        self._tick_lock = threading.Lock()
        inputs = ReentrantCallbackGroup()
        ticks = MutuallyExclusiveCallbackGroup()
        # the executor's side: /arm/cartesian_setpoint, or the lease holder's private topic
        self.lease = LeaseServer(self, "arm", "cartesian_setpoint", PoseStamped,
                                 self.on_setpoint, lease_config, callback_group=inputs)
        self.create_service(Trigger, "/arm/unlock_protective_stop", self.on_unlock,
                            callback_group=inputs)
        self.pub_tcp = self.create_publisher(PoseStamped, "/arm/tcp_pose", RELIABLE)
        self.pub_status = self.create_publisher(ArmStatus, "/arm/status", LATCHED)
        # the driver's side
        self.create_subscription(JointState, drivers.JOINT_STATES, self.on_joint_state,
                                 RELIABLE, callback_group=inputs)
        self.create_subscription(SafetyMode, drivers.SAFETY_MODE_TOPIC, self._driver(
            lambda m: self.core.on_safety_mode(m.mode)), LATCHED, callback_group=inputs)
        self.create_subscription(RobotMode, drivers.ROBOT_MODE_TOPIC, self._driver(
            lambda m: self.core.on_robot_mode(m.mode)), LATCHED, callback_group=inputs)
        self.create_subscription(Bool, drivers.PROGRAM_RUNNING_TOPIC, self._driver(
            lambda m: self.core.on_program_running(m.data)), LATCHED, callback_group=inputs)
        self.create_subscription(Float64, drivers.SPEED_SCALING_TOPIC, self._driver(
            lambda m: self.core.on_speed_scaling(m.data)), RELIABLE, callback_group=inputs)
        if self.config.command_interface == "trajectory":
            self.pub_command = self.create_publisher(JointTrajectory, drivers.TRAJECTORY_TOPIC,
                                                     RELIABLE)
        else:
            self.pub_command = self.create_publisher(Float64MultiArray,
                                                     drivers.FORWARD_POSITION_TOPIC, RELIABLE)
        self.dashboard = {call: self.create_client(Trigger, drivers.dashboard_service(call),
                                                   callback_group=inputs)
                          for call in drivers.DASHBOARD_TRIGGERS}
        self.create_timer(1.0 / self.config.command_rate_hz, self.on_timer, callback_group=ticks)
        self.get_logger().info(
            f"arm node: setpoints -> {self.config.command_interface} commands on "
            f"{self.pub_command.topic_name} at {self.config.command_rate_hz:.0f} Hz")

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    # --- inputs ---------------------------------------------------------------------------------
    def _driver(self, apply):
        """A driver status callback: applied under the lock; a bad value is logged, not fatal."""
        def callback(msg: Any) -> None:
            try:
                with self.lock:
                    apply(msg)
            except (ValueError, TypeError) as err:
                self.get_logger().warning(f"ignoring a driver status: {err}",
                                          throttle_duration_sec=5.0)
        return callback

    def on_joint_state(self, msg: JointState) -> None:
        try:
            names, positions, stamp = joint_state_values(msg)
        except MessageError as err:
            self.get_logger().warning(f"{drivers.JOINT_STATES} ignored: {err}",
                                      throttle_duration_sec=5.0)
            return
        with self.lock:
            tcp = self.core.on_joint_state(names, positions, stamp)
        if tcp is not None:
            self.pub_tcp.publish(pose_stamped_msg(msg.header.stamp, tcp[:3, 3],
                                                  matrix_to_quaternion(tcp[:3, :3])))

    def on_setpoint(self, msg: PoseStamped) -> None:
        try:
            position, quat, frame = pose_from_msg(msg)
        except (MessageError, ValueError) as err:
            self.get_logger().warning(f"/arm/cartesian_setpoint refused: {err}",
                                      throttle_duration_sec=1.0)
            return
        stamp = stamp_seconds(msg.header.stamp) or None
        with self.lock:
            result = self.core.on_setpoint(position, quat, frame, stamp)
        self._after_setpoints(result, [round(v, 4) for v in position])

    def _after_setpoints(self, result, where: list[float]) -> None:
        if not result.accepted:
            self.get_logger().warning(f"setpoint {where} refused, the arm holds: "
                                      f"{result.reason}", throttle_duration_sec=1.0)
            return
        # New setpoints lengthen what the arm can be commanded: send it now, not at the next
        # tick of the clock, so the driver's trajectory never runs short while the executor
        # streams (the sim waits for it; a real arm would slow down); see setpoint_tick_gap.
        self.tick(min_gap=setpoint_tick_gap(self._now(), self._ticked_at,
                                            self.config.command_rate_hz))

    def on_unlock(self, request: Trigger.Request, response: Trigger.Response):
        with self.lock:
            response.success, response.message = self.core.request_unlock(self._now())
        return response

    # --- the tick -------------------------------------------------------------------------------
    def tick(self, min_gap: float = 0.0) -> None:
        """One command to the driver (on the timer, and on each setpoint), at most one per
        ``min_gap`` of the node's clock."""
        with self._tick_lock:
            now = self._now()
            if now - self._ticked_at < min_gap:
                return
            self._ticked_at = now
            with self.lock:
                out = self.core.tick(now)
                status = self.core.status(round(now * 1e9))
            lease = self.lease.status()
            status = dataclasses.replace(status, lease_holder=lease.holder,
                                         refused_commands=lease.refused_commands,
                                         refused_commanders=lease.refused_commanders)
            self._send(out, now)
            self._publish_status(status, now)

    def on_timer(self) -> None:
        """The clock's tick: settling, pausing and waiting go on without setpoints."""
        self.tick(min_gap=0.75 / self.config.command_rate_hz)

    def _send(self, out: ArmOutputs, now: float) -> None:
        for line in out.log:
            self.get_logger().info(line)
        for call in out.dashboard_calls:
            self._call_dashboard(call)
        if out.trajectory is not None:
            snippet = out.trajectory
            self.pub_command.publish(trajectory_msg(
                ns_to_stamp(round(snippet.start_s * 1e9)), ur10e.ARM_JOINTS, snippet.times,
                snippet.positions, snippet.velocities))
        if out.positions is not None:
            self.pub_command.publish(Float64MultiArray(data=[float(v) for v in out.positions]))

    def _call_dashboard(self, call: str) -> None:
        client = self.dashboard[call]
        if not client.service_is_ready():
            self.get_logger().warning(f"{drivers.dashboard_service(call)} is not available",
                                      throttle_duration_sec=5.0)
            with self.lock:
                self.core.on_dashboard_answer(call, False, "service not available", self._now())
            return
        self.get_logger().info(f"dashboard: {call}")

        def done(future) -> None:
            try:
                answer = future.result()
                success, message = bool(answer.success), str(answer.message)
            except Exception as err:  # the call failed: the unlock fails, the executor retries
                success, message = False, f"{type(err).__name__}: {err}"
            with self.lock:
                self.core.on_dashboard_answer(call, success, message, self._now())
        client.call_async(Trigger.Request()).add_done_callback(done)

    def _publish_status(self, status, now: float) -> None:
        """On every change of state or reason, and at status_rate_hz (the stream time)."""
        key = (status.state, status.reason, status.program_running, status.safety_mode,
               status.speed_scaling, status.lease_holder, status.refused_commanders)
        if key == self._status_sent and now - self._status_at < 1.0 / self.config.status_rate_hz:
            return
        self._status_sent, self._status_at = key, now
        self.pub_status.publish(msg_codecs.arm_status_to_msg(status))


TOPICS = """
subscribes: /arm/cartesian_setpoint (geometry_msgs/PoseStamped, world: the executor's stream;
  refused while a node holds /arm/lease: then /arm/lease/<token>/cartesian_setpoint only);
  from ur_robot_driver: /joint_states (by name), /speed_scaling_state_broadcaster/speed_scaling
  (percent), /io_and_status_controller/{safety_mode, robot_mode, robot_program_running}
publishes:  /scaled_joint_trajectory_controller/joint_trajectory (trajectory_msgs/
  JointTrajectory) or /forward_position_controller/commands (std_msgs/Float64MultiArray);
  /arm/tcp_pose (geometry_msgs/PoseStamped, world, from the measured joints); /arm/status
  (densepack_interfaces/ArmStatus, latched)
services:   /arm/unlock_protective_stop (std_srvs/Trigger: unlock, restart the program, wait),
  /arm/lease (densepack_interfaces/ControlLease: one commander at a time)
calls:      /dashboard_client/{close_safety_popup, unlock_protective_stop, stop, play}
"""

SPEC = NodeSpec(
    "arm",
    ArmNode,
    "The arm controller: Cartesian tool setpoints in, UR10e IK and servo-style playback, "
    "joint commands out on ur_robot_driver's interfaces; the arm's state and the protective "
    "stop unlock for the executor.",
    configs=ARM_PARAMETERS,
    topics=TOPICS,
    threads=1,  # every callback is short (dashboard calls are asynchronous)
)


def main(args: Any = None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
