"""The camera check at the start of a run: one block re-gripped in place, twice.

A camera calibration half a degree off shifts every perceived pose by a centimetre (tilt
times the camera's 1.25 m height), more than a pick leaves beside a block once neighbours
are near: the first picks of a plan could hit a neighbour before any placement has shown the
detector (``nodes.detector.handeye``) that perception and arm disagree. So before the first
action of its first run the executor picks the most isolated block (the one whose fingers,
for both closing axes, clear every neighbour by ``camera_check_margin`` more than a pick's
usual margin) and sets it down where it stood, once closing along each of the block's axes,
looking after each. The 2F-85 centres a block along its closing axis, so after the second
grip the block stands exactly on the TCP: two placements whose closing axes are square to
each other, which is what the detector needs to solve the camera's error in the table plane.
Every detection after that is corrected; a plan made from the uncorrected view then no longer
fits the world and is replanned. With an exact calibration the block ends where it was and the
plan goes on.

Pure logic, no ROS: which block, and the two actions.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from msgs_py import PickPlace, Pose2D, Workspace
from msgs_py.cell import GripperGeometry
from nodes.executor.recovery import fingers_clear

#: Closing along the block's x, then along its y: square to each other.
PROBE_GRASPS = (0, 1)


def probe_block(perceived: Mapping[int, Pose2D], geo: GripperGeometry, table: Workspace,
                clearance: float, margin: float) -> int | None:
    """The block to re-grip: fingers open ``clearance`` beside it clear every neighbour by
    ``margin`` for both closing axes; of those, the one nearest the table's centre (its
    placements then weigh the rotation least). None when no block has room."""
    wide = dataclasses.replace(geo, approach_clearance=clearance)
    cx, cy = table.center
    roomy = [b for b in perceived
             if all(fingers_clear(perceived, b, wide, g, table, margin) for g in PROBE_GRASPS)]
    if not roomy:
        return None
    return min(roomy, key=lambda b: (math.hypot(perceived[b].x - cx, perceived[b].y - cy), b))


def probe_actions(block: int, at: Pose2D) -> tuple[PickPlace, ...]:
    """Pick the block and set it down where it stands, once with each closing axis."""
    return tuple(PickPlace(block, at, at, grasp) for grasp in PROBE_GRASPS)
