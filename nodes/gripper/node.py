"""``densepack-gripper``: the executor's gap commands to the Robotiq 2F-85 driver, and what the
fingers do back.

``/gripper/command`` (std_msgs/Float64, the pad gap in m) becomes a knuckle position command
for ``robotiq_85_left_knuckle_joint`` on the Robotiq driver's position controller (radians,
0 open to 0.7929 closed: ``nodes.robot.gripper_2f85``); ``/gripper/status`` (GripperStatus)
is made from the driver's knuckle joint state and the last command anyone sent on that
controller (``nodes.gripper.watch``), since the driver publishes no object detection. The same
node drives the sim's gripper, which speaks the driver's interface. One commander at a time:
a node holding ``/gripper/lease`` commands on its private topic and ``/gripper/command`` is
refused, its publishers named (``nodes.common.lease_ros``); a command sent straight to the
driver's topic cannot be refused here, and shows in the requested gap.
"""

from __future__ import annotations

import dataclasses
import math
import sys
import threading
from typing import Any

from densepack_interfaces.msg import GripperStatus
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from msgs_py import MessageError, drivers
from msgs_py import ros as msg_codecs
from nodes.common.joints import values_by_name
from nodes.common.lease import LeaseConfig
from nodes.common.lease_ros import LeaseServer
from nodes.common.params import declare_config
from nodes.common.qos import RELIABLE
from nodes.common.runner import NodeSpec, run_node
from nodes.common.standard_msgs import joint_state_values
from nodes.gripper.config import GRIPPER_PARAMETERS, GripperConfig
from nodes.gripper.watch import KnuckleWatch
from nodes.robot import gripper_2f85 as g85


class GripperNode(Node):
    def __init__(self, **kwargs) -> None:
        super().__init__("gripper", **kwargs)
        self.config: GripperConfig = declare_config(self, GripperConfig)
        lease_config = declare_config(self, LeaseConfig, "lease.")
        self.watch = KnuckleWatch(self.config.limits())
        self.lock = threading.Lock()
        self.pub_knuckle = self.create_publisher(Float64MultiArray, drivers.GRIPPER_COMMAND_TOPIC,
                                                 RELIABLE)
        self.pub_status = self.create_publisher(GripperStatus, "/gripper/status", RELIABLE)
        # /gripper/command, or the lease holder's private topic
        self.lease = LeaseServer(self, "gripper", "command", Float64, self.on_gap, lease_config)
        self.create_subscription(Float64MultiArray, drivers.GRIPPER_COMMAND_TOPIC,
                                 self.on_knuckle_command, RELIABLE)
        self.create_subscription(JointState, drivers.GRIPPER_JOINT_STATES, self.on_joint_state,
                                 RELIABLE)

    def _now(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def on_gap(self, msg: Float64) -> None:
        gap = float(msg.data)
        if not math.isfinite(gap):
            self.get_logger().warning(f"/gripper/command refused: {gap} is not finite")
            return
        self.pub_knuckle.publish(Float64MultiArray(data=[g85.gap_to_knuckle(gap)]))

    def on_knuckle_command(self, msg: Float64MultiArray) -> None:
        """Any knuckle command (ours or a stray one): what the fingers were sent to."""
        if len(msg.data) != 1 or not math.isfinite(msg.data[0]):
            return  # the driver refuses it too
        with self.lock:
            self.watch.on_command(float(msg.data[0]), self._now())

    def on_joint_state(self, msg: JointState) -> None:
        try:
            names, positions, stamp = joint_state_values(msg)
        except MessageError as err:
            self.get_logger().warning(f"{drivers.GRIPPER_JOINT_STATES} ignored: {err}",
                                      throttle_duration_sec=5.0)
            return
        values, missing = values_by_name(names, positions, (g85.KNUCKLE_JOINT,))
        if values is None:
            self.get_logger().warning(f"{drivers.GRIPPER_JOINT_STATES} lacks "
                                      f"{', '.join(missing)}", throttle_duration_sec=5.0)
            return
        with self.lock:
            status = self.watch.on_position(float(values[0]), stamp)
            stuck = self.watch.never_moved(stamp)
        if stuck:
            self.get_logger().error(f"{stuck} (reactivate: {drivers.GRIPPER_REACTIVATE})")
        lease = self.lease.status()
        status = dataclasses.replace(status, lease_holder=lease.holder,
                                     refused_commands=lease.refused_commands,
                                     refused_commanders=lease.refused_commanders)
        self.pub_status.publish(msg_codecs.gripper_status_to_msg(status))


TOPICS = """
subscribes: /gripper/command (std_msgs/Float64, pad gap m: the executor's; refused while a
  node holds /gripper/lease: then /gripper/lease/<token>/command only),
  /gripper/joint_states (the Robotiq driver's knuckle joint, by name),
  /gripper/robotiq_position_controller/commands (to see every command, anyone's)
publishes:  /gripper/robotiq_position_controller/commands (std_msgs/Float64MultiArray,
  knuckle rad), /gripper/status (densepack_interfaces/GripperStatus)
services:   /gripper/lease (densepack_interfaces/ControlLease: one commander at a time)
"""

SPEC = NodeSpec(
    "gripper",
    GripperNode,
    "The gripper node: gap commands to the Robotiq 2F-85 driver's knuckle position "
    "controller; the fingers' gap and a grasp signal (a stall short of the command) from the "
    "knuckle joint alone.",
    configs=GRIPPER_PARAMETERS,
    topics=TOPICS,
    threads=1,
)


def main(args: Any = None) -> int:
    return run_node(SPEC, args)


if __name__ == "__main__":
    sys.exit(main())
