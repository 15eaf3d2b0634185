"""A kinematic stand-in for ur_robot_driver and the Robotiq driver, written from their
documentation (no PyBullet, none of the sim's code): what the conformance tests run the arm
and gripper nodes against, beside the sim, to show the nodes need nothing only the sim has.

What it does, as the drivers document it:

* ur_robot_driver: ``/joint_states`` (the six arm joints, in the broadcaster's order, not the
  kinematic one), ``/tcp_pose_broadcaster/pose`` (frame ``base``), the speed scaling in percent,
  the latched safety mode, robot mode and program state; a ``JointTrajectory`` on the scaled
  trajectory controller's topic with exactly the controller's joints, in any order, replaces
  the last one and is played from where the arm is (here: linear between points, an ideal
  arm); after a protective stop the program is paused until the dashboard's
  ``unlock_protective_stop`` and then ``play``.
* Robotiq driver (namespace /gripper): ``/gripper/joint_states`` with the knuckle joint only,
  a forward position controller on it; the fingers move at the 2F-85's speed and stop on an
  object ``object_width`` wide (none: they close fully).
* It also publishes ``/clock`` (the nodes run on it, as in the sim cell) and has a test hook,
  ``/standin/protective_stop``, to stop the arm the way the robot's safety system would.
"""

from __future__ import annotations

import math

import numpy as np
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory
from ur_dashboard_msgs.msg import RobotMode, SafetyMode

from msgs_py import drivers
from msgs_py.cell import GRIPPER_STROKE
from msgs_py.ros import ns_to_stamp
from nodes.common.qos import LATCHED, RELIABLE
from nodes.common.standard_msgs import joint_state_msg, pose_stamped_msg, stamp_seconds
from nodes.common.transforms import matrix_to_quaternion
from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e
from nodes.robot.kinematics import tcp_pose

DT = 0.01  # s, the stand-in's step and clock period
BROADCAST_ORDER = ("shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                   "wrist_3_joint", "shoulder_pan_joint")
#: The 2F-85 closes its 85 mm stroke at up to 150 mm/s: in knuckle radians per second.
KNUCKLE_SPEED = 0.150 / GRIPPER_STROKE * g85.KNUCKLE_CLOSED


class DriverStandIn(Node):
    def __init__(self, q_start, object_width: float | None = None, **kwargs) -> None:
        super().__init__("driver_standin", **kwargs)
        self.t = 0.0
        self.q = np.array(q_start, dtype=float)
        self.trajectory: list[tuple[float, np.ndarray]] | None = None  # (abs time, q)
        self.knuckle, self.knuckle_cmd = 0.0, 0.0
        self.object_width = object_width
        self.safety, self.program = SafetyMode.NORMAL, True
        self.refused: list[str] = []
        self.joint_states = True  #: tests turn the arm's joint states off ...
        self.dropped_joint: str | None = None  #: ... or drop one joint from them
        self.speed_percent = 100.0
        self.pub_clock = self.create_publisher(Clock, "/clock", RELIABLE)
        self.pub_joints = self.create_publisher(JointState, drivers.JOINT_STATES, RELIABLE)
        self.pub_knuckle = self.create_publisher(JointState, drivers.GRIPPER_JOINT_STATES,
                                                 RELIABLE)
        self.pub_tcp = self.create_publisher(PoseStamped, drivers.TCP_POSE_TOPIC, RELIABLE)
        self.pub_speed = self.create_publisher(Float64, drivers.SPEED_SCALING_TOPIC, RELIABLE)
        self.pub_safety = self.create_publisher(SafetyMode, drivers.SAFETY_MODE_TOPIC, LATCHED)
        self.pub_mode = self.create_publisher(RobotMode, drivers.ROBOT_MODE_TOPIC, LATCHED)
        self.pub_program = self.create_publisher(Bool, drivers.PROGRAM_RUNNING_TOPIC, LATCHED)
        self.create_subscription(JointTrajectory, drivers.TRAJECTORY_TOPIC, self.on_trajectory,
                                 RELIABLE)
        self.create_subscription(Float64MultiArray, drivers.GRIPPER_COMMAND_TOPIC,
                                 self.on_knuckle, RELIABLE)
        for call, handler in (("unlock_protective_stop", self.on_unlock),
                              ("close_safety_popup", self.on_ok), ("stop", self.on_stop),
                              ("play", self.on_play)):
            self.create_service(Trigger, drivers.dashboard_service(call), handler)
        self.create_service(Trigger, "/standin/protective_stop", self.on_protective_stop)
        self._publish_status()
        self.create_timer(DT, self.step)  # on the wall clock: this node is the time source

    # --- ur_robot_driver ------------------------------------------------------------------------
    def on_trajectory(self, msg: JointTrajectory) -> None:
        names = list(msg.joint_names)
        if sorted(names) != sorted(ur10e.ARM_JOINTS) or not msg.points:
            self.refused.append(f"joints {names}")
            self.get_logger().error("Joints on incoming trajectory don't match the "
                                    "controller joints.")
            return
        if not self.program:
            self.refused.append("program not running")
            return
        order = [names.index(j) for j in ur10e.ARM_JOINTS]
        start = stamp_seconds(msg.header.stamp) or self.t
        points = [(self.t, self.q.copy())]  # played from where the arm is
        for p in msg.points:
            at = start + p.time_from_start.sec + p.time_from_start.nanosec * 1e-9
            if at > self.t:
                points.append((at, np.asarray(p.positions, dtype=float)[order]))
        self.trajectory = points

    def _sample(self, t: float) -> np.ndarray:
        points = self.trajectory
        assert points is not None
        if t >= points[-1][0]:
            return points[-1][1]
        k = next(i for i in range(1, len(points)) if t <= points[i][0])
        (t0, q0), (t1, q1) = points[k - 1], points[k]
        return q0 + (q1 - q0) * ((t - t0) / (t1 - t0))

    # --- the dashboard and the safety system ----------------------------------------------------
    def on_protective_stop(self, request, response):
        self.safety, self.program, self.trajectory = SafetyMode.PROTECTIVE_STOP, False, None
        self._publish_status()
        response.success, response.message = True, "stopped"
        return response

    def on_unlock(self, request, response):
        ok = self.safety == SafetyMode.PROTECTIVE_STOP
        if ok:
            self.safety = SafetyMode.NORMAL
            self._publish_status()
        response.success = ok
        response.message = "Protective stop releasing" if ok else "not in a protective stop"
        return response

    def on_ok(self, request, response):
        response.success, response.message = True, "closing safety popup"
        return response

    def on_stop(self, request, response):
        self.program = False
        self._publish_status()
        response.success, response.message = True, "Stopped"
        return response

    def on_play(self, request, response):
        ok = self.safety == SafetyMode.NORMAL
        if ok:
            self.program = True
            self._publish_status()
        response.success = ok
        response.message = "Starting program" if ok else "Failed to execute: play"
        return response

    def _publish_status(self) -> None:
        self.pub_safety.publish(SafetyMode(mode=self.safety))
        self.pub_mode.publish(RobotMode(mode=RobotMode.RUNNING))
        self.pub_program.publish(Bool(data=self.program))

    # --- the Robotiq driver ---------------------------------------------------------------------
    def on_knuckle(self, msg: Float64MultiArray) -> None:
        if len(msg.data) == 1 and math.isfinite(msg.data[0]):
            self.knuckle_cmd = min(max(float(msg.data[0]), 0.0), g85.KNUCKLE_CLOSED)

    def _knuckle_limit(self) -> float:
        """Where closing fingers stop: on the object, or fully closed."""
        if self.object_width is None:
            return g85.KNUCKLE_CLOSED
        return g85.gap_to_knuckle(self.object_width)

    # --- time -----------------------------------------------------------------------------------
    def step(self) -> None:
        self.t += DT
        if self.trajectory is not None and self.program:
            self.q = self._sample(self.t)
        step = math.copysign(min(abs(self.knuckle_cmd - self.knuckle), KNUCKLE_SPEED * DT),
                             self.knuckle_cmd - self.knuckle)
        self.knuckle = min(self.knuckle + step, max(self._knuckle_limit(), self.knuckle)) \
            if step > 0 else self.knuckle + step
        stamp = ns_to_stamp(round(self.t * 1e9))
        self.pub_clock.publish(Clock(clock=stamp))
        names = [n for n in BROADCAST_ORDER if n != self.dropped_joint]
        order = [ur10e.ARM_JOINTS.index(n) for n in names]
        if self.joint_states:
            self.pub_joints.publish(joint_state_msg(stamp, names, self.q[order],
                                                    np.zeros(len(names))))
        self.pub_knuckle.publish(joint_state_msg(stamp, [g85.KNUCKLE_JOINT], [self.knuckle],
                                                 [0.0]))
        tcp = tcp_pose(self.q)
        self.pub_tcp.publish(pose_stamped_msg(stamp, tcp[:3, 3],
                                              matrix_to_quaternion(tcp[:3, :3]), "base"))
        self.pub_speed.publish(Float64(data=self.speed_percent))
