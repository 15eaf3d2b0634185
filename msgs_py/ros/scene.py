"""Codecs of where things are: planar poses, detected block sets, workspaces, goals, scenes
and goal layouts (scenes and layouts are in ``world``; an empty ``frame_id`` reads as ``world``).
"""

from __future__ import annotations

from densepack_interfaces import msg as ifc

from msgs_py.detection import BlockSet
from msgs_py.errors import MessageError
from msgs_py.goal import Goal, GoalSlot, GridSpec
from msgs_py.poses import BlockPose, Pose2D
from msgs_py.ros.fields import (
    UINT32_MAX,
    block_id_at,
    check_unique,
    check_version,
    check_world_frame,
    field_paths,
    float_at,
    int_at,
    join_path,
    set_world_header,
    text_at,
)
from msgs_py.ros.stamps import ns_to_stamp, stamp_to_ns
from msgs_py.scene import Scene, Workspace


# --- poses ----------------------------------------------------------------------------------------
def pose_to_msg(pose: Pose2D | BlockPose | GoalSlot, where: str = "pose") -> ifc.PlanarPose:
    return ifc.PlanarPose(x=float_at(f"{where}.x", pose.x), y=float_at(f"{where}.y", pose.y),
                      theta=float_at(f"{where}.theta", pose.theta))


def _pose_values(msg: ifc.PlanarPose, where: str) -> tuple[float, float, float]:
    return (float_at(f"{where}.x", msg.x), float_at(f"{where}.y", msg.y),
            float_at(f"{where}.theta", msg.theta))


def pose_from_msg(msg: ifc.PlanarPose, where: str = "pose") -> Pose2D:
    return Pose2D(*_pose_values(msg, where))


def block_pose_to_msg(block: BlockPose, where: str = "block") -> ifc.BlockPose:
    return ifc.BlockPose(id=block_id_at(f"{where}.id", block.id),
                        pose=pose_to_msg(block, f"{where}.pose"))


def block_pose_from_msg(msg: ifc.BlockPose, where: str = "block") -> BlockPose:
    return BlockPose(block_id_at(f"{where}.id", msg.id), *_pose_values(msg.pose, f"{where}.pose"))


# --- detections -------------------------------------------------------------------------------
def block_set_to_msg(block_set: BlockSet) -> ifc.BlockPoseArray:
    msg = ifc.BlockPoseArray()
    msg.header.stamp = ns_to_stamp(block_set.stamp_ns, "stamp_ns")
    msg.header.frame_id = text_at("frame_id", block_set.frame_id)
    msg.block_size = float_at("block_size", block_set.block_size)
    msg.blocks = [block_pose_to_msg(b, f"blocks[{k}]") for k, b in enumerate(block_set.blocks)]
    msg.missing_ids = [block_id_at(f"missing[{k}]", i) for k, i in enumerate(block_set.missing)]
    msg.occluded_ids = [block_id_at(f"occluded[{k}]", i)
                        for k, i in enumerate(block_set.occluded)]
    seen = set(block_set.ids)
    for block_id, error in block_set.reprojection_px.items():
        where = f"reprojection_px[{block_id}]"
        if block_id not in seen:
            raise MessageError(where, error, "a reprojection error belongs to a seen block")
        if float_at(where, error) < 0.0:
            raise MessageError(where, error, "must be >= 0")
    if block_set.reprojection_px:
        msg.reprojection_error_px = [
            float(block_set.reprojection_px.get(b.id, ifc.BlockPoseArray.UNKNOWN_ERROR))
            for b in block_set.blocks
        ]
    return msg


def block_set_from_msg(msg: ifc.BlockPoseArray) -> BlockSet:
    blocks = tuple(block_pose_from_msg(b, f"blocks[{k}]") for k, b in enumerate(msg.blocks))
    check_unique("blocks", "id", [b.id for b in blocks])
    missing = tuple(block_id_at(f"missing_ids[{k}]", int(i)) for k, i in enumerate(msg.missing_ids))
    check_unique("missing_ids", "", missing)
    occluded = tuple(block_id_at(f"occluded_ids[{k}]", int(i))
                     for k, i in enumerate(msg.occluded_ids))
    check_unique("occluded_ids", "", occluded)
    errors = list(msg.reprojection_error_px)
    if errors and len(errors) != len(blocks):
        raise MessageError("reprojection_error_px", len(errors),
                           f"must be empty or hold one entry per block ({len(blocks)})")
    reprojection = {}
    for k, (block, error) in enumerate(zip(blocks, errors, strict=False)):
        value = float_at(f"reprojection_error_px[{k}]", error)
        if value == ifc.BlockPoseArray.UNKNOWN_ERROR:
            continue
        if value < 0.0:
            raise MessageError(f"reprojection_error_px[{k}]", value,
                               "must be >= 0 or UNKNOWN_ERROR")
        reprojection[block.id] = value
    with field_paths("", [("missing", "missing_ids"), ("occluded", "occluded_ids")]):
        return BlockSet(blocks, stamp_to_ns(msg.header.stamp), msg.header.frame_id,
                        float_at("block_size", msg.block_size), missing, reprojection,
                        occluded)


# --- workspace, goals, scenes -----------------------------------------------------------------
def workspace_to_msg(workspace: Workspace, where: str = "workspace") -> ifc.Workspace:
    return ifc.Workspace(**{k: float_at(f"{where}.{k}", v) for k, v in workspace.to_dict().items()})


def workspace_from_msg(msg: ifc.Workspace, where: str = "workspace") -> Workspace:
    keys = ("x_min", "x_max", "y_min", "y_max")
    values = [float_at(f"{where}.{k}", getattr(msg, k)) for k in keys]
    with field_paths("", [("workspace", where)]):
        return Workspace(*values)


def grid_to_msg(grid: GridSpec, where: str = "grid") -> ifc.GridSpec:
    return ifc.GridSpec(
        rows=int_at(f"{where}.rows", grid.rows, 1, UINT32_MAX),
        cols=int_at(f"{where}.cols", grid.cols, 1, UINT32_MAX),
        center_x=float_at(f"{where}.center_x", grid.center[0]),
        center_y=float_at(f"{where}.center_y", grid.center[1]),
        theta=float_at(f"{where}.theta", grid.theta),
        gap=float_at(f"{where}.gap", grid.gap),
    )


def grid_from_msg(msg: ifc.GridSpec, where: str = "grid") -> GridSpec:
    for name in ("rows", "cols"):
        if getattr(msg, name) < 1:
            raise MessageError(f"{where}.{name}", getattr(msg, name), "must be >= 1")
    gap = float_at(f"{where}.gap", msg.gap)
    if gap < 0.0:
        raise MessageError(f"{where}.gap", gap, "must be >= 0")
    return GridSpec(int(msg.rows), int(msg.cols),
                    (float_at(f"{where}.center_x", msg.center_x),
                     float_at(f"{where}.center_y", msg.center_y)),
                    float_at(f"{where}.theta", msg.theta), gap)


def goal_to_msg(goal: Goal, where: str = "goal") -> ifc.GoalSpec:
    msg = ifc.GoalSpec(labeled=bool(goal.labeled), yaw_exact=bool(goal.yaw_exact))
    if goal.grid is not None:
        msg.form = ifc.GoalSpec.FORM_GRID
        msg.grid = grid_to_msg(goal.grid, f"{where}.grid")
        return msg
    msg.form = ifc.GoalSpec.FORM_SLOTS
    slots = []
    for k, slot in enumerate(goal.slots):
        at = f"{where}.slots[{k}]"
        block = (ifc.GoalSlot.ANY_BLOCK if slot.id is None
                 else block_id_at(f"{at}.block_id", slot.id))
        slots.append(ifc.GoalSlot(block_id=block, pose=pose_to_msg(slot, f"{at}.pose")))
    msg.slots = slots
    return msg


def _goal_renames(n_slots: int, goal: str = "goal") -> list[tuple[str, str]]:
    """Goal/Scene error names (``goal.poses[k].id``) -> message paths under ``goal``."""
    renames = [(f"goal.poses[{k}].id", f"{goal}.slots[{k}].block_id") for k in range(n_slots)]
    return [*renames, ("goal.poses", f"{goal}.slots"), ("goal", goal)]


def goal_from_msg(msg: ifc.GoalSpec, where: str = "goal") -> Goal:
    if msg.form == ifc.GoalSpec.FORM_GRID:
        if msg.slots:
            raise MessageError(f"{where}.slots", len(msg.slots), "must be empty with FORM_GRID")
        grid = grid_from_msg(msg.grid, f"{where}.grid")
        return Goal(grid=grid, labeled=bool(msg.labeled), yaw_exact=bool(msg.yaw_exact))
    if msg.form != ifc.GoalSpec.FORM_SLOTS:
        raise MessageError(f"{where}.form", msg.form, "expected FORM_SLOTS (1) or FORM_GRID (2)")
    if msg.grid != ifc.GridSpec():
        raise MessageError(f"{where}.grid", msg.grid.rows, "must be all zero with FORM_SLOTS")
    if not msg.slots:
        raise MessageError(f"{where}.slots", [], "FORM_SLOTS needs at least one slot")
    slots = []
    for k, s in enumerate(msg.slots):
        at = f"{where}.slots[{k}]"
        block = None if s.block_id == ifc.GoalSlot.ANY_BLOCK else block_id_at(f"{at}.block_id",
                                                                          s.block_id)
        slots.append(GoalSlot(*_pose_values(s.pose, f"{at}.pose"), block))
    with field_paths("", _goal_renames(len(slots), where)):
        return Goal(slots=tuple(slots), labeled=bool(msg.labeled), yaw_exact=bool(msg.yaw_exact))


def scene_to_msg(scene: Scene, stamp_ns: int = 0) -> ifc.Scene:
    """A ``Scene`` (with or without goal); ``stamp_ns``: when its blocks were seen."""
    check_version("version", scene.version)
    msg = ifc.Scene(workspace=workspace_to_msg(scene.workspace),
                   block_size=float_at("block_size", scene.block_size))
    set_world_header(msg, stamp_ns)
    msg.blocks = [block_pose_to_msg(b, f"blocks[{k}]") for k, b in enumerate(scene.blocks)]
    if scene.goal is not None:
        msg.has_goal = True
        msg.goal = goal_to_msg(scene.goal)
    return msg


def scene_from_msg(msg: ifc.Scene, where: str = "") -> Scene:
    check_world_frame(join_path(where, "header.frame_id"), msg.header.frame_id)
    workspace = workspace_from_msg(msg.workspace, join_path(where, "workspace"))
    blocks = tuple(block_pose_from_msg(b, join_path(where, f"blocks[{k}]"))
                   for k, b in enumerate(msg.blocks))
    goal = None
    if msg.has_goal:
        goal = goal_from_msg(msg.goal, join_path(where, "goal"))
    elif msg.goal != ifc.GoalSpec():
        raise MessageError(join_path(where, "goal"), msg.goal.form,
                           "must be empty (all zero) when has_goal is false")
    with field_paths(where, _goal_renames(len(goal.slots) if goal else 0)):
        return Scene(workspace, float_at("block_size", msg.block_size), blocks, goal)


def goal_layout_to_msg(layout: Scene, stamp_ns: int = 0) -> ifc.GoalLayout:
    """A goal layout: a ``Scene`` without blocks, with a goal (what ``/goal_layout`` carries)."""
    if layout.blocks:
        raise MessageError("blocks", len(layout.blocks), "a goal layout carries no blocks")
    if layout.goal is None:
        raise MessageError("goal", None, "a goal layout needs a goal")
    check_version("version", layout.version)
    msg = ifc.GoalLayout(workspace=workspace_to_msg(layout.workspace),
                     block_size=float_at("block_size", layout.block_size),
                     goal=goal_to_msg(layout.goal))
    set_world_header(msg, stamp_ns)
    return msg


def goal_layout_from_msg(msg: ifc.GoalLayout, where: str = "") -> Scene:
    check_world_frame(join_path(where, "header.frame_id"), msg.header.frame_id)
    workspace = workspace_from_msg(msg.workspace, join_path(where, "workspace"))
    goal = goal_from_msg(msg.goal, join_path(where, "goal"))
    with field_paths(where, _goal_renames(len(goal.slots))):
        return Scene(workspace, float_at("block_size", msg.block_size), (), goal)
