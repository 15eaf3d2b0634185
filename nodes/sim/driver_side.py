"""The sim node's driver side: what ur_robot_driver and the Robotiq driver publish, subscribe
and serve, under their names and types (``msgs_py.drivers``), on the sim node's behalf.

Callbacks queue their command for the sim loop (``queue``), the only thread that touches the
world; a refused command is logged as the driver logs it and changes nothing. The loop calls
``publish_state`` at the state rate and ``publish_robot_state`` after every step (on a change
only: those topics are latched).
"""

from __future__ import annotations

import concurrent.futures
import math
from collections.abc import Callable

from geometry_msgs.msg import PoseStamped
from rclpy.callback_groups import CallbackGroup
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory
from ur_dashboard_msgs.msg import RobotMode, SafetyMode

from msgs_py import drivers
from nodes.common.qos import LATCHED, RELIABLE
from nodes.common.standard_msgs import joint_state_msg, pose_stamped_msg, trajectory_values
from nodes.robot import gripper_2f85 as g85
from nodes.sim.pacing import Pacer
from nodes.sim.world import SimWorld

#: A dashboard call waits this long for the sim loop's answer (s).
DASHBOARD_TIMEOUT_S = 60.0


class DriverSide:
    def __init__(self, node: Node, world: Callable[[], SimWorld],
                 queue: Callable[[Callable[[], None]], None], pacer: Pacer,
                 group: CallbackGroup) -> None:
        self.node, self.world, self.queue, self.pacer = node, world, queue, pacer
        self._published: tuple | None = None  # (safety, robot mode, running) last sent
        pub = node.create_publisher
        self.pub_joints = pub(JointState, drivers.JOINT_STATES, RELIABLE)
        self.pub_tcp = pub(PoseStamped, drivers.TCP_POSE_TOPIC, RELIABLE)
        self.pub_speed = pub(Float64, drivers.SPEED_SCALING_TOPIC, RELIABLE)
        self.pub_safety = pub(SafetyMode, drivers.SAFETY_MODE_TOPIC, LATCHED)
        self.pub_robot_mode = pub(RobotMode, drivers.ROBOT_MODE_TOPIC, LATCHED)
        self.pub_running = pub(Bool, drivers.PROGRAM_RUNNING_TOPIC, LATCHED)
        self.pub_knuckle = pub(JointState, drivers.GRIPPER_JOINT_STATES, RELIABLE)
        sub = node.create_subscription
        sub(JointTrajectory, drivers.TRAJECTORY_TOPIC, self._on_trajectory, RELIABLE,
            callback_group=group)
        sub(Float64MultiArray, drivers.FORWARD_POSITION_TOPIC, self._on_positions, RELIABLE,
            callback_group=group)
        sub(Float64MultiArray, drivers.GRIPPER_COMMAND_TOPIC, self._on_knuckle, RELIABLE,
            callback_group=group)
        for call in drivers.DASHBOARD_TRIGGERS:
            node.create_service(Trigger, drivers.dashboard_service(call),
                                lambda req, resp, call=call: self._on_dashboard(call, resp),
                                callback_group=group)

    # --- commands -------------------------------------------------------------------------------
    def _on_trajectory(self, msg: JointTrajectory) -> None:
        """scaled_joint_trajectory_controller: checked as the controller checks it."""
        names, start_s, points = trajectory_values(msg)
        self.queue(lambda: self._commanded(drivers.TRAJECTORY_TOPIC,
                                           self.world().command_trajectory(names, start_s,
                                                                           points)))

    def _on_positions(self, msg: Float64MultiArray) -> None:
        values = [float(v) for v in msg.data]
        self.queue(lambda: self._commanded(drivers.FORWARD_POSITION_TOPIC,
                                           self.world().command_positions(values)))

    def _commanded(self, topic: str, error: str) -> None:
        """A motion command taken (the sim paces on it) or refused (logged)."""
        if error:
            self.node.get_logger().error(f"{topic}: {error}", throttle_duration_sec=1.0)
            return
        commanded = self.world().commanded_until()
        if commanded is not None:
            until, moving, start = commanded
            self.pacer.on_command(until, moving, start=start)

    def _on_knuckle(self, msg: Float64MultiArray) -> None:
        """The Robotiq position controller: one value, the knuckle joint (rad)."""
        values = [float(v) for v in msg.data]
        if len(values) != 1 or not math.isfinite(values[0]):
            self.node.get_logger().error(
                f"{drivers.GRIPPER_COMMAND_TOPIC}: expected one finite value for "
                f"{g85.KNUCKLE_JOINT}, got {values}")
            return
        self.queue(lambda: self.world().fingers.set_knuckle(values[0]))

    def _on_dashboard(self, call: str, response):
        """A dashboard call, answered in the dashboard server's words."""
        future: concurrent.futures.Future = concurrent.futures.Future()
        self.queue(lambda: future.set_result(self.world().dashboard(call)))
        try:
            answer = future.result(timeout=DASHBOARD_TIMEOUT_S)
            response.success, response.message = answer.success, answer.message
        except concurrent.futures.TimeoutError:
            response.success, response.message = False, "the sim did not answer"
        if response.success:
            self.node.get_logger().info(f"dashboard {call}: {response.message}")
        return response

    # --- state (the sim loop) -------------------------------------------------------------------
    def publish_robot_state(self) -> None:
        """Safety mode, robot mode and program running, latched, on a change (as
        ur_robot_driver's io_and_status_controller publishes them)."""
        state = self.world().robot_state
        now = (state.safety_mode, state.robot_mode, state.program_running)
        if now == self._published:
            return
        if self._published is not None and state.stop_reason and now[0] != self._published[0]:
            self.node.get_logger().warning(f"protective stop: {state.stop_reason}")
        self._published = now
        self.pub_safety.publish(SafetyMode(mode=state.safety_mode))
        self.pub_robot_mode.publish(RobotMode(mode=state.robot_mode))
        self.pub_running.publish(Bool(data=state.program_running))

    def publish_status(self, stamp) -> None:
        """The TCP pose in ``base`` and the speed scaling (percent)."""
        world = self.world()
        position, quat = world.tcp_pose()
        self.pub_tcp.publish(pose_stamped_msg(stamp, position, quat, drivers.BASE_FRAME))
        self.pub_speed.publish(Float64(data=100.0 * world.robot_state.speed_scaling))

    def publish_state(self, stamp) -> None:
        """Joint states: the arm's, and the knuckle's."""
        world = self.world()
        names, q, v = world.joint_state()
        self.pub_joints.publish(joint_state_msg(stamp, names, q, v))
        knuckle, rate = world.fingers.knuckle()
        self.pub_knuckle.publish(joint_state_msg(stamp, [g85.KNUCKLE_JOINT], [knuckle], [rate]))
