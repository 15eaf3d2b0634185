"""The kinds of warning the detector logs: each kind is rate-limited on its own."""

from __future__ import annotations

import enum


class WarningKind(enum.Enum):
    # a frame's tags (``pipeline``)
    UNKNOWN_ID = "tag id outside allowed_ids"
    DUPLICATE_ID = "tag id seen twice in a frame"
    REPROJECTION = "tag fit reprojects badly"
    # the camera streams (``node``)
    BAD_FRAME = "malformed image or camera_info"
    LENS_MODEL = "unsupported lens model"
    STALE_FRAME = "frame older than the last one processed"
    UNPAIRED = "images without camera_info of their stamp"
    NO_FRAME = "images arrive but no frame is complete"
    LATE_FRAME = "frame complete long after its stamp"
    CLOCK = "clock jumped back"
    # the arm's placements
    PLACEMENT = "malformed placement"
    CHECK_RECORD = "camera check record not written"
    # the robot's joint states (what it covers in a frame)
    JOINT_STATE = "malformed joint state"
