"""Codecs between msgs_py records and ``common_interfaces`` messages.

This module and ``msgs_py.interface_codecs`` (the cell's own ``densepack_interfaces`` types)
are the only ones of msgs_py that touch ROS message classes (not rclpy): node adapters call
them at their edge, nothing deeper sees a ROS message.

* ``builtin_interfaces/Time`` <-> integer nanoseconds (every stamp of the cell).
* ``BlockSet`` -> ``visualization_msgs/MarkerArray`` for viewers (``/blocks/detected/markers``,
  ``/sim/ground_truth/markers``): one CUBE marker (ns ``blocks``, action ADD) per seen
  block, ``id`` = tag id, yaw as a pure-z quaternion, z = s/2, scale = s; known-but-unseen
  blocks as DELETE markers with their id. The cell itself reads the typed
  ``densepack_interfaces/BlockPoseArray`` beside it; markers are never decoded.
"""

from __future__ import annotations

import math
from typing import Any

from builtin_interfaces.msg import Time
from visualization_msgs.msg import Marker, MarkerArray

from msgs_py.detection import BlockSet
from msgs_py.errors import MessageError

BLOCK_NS = "blocks"
_WOOD_RGBA = (0.85, 0.68, 0.45, 1.0)
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1


# --- time -------------------------------------------------------------------------------------
def stamp_to_ns(stamp: Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(stamp_ns: Any, where: str = "stamp") -> Time:
    """Nanoseconds -> ``Time``; MessageError (naming ``where``) when Time cannot hold it."""
    if isinstance(stamp_ns, bool) or not isinstance(stamp_ns, int):
        raise MessageError(where, stamp_ns, "expected an integer (ns)")
    sec, nanosec = divmod(stamp_ns, 1_000_000_000)
    if not -(2**31) <= sec <= 2**31 - 1:
        raise MessageError(where, stamp_ns, "outside the range of builtin_interfaces/Time")
    return Time(sec=sec, nanosec=nanosec)


# --- blocks -> MarkerArray (viewers) ------------------------------------------------------------
def yaw_to_quaternion_xyzw(theta: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(0.5 * theta), math.cos(0.5 * theta))


def block_set_to_markers(block_set: BlockSet) -> MarkerArray:
    stamp = ns_to_stamp(block_set.stamp_ns)
    s = block_set.block_size
    markers = []
    for b in block_set.blocks:
        m = Marker()
        m.header.stamp = stamp
        m.header.frame_id = block_set.frame_id
        m.ns = BLOCK_NS
        m.id = int(b.id)
        m.type = Marker.CUBE
        m.action = Marker.ADD
        m.pose.position.x, m.pose.position.y, m.pose.position.z = b.x, b.y, 0.5 * s
        qx, qy, qz, qw = yaw_to_quaternion_xyzw(b.theta)
        m.pose.orientation.x, m.pose.orientation.y = qx, qy
        m.pose.orientation.z, m.pose.orientation.w = qz, qw
        m.scale.x = m.scale.y = m.scale.z = s
        m.color.r, m.color.g, m.color.b, m.color.a = _WOOD_RGBA
        markers.append(m)
    for block_id in block_set.missing:
        m = Marker()
        m.header.stamp = stamp
        m.header.frame_id = block_set.frame_id
        m.ns = BLOCK_NS
        m.id = int(block_id)
        m.action = Marker.DELETE
        markers.append(m)
    return MarkerArray(markers=markers)
