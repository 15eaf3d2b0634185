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

#: Camera frames (1280x960 rgb8, 3.7 MB): reliable with a history of 2, on both ends. Best
#: effort loses a whole frame whenever one of its UDP fragments is dropped, which under load
#: was one frame in three; only the newest frames matter, so the history stays short.
CAMERA = QoSProfile(
    history=HistoryPolicy.KEEP_LAST,
    depth=2,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)


def camera_qos(reliability: str) -> QoSProfile:
    """``CAMERA`` or, for ``best_effort`` (a camera driver's sensor-data QoS), the same
    history with best-effort delivery: for publishers and subscribers alike. A reliable
    subscriber never matches a best-effort publisher; a best-effort one matches both."""
    if reliability == "best_effort":
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=2,
                          reliability=ReliabilityPolicy.BEST_EFFORT,
                          durability=DurabilityPolicy.VOLATILE)
    if reliability != "reliable":
        raise ValueError(f"camera QoS reliability '{reliability}' is not reliable or "
                         "best_effort")
    return CAMERA
