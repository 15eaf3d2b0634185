"""ROS message <-> plain values for the sim node's edge (message classes only, no rclpy)."""

from __future__ import annotations

import math

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState

from msgs_py import MessageError
from msgs_py.checks import finite_float


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
