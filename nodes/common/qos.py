"""The QoS profiles densepack uses, named by what they are for."""

from __future__ import annotations

from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_sensor_data,
)

#: Commands, statuses, detections: reliable, a short queue, nothing replayed to late joiners.
RELIABLE = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)

#: "Latched" documents (goal layout, plan, last status): a late subscriber still gets the
#: last message, like a ROS 1 latched topic.
LATCHED = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)

#: Camera images and other high-rate sensor streams (best effort, depth 5).
SENSOR = qos_profile_sensor_data
