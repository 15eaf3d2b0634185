"""The camera check at the start of a run: one block gripped in place along both of its axes.

A camera calibration half a degree off shifts every perceived pose by a centimetre (tilt
times the camera's 1.25 m height), more than a pick leaves beside a block once neighbours
are near: the first picks of a plan could hit a neighbour before any placement has shown the
detector (``nodes.detector.handeye``) that perception and arm disagree. So before the first
action of its first run the executor goes down around the most isolated block (the one whose
fingers, for both closing axes, clear every neighbour by ``camera_check_margin`` more than a
pick's usual margin), closes along the block's x, opens, lifts the fingertips just over the
block, turns a quarter turn, closes along its y and lets go. The 2F-85 centres a block along
its closing axis, so after the two grips the block stands on the TCP on both axes, squared
up with the tool, whatever the camera said: one look then shows the camera's error in the
table plane where the block stands (a ``squared`` placement). The block never leaves the
table. Every detection after that is corrected; a plan made from the uncorrected view then no
longer fits the world and is replanned. With an exact calibration the block ends where it was
and the plan goes on.

Pure logic, no ROS: which block, its entry in the plan, and the steps.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

from msgs_py import PickPlace, Pose2D, Workspace
from msgs_py.cell import GripperGeometry
from nodes.executor.config import ExecutorConfig
from nodes.executor.motion import ToolPose
from nodes.executor.primitives import rise_then_shape, settle_onto, tool_yaw
from nodes.executor.recovery import fingers_clear
from nodes.executor.steps import Grip, Move, Step, of_block

#: Closing along the block's x, then along its y: square to each other.
PROBE_GRASPS = (0, 1)
#: Fingertips this far over the block's top while the tool turns between the grips (m).
TURN_CLEARANCE = 0.008


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
    """The check's entry in front of the plan: the block stays where it stands (its steps
    come from ``probe_steps``, not from a pick-and-place)."""
    return (PickPlace(block, at, at, PROBE_GRASPS[0]),)


def probe_steps(block: int, at: Pose2D, geo: GripperGeometry, cfg: ExecutorConfig,
                opening: float) -> list[Step]:
    """Down around the block perceived at ``at`` with the fingers ``opening`` wide, grip
    along its x and let go, turn a quarter turn with the fingertips over its top, grip along
    its y and let go, and back up to travel height."""
    yaws = [tool_yaw(at.theta + g * math.pi / 2, cfg) for g in PROBE_GRASPS]
    over = [ToolPose(at.x, at.y, cfg.travel_height, yaw) for yaw in yaws]
    clear = geo.block_size + TURN_CLEARANCE
    tag = f"block {block}"
    of = of_block(block)
    r = cfg.blend_radius
    settle = cfg.gripper_settle_s
    return [
        *rise_then_shape(opening, cfg, tag, block),
        Move(over[0], cfg.travel_limits, f"{tag}: travel above", converge=False, **of),
        Grip(opening, settle, f"{tag}: fingers open", **of),
        *settle_onto(over[0], cfg.grasp_height, cfg, f"{tag}: descend", block),
        Grip(cfg.grip_command, settle, f"{tag}: grip along x", holds=block, **of),
        Grip(opening, settle, f"{tag}: let go", **of),
        Move(over[0].with_z(clear), cfg.vertical_limits, f"{tag}: clear the top",
             converge=False, **of),
        Move(over[1].with_z(clear), cfg.travel_limits, f"{tag}: turn", converge=False, **of),
        *settle_onto(over[1].with_z(clear), cfg.grasp_height, cfg, f"{tag}: descend again",
                     block),
        Grip(cfg.grip_command, settle, f"{tag}: grip along y", holds=block, squares=True, **of),
        Grip(opening, settle, f"{tag}: release", **of),
        Move(over[1], cfg.vertical_limits, f"{tag}: retreat", converge=False, blend=r, **of),
    ]
