"""``BlockSet`` -> ``visualization_msgs/MarkerArray`` for viewers (``/blocks/detected/markers``,
``/sim/ground_truth/markers``): one CUBE marker (ns ``blocks``, action ADD) per seen block,
``id`` = tag id, yaw as a pure-z quaternion, z = s/2, scale = s; known-but-unseen blocks as
DELETE markers with their id. The cell itself reads the typed
``densepack_interfaces/BlockPoseArray`` beside it; markers are never decoded.
"""

from __future__ import annotations

import math

from visualization_msgs.msg import Marker, MarkerArray

from msgs_py.detection import BlockSet
from msgs_py.ros.stamps import ns_to_stamp

BLOCK_NS = "blocks"
_WOOD_RGBA = (0.85, 0.68, 0.45, 1.0)


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
