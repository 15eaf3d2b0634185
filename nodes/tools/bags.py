"""What densepack-record, densepack-play and densepack-view share: the message types of the
graph and of rosbag2 bags, and the QoS a topic is recorded and replayed with.

The bag format is ``rosbags``' (a rosbag2 folder: ``metadata.yaml`` and MCAP storage); its
typestore knows the ROS 2 Jazzy types and learns the cell's own ``densepack_interfaces``
types from the ``.msg`` files their package installs (found through the ament index), so a
bag carries the same definitions (and type hashes) as the generated Python classes. The same
definitions give the Foxglove app its ``ros2msg`` schemas.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from functools import cache
from pathlib import Path
from typing import Any

#: Interface packages outside the typestore's own ROS 2 Jazzy set, learnt from their .msg files.
OWN_INTERFACE_PACKAGES = ("densepack_interfaces",)
#: Queue of a recording or viewing subscription: bursts (a plan, markers) must not be dropped.
RECORD_DEPTH = 100
#: The line between the parts of a concatenated message definition (rosbag2's).
DEFINITION_SEPARATOR = "=" * 80


def interface_share_dir(package: str) -> Path:
    """``share/<package>`` of an installed interface package, from the ament index: the
    prefixes of ``AMENT_PREFIX_PATH`` (a sourced ROS install or colcon workspace), then this
    Python's own prefix, where pip installs it.

    Raises:
        LookupError: no ament index holds the package.
    """
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in [*prefixes, sys.prefix]:
        marker = Path(prefix) / "share" / "ament_index" / "resource_index" / "packages" / package
        if marker.is_file():
            return Path(prefix) / "share" / package
    raise LookupError(f"interface package {package} is not installed (no ament index lists it)")


@cache
def typestore() -> Any:
    """The rosbags typestore of ROS 2 Jazzy plus every ``OWN_INTERFACE_PACKAGES`` message."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    types: dict[str, Any] = {}
    for package in OWN_INTERFACE_PACKAGES:
        for path in sorted((interface_share_dir(package) / "msg").glob("*.msg")):
            types.update(get_types_from_msg(path.read_text(), f"{package}/msg/{path.stem}"))
    store.register(types)
    return store


def message_definition(type_name: str) -> str:
    """The ``ros2msg`` text of ``pkg/msg/Type`` with every type it uses appended (the
    ``=====`` / ``MSG: pkg/Type`` concatenation of rosbag2 and the Foxglove app).

    Each part is the installed ``.msg`` file as written, as rosbag2 stores it, where one is
    found: the apps name a field's values by the constants written just before it (the
    executor's ``state`` shows ``STATE_RUNNING``), and the typestore's own rendering lists
    every constant first. A type without an installed file keeps that rendering.

    Raises:
        KeyError: a type the typestore does not know.
    """
    from nodes.common.messages import canonical_type_name

    name = canonical_type_name(type_name)
    text, _ = typestore().generate_msgdef(name, ros_version=2)
    head, *used = text.split(f"{DEFINITION_SEPARATOR}\n")
    parts = [msg_source(name) or head]
    for part in used:
        title, _, body = part.partition("\n")
        source = msg_source(canonical_type_name(title.removeprefix("MSG: ")))
        parts.append(f"{title}\n{source or body}")
    return f"{DEFINITION_SEPARATOR}\n".join(parts)


def msg_source(type_name: str) -> str | None:
    """The installed ``share/<pkg>/msg/<Type>.msg`` of ``pkg/msg/Type`` (ending in one
    newline), or None when no ament index lists the package or the file is not there."""
    package, _, name = type_name.split("/")
    try:
        path = interface_share_dir(package) / "msg" / f"{name}.msg"
    except LookupError:
        return None
    return path.read_text().rstrip() + "\n" if path.is_file() else None


def is_hidden(topic: str) -> bool:
    """A hidden topic (a name part starting with ``_``: action internals), as ros2 sees it."""
    return any(part.startswith("_") for part in topic.split("/"))


def publisher_qos(infos: Iterable[Any]) -> list[Any]:
    """The QoS profiles the publishers of a topic offer (``get_publishers_info_by_topic``)."""
    return [info.qos_profile for info in infos]


def subscription_qos(offered: list[Any], depth: int = RECORD_DEPTH) -> Any:
    """The QoS that hears every offering publisher and gets a latched topic's last message:
    best effort if any publisher is, transient local if all latch."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    best_effort = any(q.reliability == ReliabilityPolicy.BEST_EFFORT for q in offered)
    latched = bool(offered) and all(
        q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=depth,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def replay_qos(offered: list[Any]) -> Any:
    """The QoS a player offers for a topic recorded with ``offered`` (rosbags ``Qos``):
    latched if the recorded publishers all latched (depth 1: a late subscriber gets the last
    message, as from the original), reliable unless they were all best effort."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from rosbags.interfaces import QosDurability, QosReliability

    latched = bool(offered) and all(
        q.durability == QosDurability.TRANSIENT_LOCAL for q in offered)
    best_effort = bool(offered) and all(
        q.reliability == QosReliability.BEST_EFFORT for q in offered)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST, depth=1 if latched else 10,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)


def to_bag_qos(profile: Any) -> Any:
    """An rclpy ``QoSProfile`` as rosbags' ``Qos`` (the bag's ``offered_qos_profiles``)."""
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    def span(duration: Any) -> Any:
        ns = int(duration.nanoseconds)
        return QosTime(ns // 10**9, ns % 10**9)

    return Qos(
        history=QosHistory(int(profile.history)),
        depth=int(profile.depth),
        reliability=QosReliability(int(profile.reliability)),
        durability=QosDurability(int(profile.durability)),
        deadline=span(profile.deadline),
        lifespan=span(profile.lifespan),
        liveliness=QosLiveliness(int(profile.liveliness)),
        liveliness_lease_duration=span(profile.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions),
    )
