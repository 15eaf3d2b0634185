"""Recovery geometry and scripts: where a block can be set down or picked up, and the moves.

A block in the fingers that should not be there (found at start-up, or held when the arm
must stop) is set down at the free spot nearest where it is wanted: block and both fingers
(closing axis at the tool's yaw) clear of every perceived block by a margin, the block in the
workspace and within the arm's working reach (``nodes.robot.reach``: a spot past it would
be one no plan may use), the fingers on the table. A block found outside the workspace or
past that reach (dropped, knocked) is brought back the same way, with a grasp whose fingers
are clear where it lies.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import shapely

from msgs_py import PickPlace, Pose2D, Workspace
from msgs_py.cell import BLOCK_SIZE, GRIPPER_STROKE, TABLE_MARGIN, GripperGeometry
from msgs_py.footprint import (
    block_corners,
    grasp_finger_corners,
    overlapping_blocks,
    to_polygons,
)
from nodes.executor.config import ExecutorConfig
from nodes.executor.motion import ToolPose
from nodes.executor.primitives import GRASP_SYMMETRY, pick_place_steps, release_opening
from nodes.executor.steps import Grip, Move, Rise, Step, of_block
from nodes.robot.reach import ur10e_reach

#: Finger gap (m) that means "holding a block": the pads stopped on a cube of the contract's
#: BLOCK_SIZE (open for a grasp is the block + 2 x clearance, closed on nothing is 0, a push
#: 20 mm). Other block sizes scale it.
HOLDING_GAP = (0.040, 0.058)
#: Room (m) fingers opened wider than the plan's, or standing where the plan did not check
#: them (a recovery's grasp), keep from every other perceived block.
FINGER_MARGIN = 0.004
#: Room (m) a finger going down keeps from a neighbour before the pick opens less than the
#: plan's opening: a few times the perception's error on a block's face.
NEIGHBOUR_MARGIN = 0.001


def holds_block(finger_gap: float | None, block_size: float = BLOCK_SIZE) -> bool:
    if finger_gap is None:
        return False
    lo, hi = (g * block_size / BLOCK_SIZE for g in HOLDING_GAP)
    return lo <= finger_gap <= hi


def free_spot(
    perceived: Mapping[int, Pose2D],
    workspace: Workspace,
    geo: GripperGeometry,
    tool_yaw: float,
    near: tuple[float, float],
    table_margin: float = TABLE_MARGIN,
    margin: float = 0.008,
    step: float = 0.01,
) -> Pose2D | None:
    """The candidate pose nearest ``near`` where block and fingers are clear and the arm
    reaches it on its working branch, or None."""
    xs = np.arange(workspace.x_min, workspace.x_max + 1e-9, step)
    ys = np.arange(workspace.y_min, workspace.y_max + 1e-9, step)
    gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
    order = np.argsort(np.hypot(gx - near[0], gy - near[1]), kind="stable")
    gx, gy = gx[order], gy[order]
    yaw = np.full_like(gx, tool_yaw)
    blocks = block_corners(gx, gy, yaw, geo.block_size)
    fingers = grasp_finger_corners(geo, gx, gy, yaw, np.zeros_like(gx))
    inside = (_inside(blocks, workspace, 0.0) & _inside(fingers, workspace, table_margin).all(-1)
              & ur10e_reach().contains(np.column_stack([gx, gy])))
    if not perceived:
        hits = np.zeros(len(gx), dtype=bool)
    else:
        p = np.array([[q.x, q.y, q.theta] for q in perceived.values()])
        obstacles = shapely.buffer(to_polygons(block_corners(p[:, 0], p[:, 1], p[:, 2],
                                                             geo.block_size)), margin)
        tree = shapely.STRtree(obstacles)
        shapes = np.concatenate([to_polygons(blocks)[:, None], to_polygons(fingers)], axis=1)
        hit_rows, _ = tree.query(shapes.ravel(), predicate="intersects")
        hits = np.zeros(shapes.size, dtype=bool)
        hits[hit_rows] = True
        hits = hits.reshape(shapes.shape).any(axis=1)
    ok = np.flatnonzero(inside & ~hits)
    if ok.size == 0:
        return None
    k = ok[0]
    return Pose2D(float(gx[k]), float(gy[k]), float(tool_yaw))


def _inside(corners: np.ndarray, ws: Workspace, grow: float) -> np.ndarray:
    x, y = corners[..., 0], corners[..., 1]
    ok = ((x >= ws.x_min - grow) & (x <= ws.x_max + grow)
          & (y >= ws.y_min - grow) & (y <= ws.y_max + grow))
    return ok.all(axis=-1)


def outside(perceived: Mapping[int, Pose2D], workspace: Workspace, block_size: float
            ) -> list[int]:
    """Ids of the perceived blocks whose footprint leaves the workspace, or whose centre
    stands past the arm's working reach (no plan may pick it there: a large workspace runs
    past that reach in its far corners)."""
    reach = ur10e_reach()
    return sorted(b for b, pose in perceived.items()
                  if not workspace.contains_square(pose, block_size)
                  or not reach.contains((pose.x, pose.y)))


def overlapping_ids(perceived: Mapping[int, Pose2D], block_size: float
                    ) -> list[tuple[int, int]]:
    """Pairs of perceived blocks whose footprints overlap (a block leaning on another, seen
    from above), as (smaller id, larger id)."""
    ids = sorted(perceived)
    if len(ids) < 2:
        return []
    p = np.array([[perceived[b].x, perceived[b].y, perceived[b].theta] for b in ids])
    pairs = overlapping_blocks(block_corners(p[:, 0], p[:, 1], p[:, 2], block_size))
    return [(ids[i], ids[j]) for i, j in pairs]


def fingers_clear(perceived: Mapping[int, Pose2D], block: int, geo: GripperGeometry,
                  grasp: int, table: Workspace, margin: float = FINGER_MARGIN) -> bool:
    """Whether the fingers of ``grasp`` (0: closing along the block's x, 1: along its y),
    open as ``geo`` says, touch no other perceived block (by ``margin``) and stand on the
    table ``table``."""
    pose = perceived[block]
    fingers = grasp_finger_corners(geo, pose.x, pose.y, pose.theta, grasp)
    if not _inside(fingers, table, 0.0).all():
        return False
    others = [q for b, q in perceived.items() if b != block]
    if not others:
        return True
    p = np.array([[q.x, q.y, q.theta] for q in others])
    obstacles = shapely.STRtree(shapely.buffer(
        to_polygons(block_corners(p[:, 0], p[:, 1], p[:, 2], geo.block_size)), margin))
    return not len(obstacles.query(to_polygons(fingers), predicate="intersects")[0])


def free_grasp(perceived: Mapping[int, Pose2D], block: int, geo: GripperGeometry,
               table: Workspace, margin: float = FINGER_MARGIN) -> int | None:
    """A grasp whose fingers are clear (``fingers_clear``); None when neither is."""
    return next((g for g in (0, 1) if fingers_clear(perceived, block, geo, g, table, margin)),
                None)


def _opening_if_clear(around: Mapping[int, Pose2D], block: int, grasp: int, table: Workspace,
                      geo: GripperGeometry, clearance: float, margin: float) -> float | None:
    """The opening that leaves ``clearance`` beside ``block`` if it fits the gripper's stroke
    and those fingers clear every other block of ``around`` by ``margin`` and stand on
    ``table``; None otherwise."""
    opened = dataclasses.replace(geo, approach_clearance=clearance)
    if opened.approach_opening > GRIPPER_STROKE - 0.001:
        return None
    if not fingers_clear(around, block, opened, grasp, table, margin):
        return None
    return opened.approach_opening


def wide_opening(around: Mapping[int, Pose2D], block: int, grasp: int, table: Workspace,
                 geo: GripperGeometry, pick_clearance: float) -> float | None:
    """The opening that leaves ``pick_clearance`` beside ``block`` (a perception a
    centimetre off still grips it) if those fingers clear every other block of ``around``
    and stand on ``table``; None (the plan's opening) otherwise."""
    return _opening_if_clear(around, block, grasp, table, geo,
                             max(pick_clearance, geo.approach_clearance), FINGER_MARGIN)


def tight_opening(around: Mapping[int, Pose2D], block: int, grasp: int, table: Workspace,
                  geo: GripperGeometry, clearance: float) -> float | None:
    """The narrower opening that leaves ``clearance`` beside ``block`` where the plan's
    fingers would go down within ``NEIGHBOUR_MARGIN`` of another block of ``around`` (the
    plan allows a finger flush with a neighbour; the perception's fraction of a millimetre
    then grazes it) and the narrower ones keep that margin; None (the plan's) otherwise."""
    if clearance >= geo.approach_clearance or fingers_clear(
            around, block, geo, grasp, table, NEIGHBOUR_MARGIN):
        return None
    return _opening_if_clear(around, block, grasp, table, geo, clearance, NEIGHBOUR_MARGIN)


def set_down_steps(block: int, where: Pose2D, yaw: float, geo: GripperGeometry,
                   cfg: ExecutorConfig) -> list[Step]:
    """Carry the block in the fingers above ``where``, set it down and let go."""
    above = ToolPose(where.x, where.y, cfg.travel_height, yaw)
    tag, of = f"block {block}", of_block(block)
    return [
        Rise(cfg.travel_height, cfg.vertical_limits, f"{tag}: rise", blend=cfg.blend_radius,
             **of),
        Move(above, cfg.travel_limits, f"{tag}: carry", converge=False, **of),
        Move(above.with_z(cfg.grasp_height + cfg.place_drop + cfg.approach_distance),
             cfg.vertical_limits, f"{tag}: lower", converge=False, **of),
        Move(above.with_z(cfg.grasp_height + cfg.place_drop), cfg.approach_limits,
             f"{tag}: lower (last cm)", **of),
        Grip(release_opening(geo, cfg), cfg.gripper_settle_s, f"{tag}: release", **of),
        Move(above, cfg.vertical_limits, f"{tag}: retreat", **of),
    ]


def let_go_steps(geo: GripperGeometry, cfg: ExecutorConfig, label: str) -> list[Step]:
    """Open the fingers where the tool is (whatever they hold stays there) and rise to travel
    height."""
    return [Grip(geo.approach_opening, cfg.gripper_settle_s, f"{label}: open"),
            Rise(cfg.travel_height, cfg.vertical_limits, f"{label}: rise")]


def bring_in_steps(block: int, at: Pose2D, to: Pose2D, grasp: int, geo: GripperGeometry,
                   cfg: ExecutorConfig, pick_opening: float | None = None,
                   turn_period: float = GRASP_SYMMETRY) -> list[Step]:
    """Pick the block up where it lies (outside the workspace, say) and place it at ``to``,
    the fingers open to ``pick_opening`` (default: the plan's) to go down around it."""
    return pick_place_steps(PickPlace(block, at, to, grasp), at, geo, cfg, pick_opening,
                            turn_period)
