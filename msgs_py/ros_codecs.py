"""Lossless codecs between msgs_py dataclasses and ``common_interfaces`` messages.

This is the only module of msgs_py that touches ROS message classes (not rclpy): node
adapters call it at their edge, nothing deeper sees a ROS message.

* ``BlockSet`` <-> ``visualization_msgs/MarkerArray``: one CUBE marker (ns ``blocks``,
  action ADD) per seen block, ``id`` = tag id, yaw as a pure-z quaternion, z = s/2,
  scale = s; known-but-unseen blocks as DELETE markers with their id. A tag's reprojection
  error, when known, rides in the marker's ``text`` as JSON.
* ``Plan``, ``Scene`` (goal layouts), ``ExecutorStatus``, ``PlannerStatus`` <-> ``std_msgs/String``
  holding JSON.
"""

from __future__ import annotations

import json
import math
from typing import Any, TypeVar

from builtin_interfaces.msg import Time
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from msgs_py.actions import Plan
from msgs_py.cell import BLOCK_SIZE
from msgs_py.checks import finite_float
from msgs_py.detection import BlockSet
from msgs_py.documents import dump_json, parse_text
from msgs_py.errors import MessageError
from msgs_py.poses import BlockPose
from msgs_py.scene import Scene
from msgs_py.status import ExecutorStatus, PlannerStatus

BLOCK_NS = "blocks"
_WOOD_RGBA = (0.85, 0.68, 0.45, 1.0)

T = TypeVar("T")


# --- time -------------------------------------------------------------------------------------
def stamp_to_ns(stamp: Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def ns_to_stamp(stamp_ns: int) -> Time:
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nanosec)


# --- blocks <-> MarkerArray -------------------------------------------------------------------
def yaw_to_quaternion_xyzw(theta: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(0.5 * theta), math.cos(0.5 * theta))


def quaternion_xyzw_to_yaw(x: float, y: float, z: float, w: float) -> float:
    """Yaw of the body x axis projected on the table (exact for pure-z quaternions)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


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
        if b.id in block_set.reprojection_px:
            m.text = json.dumps({"reprojection_px": block_set.reprojection_px[b.id]})
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


def block_set_from_markers(msg: MarkerArray, default_stamp_ns: int = 0) -> BlockSet:
    """Decode a block MarkerArray; markers of other namespaces are ignored.

    Raises:
        MessageError: mixed frames or stamps, a non-CUBE block marker, a non-finite pose,
            a duplicate id.
    """
    blocks: list[BlockPose] = []
    missing: list[int] = []
    reprojection: dict[int, float] = {}
    frame_id, stamp_ns, size = None, None, None
    for k, m in enumerate(msg.markers):
        if m.ns != BLOCK_NS:
            continue
        where = f"markers[{k}]"
        frame_id = _same(f"{where}.header.frame_id", frame_id, m.header.frame_id)
        stamp_ns = _same(f"{where}.header.stamp", stamp_ns, stamp_to_ns(m.header.stamp))
        if m.action == Marker.DELETE:
            missing.append(int(m.id))
            continue
        if m.action != Marker.ADD or m.type != Marker.CUBE:
            raise MessageError(f"{where}.type", m.type, "block markers are ADD CUBE markers")
        if m.id < 0:
            raise MessageError(f"{where}.id", m.id, "block ids are >= 0")
        p, q = m.pose.position, m.pose.orientation
        x = finite_float(f"{where}.pose.position.x", p.x)
        y = finite_float(f"{where}.pose.position.y", p.y)
        quat = [finite_float(f"{where}.pose.orientation", v) for v in (q.x, q.y, q.z, q.w)]
        size = finite_float(f"{where}.scale.x", m.scale.x)
        blocks.append(BlockPose(int(m.id), x, y, quaternion_xyzw_to_yaw(*quat)))
        if m.text:
            reprojection[int(m.id)] = _reprojection(f"{where}.text", m.text)
    return BlockSet(
        blocks=tuple(blocks),
        stamp_ns=default_stamp_ns if stamp_ns is None else stamp_ns,
        frame_id=frame_id or "world",
        block_size=size if size else BLOCK_SIZE,
        missing=tuple(missing),
        reprojection_px=reprojection,
    )


def _same(field: str, current: Any, new: Any) -> Any:
    if current is not None and current != new:
        raise MessageError(field, new, f"differs from the other markers ({current})")
    return new


def _reprojection(field: str, raw: str) -> float:
    data = parse_text(raw, field)
    if not isinstance(data, dict) or "reprojection_px" not in data:
        raise MessageError(field, raw, "expected {\"reprojection_px\": number}")
    return finite_float(field, data["reprojection_px"])


# --- JSON documents <-> String ---------------------------------------------------------------
def to_string_msg(obj: Any) -> String:
    """Any msgs_py record with ``to_dict`` as a JSON ``std_msgs/String``."""
    return String(data=dump_json(obj.to_dict()))


def _decode(msg: String, source: str) -> Any:
    return parse_text(msg.data, source)


def plan_from_string(msg: String) -> Plan:
    return Plan.from_dict(_decode(msg, "plan"))


def scene_from_string(msg: String) -> Scene:
    """A scene or goal layout (YAML or JSON text) from ``/goal_layout``."""
    return Scene.from_dict(_decode(msg, "goal_layout"))


def executor_status_from_string(msg: String) -> ExecutorStatus:
    return ExecutorStatus.from_dict(_decode(msg, "executor_status"))


def planner_status_from_string(msg: String) -> PlannerStatus:
    return PlannerStatus.from_dict(_decode(msg, "planner_status"))
