"""Standard ROS messages <-> plain values, for the nodes that talk to the drivers (sim, arm,
gripper): poses, joint states, joint trajectories. Message classes only, no rclpy."""

from __future__ import annotations

import math

from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from msgs_py import MessageError
from msgs_py.checks import finite_float
from nodes.common.transforms import quaternion_to_matrix, yaw_of_matrix


def pose_from_msg(msg: PoseStamped) -> tuple[list[float], list[float], str]:
    """(position, quaternion xyzw, frame_id) of a setpoint, or MessageError naming the field."""
    p, q = msg.pose.position, msg.pose.orientation
    position = [finite_float(f"pose.position.{k}", getattr(p, k)) for k in "xyz"]
    quat = [finite_float(f"pose.orientation.{k}", getattr(q, k)) for k in "xyzw"]
    norm = math.sqrt(sum(v * v for v in quat))
    if abs(norm - 1.0) > 0.1:
        raise MessageError("pose.orientation", quat, f"quaternion norm {norm:.3f} is not ~1")
    return position, quat, msg.header.frame_id


def pose_stamped_msg(stamp: Time, position, quat_xyzw, frame_id: str = "world") -> PoseStamped:
    msg = PoseStamped()
    msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = (float(v) for v in position)
    o = msg.pose.orientation
    o.x, o.y, o.z, o.w = (float(v) for v in quat_xyzw)
    return msg


def joint_state_msg(stamp: Time, names, positions, velocities) -> JointState:
    msg = JointState()
    msg.header.stamp = stamp
    msg.name = list(names)
    msg.position = [float(v) for v in positions]
    msg.velocity = [float(v) for v in velocities]
    return msg


def joint_state_values(msg: JointState) -> tuple[list[str], list[float], float]:
    """(names, positions, stamp s) of a joint state; MessageError when the lists disagree."""
    names, positions = list(msg.name), list(msg.position)
    if len(positions) != len(names):
        raise MessageError("position", len(positions),
                           f"{len(names)} names but {len(positions)} positions")
    return names, [float(v) for v in positions], stamp_seconds(msg.header.stamp)


def stamp_seconds(stamp: Time) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def trajectory_msg(start: Time, names, times, positions, velocities) -> JointTrajectory:
    """A JointTrajectory: one point per time (s from ``start``), positions and velocities in
    the order of ``names``."""
    msg = JointTrajectory()
    msg.header.stamp = start
    msg.joint_names = list(names)
    for t, q, v in zip(times, positions, velocities, strict=True):
        point = JointTrajectoryPoint()
        sec, nanosec = divmod(round(t * 1e9), 1_000_000_000)
        point.time_from_start = Duration(sec=sec, nanosec=nanosec)
        point.positions = [float(x) for x in q]
        point.velocities = [float(x) for x in v]
        msg.points.append(point)
    return msg


def trajectory_values(msg: JointTrajectory) -> tuple[list[str], float, list[tuple]]:
    """(joint names, start s (0: now), points as (time_from_start s, positions, velocities,
    accelerations, effort)) of a JointTrajectory, unchecked: the receiving controller checks
    it as ros2_controllers does."""
    points = [(p.time_from_start.sec + p.time_from_start.nanosec * 1e-9, list(p.positions),
               list(p.velocities), list(p.accelerations), list(p.effort)) for p in msg.points]
    return list(msg.joint_names), stamp_seconds(msg.header.stamp), points


def tool_pose_values(msg: PoseStamped) -> tuple[float, float, float, float]:
    """(x, y, z, yaw) of a measured gripper-down TCP (yaw: the closing axis in the table
    plane); MessageError names a non-finite field."""
    p, q = msg.pose.position, msg.pose.orientation
    for name, part in (("position", p), ("orientation", q)):
        for axis in ("x", "y", "z", "w") if name == "orientation" else ("x", "y", "z"):
            finite_float(f"pose.{name}.{axis}", getattr(part, axis))
    return p.x, p.y, p.z, yaw_of_matrix(quaternion_to_matrix((q.x, q.y, q.z, q.w)))
