"""Lossless codecs between msgs_py dataclasses and the ``densepack_interfaces`` messages.

For every record, ``X_to_msg`` builds the typed message and ``X_from_msg`` decodes one,
validating as it goes: a NaN, an unknown state or action type, a duplicate id, an id out of
range, a field filled that the message's own discriminator says is unused... raises
``MessageError`` naming the offending field by its message path (``blocks[2].pose.x``,
``goal.slots[0].block_id``, ``actions[4].type``). ``from_msg`` and ``to_msg`` dispatch on type.

dataclass -> message -> dataclass gives back an equal dataclass. Conventions:

* Poses are ``PlanarPose`` (x, y, theta in float64), so yaws travel bit-exact.
* Optional block ids travel as the message's ``NO_BLOCK`` / ``ANY_BLOCK`` (-1).
* Vocabularies (states, outcomes, errors, action types) travel as the messages' constants.
* Dicts of figures travel as ``Metric[]``; plan parameters and planner overrides as
  ``rcl_interfaces/Parameter[]`` (typed; a list must hold one type; lists decode as lists).
* Scenes and goal layouts are in ``world``; their header's ``frame_id`` is written ``world``
  and an empty one is read as ``world``.
* Stamps that the dataclasses do not hold (status, scene headers) are taken as an argument.

Import this module only where ROS messages are wanted (node adapters, tools): it imports the
generated ``densepack_interfaces`` package (from ``pip install ros_ws/src/densepack_interfaces``
or ``colcon build``). ``import msgs_py`` does not import it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from densepack_interfaces import msg as ifc
from densepack_interfaces.action import Rearrange
from densepack_interfaces.srv import PlanScene
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue

from msgs_py.actions import Action, PickPlace, Plan, Push
from msgs_py.checks import finite_float
from msgs_py.detection import BlockSet
from msgs_py.errors import MessageError
from msgs_py.placement import Placement
from msgs_py.poses import BlockPose, Pose2D
from msgs_py.ros_codecs import ns_to_stamp, stamp_to_ns
from msgs_py.scene import SCHEMA_VERSION, Goal, GoalSlot, GridSpec, Scene, Workspace
from msgs_py.sim import (
    SIM_EVENT_TYPES,
    SIM_FAULT_KINDS,
    Disturbance,
    SimEvent,
    SimEvents,
    SimFault,
)
from msgs_py.status import (
    GRIPPER_OBJECT_STATES,
    PLANNER_STATES,
    SAFETY_MODES,
    ExecutorState,
    ExecutorStatus,
    GripperStatus,
    PlannerStatus,
    SafetyMode,
)
from msgs_py.tasks import (
    PLAN_ERRORS,
    REARRANGE_OUTCOMES,
    BlockError,
    PlanReply,
    PlanRequest,
    RearrangeFeedback,
    RearrangeResult,
    check_params,
)

WORLD = "world"
NO_BLOCK = -1
INT32_MAX = 2**31 - 1
UINT32_MAX = 2**32 - 1
INT64_MIN, INT64_MAX = -(2**63), 2**63 - 1


def _constants(msg_type: type, prefix: str, names: Sequence[str]) -> dict[str, int]:
    """Vocabulary name -> the message's constant ``PREFIX_NAME`` (all of them must exist)."""
    table = {}
    for name in names:
        constant = f"{prefix}{name.upper()}"
        if not hasattr(msg_type, constant):
            raise ImportError(f"{msg_type.__name__} lacks {constant} for '{name}': rebuild "
                              "densepack_interfaces after changing the vocabulary")
        table[name] = int(getattr(msg_type, constant))
    return table


EXECUTOR_STATE_CODES = _constants(ifc.ExecutorStatus, "STATE_", [s.value for s in ExecutorState])
PLANNER_STATE_CODES = _constants(ifc.PlannerStatus, "STATE_", PLANNER_STATES)
PLAN_ERROR_CODES = _constants(PlanScene.Response, "ERROR_", PLAN_ERRORS)
OUTCOME_CODES = _constants(Rearrange.Result, "OUTCOME_", REARRANGE_OUTCOMES)
GRIPPER_OBJECT_CODES = _constants(ifc.GripperStatus, "OBJECT_", GRIPPER_OBJECT_STATES)
SAFETY_MODE_CODES = _constants(ifc.SafetyMode, "", SAFETY_MODES)
SIM_EVENT_CODES = _constants(ifc.SimEvent, "TYPE_", SIM_EVENT_TYPES)
SIM_FAULT_CODES = _constants(ifc.SimFault, "KIND_", SIM_FAULT_KINDS)
ACTION_TYPE_CODES = {"pick_place": ifc.PlanAction.PICK_PLACE, "push": ifc.PlanAction.PUSH}


# --- small field helpers ----------------------------------------------------------------------
@contextmanager
def _fields(prefix: str, renames: Sequence[tuple[str, str]] = ()) -> Iterator[None]:
    """Re-raise a dataclass's MessageError with its field as a message path under ``prefix``.

    ``renames`` maps the dict-schema names the dataclasses use (``goal.poses[2].id``) to the
    message's (``goal.slots[2].block_id``); the longest matching start wins.
    """
    try:
        yield
    except MessageError as err:
        name, reason = err.field, err.reason
        for old, new in sorted(renames, key=lambda r: -len(r[0])):
            if name == old or name.startswith((f"{old}.", f"{old}[")):
                name = new + name[len(old):]
                break
        for old, new in renames:  # "duplicate id (also at goal.poses[0])"
            if "[" not in old:
                reason = reason.replace(f"{old}[", f"{new}[")
        full = f"{prefix}.{name}" if prefix and name else (prefix or name)
        raise MessageError(full, err.value, reason) from None


def _join(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def _float(where: str, value: Any) -> float:
    return finite_float(where, value)


def _int(where: str, value: Any, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise MessageError(where, value, "expected an integer")
    if not lo <= value <= hi:
        raise MessageError(where, value, f"must lie in [{lo}, {hi}]")
    return int(value)


def _text(where: str, value: Any) -> str:
    """A ROS string: UTF-8 and a C string on the wire (a NUL would cut it short)."""
    if not isinstance(value, str):
        raise MessageError(where, value, "expected a string")
    if "\x00" in value:
        raise MessageError(where, value, "a ROS string cannot hold a NUL character")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise MessageError(where, value, "a ROS string is UTF-8 (no lone surrogates)") from None
    return value


def _block_id(where: str, value: Any) -> int:
    return _int(where, value, 0, INT32_MAX)


def _optional_block_to(where: str, block: int | None) -> int:
    return NO_BLOCK if block is None else _block_id(where, block)


def _optional_block_from(where: str, value: int) -> int | None:
    if value == NO_BLOCK:
        return None
    return _block_id(where, value)


def _code_to(where: str, table: dict[str, int], name: str) -> int:
    if name not in table:
        raise MessageError(where, name, f"expected one of {list(table)}")
    return table[name]


def _code_from(where: str, table: dict[str, int], code: int) -> str:
    for name, value in table.items():
        if value == code:
            return name
    raise MessageError(where, code, f"unknown constant; expected one of {table}")


def _unique(where: str, key: str, values: Sequence[Any]) -> None:
    seen: dict[Any, int] = {}
    for k, value in enumerate(values):
        if value in seen:
            raise MessageError(f"{where}[{k}].{key}" if key else f"{where}[{k}]", value,
                               f"duplicate (also at {where}[{seen[value]}])")
        seen[value] = k


def _check_version(where: str, version: int) -> None:
    if version != SCHEMA_VERSION:
        raise MessageError(where, version, f"only schema v{SCHEMA_VERSION} has a message form")


# --- frames ---------------------------------------------------------------------------------------
def _world_frame_from(where: str, frame_id: str) -> None:
    if frame_id not in (WORLD, ""):
        raise MessageError(where, frame_id, f"scenes and goal layouts are in '{WORLD}'")


# --- poses ----------------------------------------------------------------------------------------
def pose_to_msg(pose: Pose2D | BlockPose | GoalSlot, where: str = "pose") -> ifc.PlanarPose:
    return ifc.PlanarPose(x=_float(f"{where}.x", pose.x), y=_float(f"{where}.y", pose.y),
                      theta=_float(f"{where}.theta", pose.theta))


def _pose_values(msg: ifc.PlanarPose, where: str) -> tuple[float, float, float]:
    return (_float(f"{where}.x", msg.x), _float(f"{where}.y", msg.y),
            _float(f"{where}.theta", msg.theta))


def pose_from_msg(msg: ifc.PlanarPose, where: str = "pose") -> Pose2D:
    return Pose2D(*_pose_values(msg, where))


def block_pose_to_msg(block: BlockPose, where: str = "block") -> ifc.BlockPose:
    return ifc.BlockPose(id=_block_id(f"{where}.id", block.id),
                        pose=pose_to_msg(block, f"{where}.pose"))


def block_pose_from_msg(msg: ifc.BlockPose, where: str = "block") -> BlockPose:
    return BlockPose(_block_id(f"{where}.id", msg.id), *_pose_values(msg.pose, f"{where}.pose"))


# --- detections -------------------------------------------------------------------------------
def block_set_to_msg(block_set: BlockSet) -> ifc.BlockPoseArray:
    msg = ifc.BlockPoseArray()
    msg.header.stamp = ns_to_stamp(block_set.stamp_ns, "stamp_ns")
    msg.header.frame_id = _text("frame_id", block_set.frame_id)
    msg.block_size = _float("block_size", block_set.block_size)
    msg.blocks = [block_pose_to_msg(b, f"blocks[{k}]") for k, b in enumerate(block_set.blocks)]
    msg.missing_ids = [_block_id(f"missing[{k}]", i) for k, i in enumerate(block_set.missing)]
    seen = set(block_set.ids)
    for block_id, error in block_set.reprojection_px.items():
        where = f"reprojection_px[{block_id}]"
        if block_id not in seen:
            raise MessageError(where, error, "a reprojection error belongs to a seen block")
        if _float(where, error) < 0.0:
            raise MessageError(where, error, "must be >= 0")
    if block_set.reprojection_px:
        msg.reprojection_error_px = [
            float(block_set.reprojection_px.get(b.id, ifc.BlockPoseArray.UNKNOWN_ERROR))
            for b in block_set.blocks
        ]
    return msg


def block_set_from_msg(msg: ifc.BlockPoseArray) -> BlockSet:
    blocks = tuple(block_pose_from_msg(b, f"blocks[{k}]") for k, b in enumerate(msg.blocks))
    _unique("blocks", "id", [b.id for b in blocks])
    missing = tuple(_block_id(f"missing_ids[{k}]", int(i)) for k, i in enumerate(msg.missing_ids))
    _unique("missing_ids", "", missing)
    errors = list(msg.reprojection_error_px)
    if errors and len(errors) != len(blocks):
        raise MessageError("reprojection_error_px", len(errors),
                           f"must be empty or hold one entry per block ({len(blocks)})")
    reprojection = {}
    for k, (block, error) in enumerate(zip(blocks, errors, strict=False)):
        value = _float(f"reprojection_error_px[{k}]", error)
        if value == ifc.BlockPoseArray.UNKNOWN_ERROR:
            continue
        if value < 0.0:
            raise MessageError(f"reprojection_error_px[{k}]", value,
                               "must be >= 0 or UNKNOWN_ERROR")
        reprojection[block.id] = value
    with _fields("", [("missing", "missing_ids")]):
        return BlockSet(blocks, stamp_to_ns(msg.header.stamp), msg.header.frame_id,
                        _float("block_size", msg.block_size), missing, reprojection)


# --- workspace, goals, scenes -----------------------------------------------------------------
def workspace_to_msg(workspace: Workspace, where: str = "workspace") -> ifc.Workspace:
    return ifc.Workspace(**{k: _float(f"{where}.{k}", v) for k, v in workspace.to_dict().items()})


def workspace_from_msg(msg: ifc.Workspace, where: str = "workspace") -> Workspace:
    keys = ("x_min", "x_max", "y_min", "y_max")
    values = [_float(f"{where}.{k}", getattr(msg, k)) for k in keys]
    with _fields("", [("workspace", where)]):
        return Workspace(*values)


def grid_to_msg(grid: GridSpec, where: str = "grid") -> ifc.GridSpec:
    return ifc.GridSpec(
        rows=_int(f"{where}.rows", grid.rows, 1, UINT32_MAX),
        cols=_int(f"{where}.cols", grid.cols, 1, UINT32_MAX),
        center_x=_float(f"{where}.center_x", grid.center[0]),
        center_y=_float(f"{where}.center_y", grid.center[1]),
        theta=_float(f"{where}.theta", grid.theta),
        gap=_float(f"{where}.gap", grid.gap),
    )


def grid_from_msg(msg: ifc.GridSpec, where: str = "grid") -> GridSpec:
    for name in ("rows", "cols"):
        if getattr(msg, name) < 1:
            raise MessageError(f"{where}.{name}", getattr(msg, name), "must be >= 1")
    gap = _float(f"{where}.gap", msg.gap)
    if gap < 0.0:
        raise MessageError(f"{where}.gap", gap, "must be >= 0")
    return GridSpec(int(msg.rows), int(msg.cols),
                    (_float(f"{where}.center_x", msg.center_x),
                     _float(f"{where}.center_y", msg.center_y)),
                    _float(f"{where}.theta", msg.theta), gap)


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
        block = ifc.GoalSlot.ANY_BLOCK if slot.id is None else _block_id(f"{at}.block_id", slot.id)
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
        block = None if s.block_id == ifc.GoalSlot.ANY_BLOCK else _block_id(f"{at}.block_id",
                                                                          s.block_id)
        slots.append(GoalSlot(*_pose_values(s.pose, f"{at}.pose"), block))
    with _fields("", _goal_renames(len(slots), where)):
        return Goal(slots=tuple(slots), labeled=bool(msg.labeled), yaw_exact=bool(msg.yaw_exact))


def _header_to(msg: Any, stamp_ns: int) -> None:
    msg.header.stamp = ns_to_stamp(stamp_ns)
    msg.header.frame_id = WORLD


def scene_to_msg(scene: Scene, stamp_ns: int = 0) -> ifc.Scene:
    """A ``Scene`` (with or without goal); ``stamp_ns``: when its blocks were seen."""
    _check_version("version", scene.version)
    msg = ifc.Scene(workspace=workspace_to_msg(scene.workspace),
                   block_size=_float("block_size", scene.block_size))
    _header_to(msg, stamp_ns)
    msg.blocks = [block_pose_to_msg(b, f"blocks[{k}]") for k, b in enumerate(scene.blocks)]
    if scene.goal is not None:
        msg.has_goal = True
        msg.goal = goal_to_msg(scene.goal)
    return msg


def scene_from_msg(msg: ifc.Scene, where: str = "") -> Scene:
    _world_frame_from(_join(where, "header.frame_id"), msg.header.frame_id)
    workspace = workspace_from_msg(msg.workspace, _join(where, "workspace"))
    blocks = tuple(block_pose_from_msg(b, _join(where, f"blocks[{k}]"))
                   for k, b in enumerate(msg.blocks))
    goal = None
    if msg.has_goal:
        goal = goal_from_msg(msg.goal, _join(where, "goal"))
    elif msg.goal != ifc.GoalSpec():
        raise MessageError(_join(where, "goal"), msg.goal.form,
                           "must be empty (all zero) when has_goal is false")
    with _fields(where, _goal_renames(len(goal.slots) if goal else 0)):
        return Scene(workspace, _float("block_size", msg.block_size), blocks, goal)


def goal_layout_to_msg(layout: Scene, stamp_ns: int = 0) -> ifc.GoalLayout:
    """A goal layout: a ``Scene`` without blocks, with a goal (what ``/goal_layout`` carries)."""
    if layout.blocks:
        raise MessageError("blocks", len(layout.blocks), "a goal layout carries no blocks")
    if layout.goal is None:
        raise MessageError("goal", None, "a goal layout needs a goal")
    _check_version("version", layout.version)
    msg = ifc.GoalLayout(workspace=workspace_to_msg(layout.workspace),
                     block_size=_float("block_size", layout.block_size),
                     goal=goal_to_msg(layout.goal))
    _header_to(msg, stamp_ns)
    return msg


def goal_layout_from_msg(msg: ifc.GoalLayout, where: str = "") -> Scene:
    _world_frame_from(_join(where, "header.frame_id"), msg.header.frame_id)
    workspace = workspace_from_msg(msg.workspace, _join(where, "workspace"))
    goal = goal_from_msg(msg.goal, _join(where, "goal"))
    with _fields(where, _goal_renames(len(goal.slots))):
        return Scene(workspace, _float("block_size", msg.block_size), (), goal)


# --- plans ---------------------------------------------------------------------------------------
def action_to_msg(action: Action, where: str = "action") -> ifc.PlanAction:
    msg = ifc.PlanAction(block=_block_id(f"{where}.block", action.block),
                     from_pose=pose_to_msg(action.from_, f"{where}.from_pose"),
                     to_pose=pose_to_msg(action.to, f"{where}.to_pose"))
    if isinstance(action, PickPlace):
        msg.type = ifc.PlanAction.PICK_PLACE
        msg.grasp = _int(f"{where}.grasp", action.grasp, 0, 1)
    elif isinstance(action, Push):
        msg.type = ifc.PlanAction.PUSH
        msg.direction_x = _float(f"{where}.direction_x", action.direction[0])
        msg.direction_y = _float(f"{where}.direction_y", action.direction[1])
        msg.distance = _float(f"{where}.distance", action.distance)
    else:
        raise MessageError(f"{where}.type", type(action).__name__, "not a PickPlace or a Push")
    return msg


_ACTION_RENAMES = (("from", "from_pose"), ("to", "to_pose"), ("direction", "direction_x"))


def action_from_msg(msg: ifc.PlanAction, where: str = "action") -> Action:
    block = _block_id(f"{where}.block", msg.block)
    start = pose_from_msg(msg.from_pose, f"{where}.from_pose")
    end = pose_from_msg(msg.to_pose, f"{where}.to_pose")
    with _fields(where, _ACTION_RENAMES):
        if msg.type == ifc.PlanAction.PICK_PLACE:
            for name in ("direction_x", "direction_y", "distance"):
                if getattr(msg, name) != 0.0:
                    raise MessageError(name, getattr(msg, name), "unused by PICK_PLACE: keep 0")
            if msg.grasp not in (ifc.PlanAction.GRASP_LOCAL_X, ifc.PlanAction.GRASP_LOCAL_Y):
                raise MessageError("grasp", msg.grasp, "expected GRASP_LOCAL_X (0) or _Y (1)")
            return PickPlace(block, start, end, int(msg.grasp))
        if msg.type == ifc.PlanAction.PUSH:
            if msg.grasp != 0:
                raise MessageError("grasp", msg.grasp, "unused by PUSH: keep 0")
            direction = (_float("direction_x", msg.direction_x),
                         _float("direction_y", msg.direction_y))
            return Push(block, start, end, direction, _float("distance", msg.distance))
    raise MessageError(f"{where}.type", msg.type, "expected PICK_PLACE (1) or PUSH (2)")


def params_to_msg(params: dict[str, Any], where: str = "params") -> list[Parameter]:
    """Typed ROS parameters, in the dict's order. Lists must hold one type (or be empty)."""
    check_params(where, params)
    return [Parameter(name=_text(where, name), value=_param_value(f"{where}.{name}", value))
            for name, value in params.items()]


def _param_value(where: str, value: Any) -> ParameterValue:
    if value is None:
        return ParameterValue(type=ParameterType.PARAMETER_NOT_SET)
    if isinstance(value, bool):
        return ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
    if isinstance(value, int):
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER,
                              integer_value=_int(where, value, INT64_MIN, INT64_MAX))
    if isinstance(value, float):
        return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    if isinstance(value, str):
        return ParameterValue(type=ParameterType.PARAMETER_STRING,
                              string_value=_text(where, value))
    items = list(value)
    if items and isinstance(items[0], bool):
        return ParameterValue(type=ParameterType.PARAMETER_BOOL_ARRAY, bool_array_value=items)
    if items and isinstance(items[0], int):
        ints = [_int(f"{where}[{k}]", v, INT64_MIN, INT64_MAX) for k, v in enumerate(items)]
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER_ARRAY,
                              integer_array_value=ints)
    if items and isinstance(items[0], str):
        return ParameterValue(type=ParameterType.PARAMETER_STRING_ARRAY,
                              string_array_value=[_text(f"{where}[{k}]", s)
                                                  for k, s in enumerate(items)])
    return ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY,
                          double_array_value=[float(v) for v in items])


def params_from_msg(msgs: Sequence[Parameter], where: str = "params") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, p in enumerate(msgs):
        at = f"{where}[{k}]"
        if not p.name:
            raise MessageError(f"{at}.name", p.name, "a parameter needs a name")
        if p.name in out:
            raise MessageError(f"{at}.name", p.name, "duplicate parameter name")
        out[p.name] = _param_from(f"{at}.value", p.value)
    return out


def _param_from(where: str, v: ParameterValue) -> Any:
    t = v.type
    if t == ParameterType.PARAMETER_NOT_SET:
        return None
    if t == ParameterType.PARAMETER_BOOL:
        return bool(v.bool_value)
    if t == ParameterType.PARAMETER_INTEGER:
        return int(v.integer_value)
    if t == ParameterType.PARAMETER_DOUBLE:
        return _float(f"{where}.double_value", v.double_value)
    if t == ParameterType.PARAMETER_STRING:
        return str(v.string_value)
    if t == ParameterType.PARAMETER_BOOL_ARRAY:
        return [bool(b) for b in v.bool_array_value]
    if t == ParameterType.PARAMETER_INTEGER_ARRAY:
        return [int(i) for i in v.integer_array_value]
    if t == ParameterType.PARAMETER_DOUBLE_ARRAY:
        return [_float(f"{where}.double_array_value[{k}]", d)
                for k, d in enumerate(v.double_array_value)]
    if t == ParameterType.PARAMETER_STRING_ARRAY:
        return [str(s) for s in v.string_array_value]
    raise MessageError(f"{where}.type", t, "expected NOT_SET, a bool, integer, double or string "
                       "(array) parameter; byte arrays are not used")


def plan_to_msg(plan: Plan) -> ifc.Plan:
    _check_version("version", plan.version)
    msg = ifc.Plan(plan_id=_text("plan_id", plan.plan_id), planner=_text("planner", plan.planner),
                  seed=_int("seed", plan.seed, INT64_MIN, INT64_MAX),
                  planning_time_s=_float("planning_time_s", plan.planning_time_s),
                  cost=_float("cost", plan.cost), params=params_to_msg(plan.params))
    if plan.scene is not None:
        msg.has_scene = True
        msg.scene = scene_to_msg(plan.scene)
    msg.actions = [action_to_msg(a, f"actions[{k}]") for k, a in enumerate(plan.actions)]
    return msg


def plan_from_msg(msg: ifc.Plan, where: str = "") -> Plan:
    planning_time = _float(_join(where, "planning_time_s"), msg.planning_time_s)
    if planning_time < 0.0:
        raise MessageError(_join(where, "planning_time_s"), planning_time, "must be >= 0")
    scene = None
    if msg.has_scene:
        scene = scene_from_msg(msg.scene, _join(where, "scene"))
    elif msg.scene != ifc.Scene():
        raise MessageError(_join(where, "scene"), "...", "must be empty when has_scene is false")
    return Plan(
        actions=tuple(action_from_msg(a, _join(where, f"actions[{k}]"))
                      for k, a in enumerate(msg.actions)),
        planner=msg.planner,
        params=params_from_msg(msg.params, _join(where, "params")),
        seed=int(msg.seed),
        planning_time_s=planning_time,
        cost=_float(_join(where, "cost"), msg.cost),
        plan_id=msg.plan_id,
        scene=scene,
    )


# --- status ------------------------------------------------------------------------------------
def metrics_to_msg(metrics: dict[str, float], where: str = "metrics") -> list[ifc.Metric]:
    return [ifc.Metric(name=_text(where, name), value=_float(f"{where}.{name}", value))
            for name, value in metrics.items()]


def metrics_from_msg(msgs: Sequence[ifc.Metric], where: str = "metrics") -> dict[str, float]:
    out: dict[str, float] = {}
    for k, m in enumerate(msgs):
        if m.name in out:
            raise MessageError(f"{where}[{k}].name", m.name, "duplicate metric name")
        out[m.name] = _float(f"{where}[{k}].value", m.value)
    return out


def executor_status_to_msg(status: ExecutorStatus, stamp_ns: int = 0) -> ifc.ExecutorStatus:
    _check_version("version", status.version)
    return ifc.ExecutorStatus(
        stamp=ns_to_stamp(stamp_ns),
        state=_code_to("state", EXECUTOR_STATE_CODES, status.state),
        plan_id=_text("plan_id", status.plan_id),
        action_index=_int("action_index", status.action_index, 0, UINT32_MAX),
        action_total=_int("action_total", status.action_total, 0, UINT32_MAX),
        block=_optional_block_to("block", status.block),
        last_error=_text("last_error", status.last_error),
        detail=_text("detail", status.detail),
        metrics=metrics_to_msg(status.metrics),
    )


def executor_status_from_msg(msg: ifc.ExecutorStatus) -> ExecutorStatus:
    return ExecutorStatus(
        state=_code_from("state", EXECUTOR_STATE_CODES, msg.state),
        plan_id=msg.plan_id,
        action_index=int(msg.action_index),
        action_total=int(msg.action_total),
        block=_optional_block_from("block", msg.block),
        last_error=msg.last_error,
        detail=msg.detail,
        metrics=metrics_from_msg(msg.metrics),
    )


def planner_status_to_msg(status: PlannerStatus, stamp_ns: int = 0) -> ifc.PlannerStatus:
    _check_version("version", status.version)
    return ifc.PlannerStatus(
        stamp=ns_to_stamp(stamp_ns),
        state=_code_to("state", PLANNER_STATE_CODES, status.state),
        plan_id=_text("plan_id", status.plan_id),
        n_actions=_int("n_actions", status.n_actions, 0, UINT32_MAX),
        planning_time_s=_float("planning_time_s", status.planning_time_s),
        last_error=_text("last_error", status.last_error),
        failed_block=_optional_block_to("failed_block", status.failed_block),
        metrics=metrics_to_msg(status.metrics),
    )


def planner_status_from_msg(msg: ifc.PlannerStatus) -> PlannerStatus:
    return PlannerStatus(
        state=_code_from("state", PLANNER_STATE_CODES, msg.state),
        plan_id=msg.plan_id,
        n_actions=int(msg.n_actions),
        planning_time_s=_float("planning_time_s", msg.planning_time_s),
        last_error=msg.last_error,
        failed_block=_optional_block_from("failed_block", msg.failed_block),
        metrics=metrics_from_msg(msg.metrics),
    )


def gripper_status_to_msg(status: GripperStatus) -> ifc.GripperStatus:
    msg = ifc.GripperStatus(gap=_float("gap", status.gap),
                            requested_gap=_float("requested_gap", status.requested_gap),
                            object=_code_to("object", GRIPPER_OBJECT_CODES, status.object))
    msg.header.stamp = ns_to_stamp(status.stamp_ns, "stamp_ns")
    return msg


def gripper_status_from_msg(msg: ifc.GripperStatus) -> GripperStatus:
    return GripperStatus(_float("gap", msg.gap), _float("requested_gap", msg.requested_gap),
                         _code_from("object", GRIPPER_OBJECT_CODES, msg.object),
                         stamp_to_ns(msg.header.stamp))


def safety_mode_to_msg(mode: SafetyMode) -> ifc.SafetyMode:
    msg = ifc.SafetyMode(mode=_code_to("mode", SAFETY_MODE_CODES, mode.mode),
                         reason=mode.reason)
    msg.header.stamp = ns_to_stamp(mode.stamp_ns, "stamp_ns")
    return msg


def safety_mode_from_msg(msg: ifc.SafetyMode) -> SafetyMode:
    return SafetyMode(_code_from("mode", SAFETY_MODE_CODES, msg.mode), str(msg.reason),
                      stamp_to_ns(msg.header.stamp))


def sim_fault_to_msg(fault: SimFault) -> ifc.SimFault:
    msg = ifc.SimFault(kind=_code_to("kind", SIM_FAULT_CODES, fault.kind),
                       value=_float("value", fault.value))
    msg.block = _optional_block_to("block", fault.block)
    if fault.pose is not None:
        msg.pose = pose_to_msg(Pose2D(*fault.pose))
    return msg


def sim_fault_from_msg(msg: ifc.SimFault) -> SimFault:
    kind = _code_from("kind", SIM_FAULT_CODES, msg.kind)
    block = _optional_block_from("block", msg.block)
    pose = pose_from_msg(msg.pose) if kind == "add_block" else None
    return SimFault(kind, block, None if pose is None else (pose.x, pose.y, pose.theta),
                    _float("value", msg.value))


def placement_to_msg(placement: Placement) -> ifc.Placement:
    msg = ifc.Placement(block=_block_id("block", placement.block),
                        pose=pose_to_msg(placement.pose),
                        picked_from=pose_to_msg(placement.picked_from, "picked_from"),
                        closing_axis_yaw=_float("closing_axis_yaw", placement.closing_axis_yaw),
                        squared=bool(placement.squared))
    msg.header.stamp = ns_to_stamp(placement.stamp_ns, "stamp_ns")
    msg.header.frame_id = "world"
    return msg


def placement_from_msg(msg: ifc.Placement) -> Placement:
    if msg.header.frame_id not in ("", "world"):
        raise MessageError("header.frame_id", msg.header.frame_id, "placements are in world")
    return Placement(int(msg.block), pose_from_msg(msg.pose),
                     pose_from_msg(msg.picked_from, "picked_from"),
                     _float("closing_axis_yaw", msg.closing_axis_yaw),
                     stamp_to_ns(msg.header.stamp), bool(msg.squared))


# --- the simulator's events and disturbances -------------------------------------------------
def sim_event_to_msg(event: SimEvent, where: str = "event") -> ifc.SimEvent:
    return ifc.SimEvent(
        time_s=_float(f"{where}.time_s", event.time_s),
        type=_code_to(f"{where}.type", SIM_EVENT_CODES, event.type),
        block=_block_id(f"{where}.block", event.block),
        other_block=_optional_block_to(f"{where}.other_block", event.other_block),
        manipulated=_optional_block_to(f"{where}.manipulated", event.manipulated),
        robot=_text(f"{where}.robot", event.robot),
        reason=_text(f"{where}.reason", event.reason),
    )


def sim_event_from_msg(msg: ifc.SimEvent, where: str = "event") -> SimEvent:
    kind = _code_from(f"{where}.type", SIM_EVENT_CODES, msg.type)
    time_s = _float(f"{where}.time_s", msg.time_s)
    block = _block_id(f"{where}.block", msg.block)
    other = _optional_block_from(f"{where}.other_block", msg.other_block)
    manipulated = _optional_block_from(f"{where}.manipulated", msg.manipulated)
    with _fields(where):
        return SimEvent(kind, time_s, block, other, manipulated, msg.robot, msg.reason)


def sim_events_to_msg(events: SimEvents) -> ifc.SimEvents:
    msg = ifc.SimEvents(
        unintended_contacts=_int("unintended_contacts", events.unintended_contacts, 0,
                                 UINT32_MAX),
        blocks_lost=_int("blocks_lost", events.blocks_lost, 0, UINT32_MAX),
        events=[sim_event_to_msg(e, f"events[{k}]") for k, e in enumerate(events.events)])
    _header_to(msg, events.stamp_ns)
    return msg


def sim_events_from_msg(msg: ifc.SimEvents) -> SimEvents:
    events = tuple(sim_event_from_msg(e, f"events[{k}]") for k, e in enumerate(msg.events))
    return SimEvents(int(msg.unintended_contacts), int(msg.blocks_lost), events,
                     stamp_to_ns(msg.header.stamp))


def disturbance_to_msg(disturbance: Disturbance) -> ifc.Disturbance:
    return ifc.Disturbance(block=_block_id("block", disturbance.block),
                           dx=_float("dx", disturbance.dx), dy=_float("dy", disturbance.dy))


def disturbance_from_msg(msg: ifc.Disturbance) -> Disturbance:
    return Disturbance(_block_id("block", msg.block), _float("dx", msg.dx), _float("dy", msg.dy))


# --- PlanScene service -------------------------------------------------------------------------
def plan_request_to_msg(request: PlanRequest) -> PlanScene.Request:
    return PlanScene.Request(scene=scene_to_msg(request.scene),
                             overrides=params_to_msg(request.overrides, "overrides"))


def plan_request_from_msg(msg: PlanScene.Request) -> PlanRequest:
    if not msg.scene.has_goal:
        raise MessageError("scene.has_goal", False, "a scene to plan needs a goal")
    return PlanRequest(scene_from_msg(msg.scene, "scene"),
                       params_from_msg(msg.overrides, "overrides"))


def plan_reply_to_msg(reply: PlanReply) -> PlanScene.Response:
    msg = PlanScene.Response(
        success=reply.success,
        error_code=_code_to("error", PLAN_ERROR_CODES, reply.error),
        failed_block=_optional_block_to("failed_block", reply.failed_block),
        failed_field=_text("failed_field", reply.failed_field),
        message=_text("message", reply.message),
    )
    if reply.plan is not None:
        msg.plan = plan_to_msg(reply.plan)
    return msg


def plan_reply_from_msg(msg: PlanScene.Response) -> PlanReply:
    plan = None
    if msg.success:
        plan = plan_from_msg(msg.plan, "plan")
    elif msg.plan != ifc.Plan():
        raise MessageError("plan", msg.plan.plan_id, "must be empty when success is false")
    with _fields("", [("error", "error_code")]):
        return PlanReply(
            success=bool(msg.success),
            plan=plan,
            error=_code_from("error_code", PLAN_ERROR_CODES, msg.error_code),
            failed_block=_optional_block_from("failed_block", msg.failed_block),
            failed_field=msg.failed_field,
            message=msg.message,
        )


# --- Rearrange action ---------------------------------------------------------------------------
def rearrange_goal_to_msg(layout: Scene, stamp_ns: int = 0) -> Rearrange.Goal:
    return Rearrange.Goal(layout=goal_layout_to_msg(layout, stamp_ns))


def rearrange_goal_from_msg(msg: Rearrange.Goal) -> Scene:
    return goal_layout_from_msg(msg.layout, "layout")


def rearrange_feedback_to_msg(feedback: RearrangeFeedback) -> Rearrange.Feedback:
    return Rearrange.Feedback(
        state=_code_to("state", EXECUTOR_STATE_CODES, feedback.state),
        action_index=_int("action_index", feedback.action_index, 0, UINT32_MAX),
        action_total=_int("action_total", feedback.action_total, 0, UINT32_MAX),
        block=_optional_block_to("block", feedback.block),
        corrections=_int("corrections", feedback.corrections, 0, UINT32_MAX),
        detail=_text("detail", feedback.detail),
    )


def rearrange_feedback_from_msg(msg: Rearrange.Feedback) -> RearrangeFeedback:
    return RearrangeFeedback(
        state=_code_from("state", EXECUTOR_STATE_CODES, msg.state),
        action_index=int(msg.action_index),
        action_total=int(msg.action_total),
        block=_optional_block_from("block", msg.block),
        corrections=int(msg.corrections),
        detail=msg.detail,
    )


def block_error_to_msg(error: BlockError, where: str = "block_error") -> ifc.BlockError:
    return ifc.BlockError(block_id=_block_id(f"{where}.block_id", error.block_id),
                         found=bool(error.found),
                         position_error_m=_float(f"{where}.position_error_m",
                                                 error.position_error_m),
                         yaw_error_rad=_float(f"{where}.yaw_error_rad", error.yaw_error_rad))


def block_error_from_msg(msg: ifc.BlockError, where: str = "block_error") -> BlockError:
    block = _block_id(f"{where}.block_id", msg.block_id)
    position = _float(f"{where}.position_error_m", msg.position_error_m)
    yaw = _float(f"{where}.yaw_error_rad", msg.yaw_error_rad)
    with _fields(where):
        return BlockError(block, position, yaw, bool(msg.found))


def rearrange_result_to_msg(result: RearrangeResult) -> Rearrange.Result:
    return Rearrange.Result(
        outcome=_code_to("outcome", OUTCOME_CODES, result.outcome),
        detail=_text("detail", result.detail),
        block_errors=[block_error_to_msg(e, f"block_errors[{k}]")
                      for k, e in enumerate(result.block_errors)],
        metrics=metrics_to_msg(result.metrics),
    )


def rearrange_result_from_msg(msg: Rearrange.Result) -> RearrangeResult:
    errors = tuple(block_error_from_msg(e, f"block_errors[{k}]")
                   for k, e in enumerate(msg.block_errors))
    return RearrangeResult(
        outcome=_code_from("outcome", OUTCOME_CODES, msg.outcome),
        detail=msg.detail,
        block_errors=errors,
        metrics=metrics_from_msg(msg.metrics),
    )


# --- dispatch ------------------------------------------------------------------------------------
#: dataclass type -> encoder, for the records that have one message form.
ENCODERS: dict[type, Callable[[Any], Any]] = {
    Pose2D: pose_to_msg,
    BlockPose: block_pose_to_msg,
    BlockSet: block_set_to_msg,
    Workspace: workspace_to_msg,
    GridSpec: grid_to_msg,
    Goal: goal_to_msg,
    PickPlace: action_to_msg,
    Push: action_to_msg,
    Plan: plan_to_msg,
    ExecutorStatus: executor_status_to_msg,
    PlannerStatus: planner_status_to_msg,
    PlanRequest: plan_request_to_msg,
    PlanReply: plan_reply_to_msg,
    RearrangeFeedback: rearrange_feedback_to_msg,
    RearrangeResult: rearrange_result_to_msg,
    BlockError: block_error_to_msg,
    GripperStatus: gripper_status_to_msg,
    Placement: placement_to_msg,
    SimFault: sim_fault_to_msg,
    SimEvent: sim_event_to_msg,
    SimEvents: sim_events_to_msg,
    Disturbance: disturbance_to_msg,
}

#: message type -> decoder.
DECODERS: dict[type, Callable[[Any], Any]] = {
    ifc.PlanarPose: pose_from_msg,
    ifc.BlockPose: block_pose_from_msg,
    ifc.BlockPoseArray: block_set_from_msg,
    ifc.Workspace: workspace_from_msg,
    ifc.GridSpec: grid_from_msg,
    ifc.GoalSpec: goal_from_msg,
    ifc.GoalLayout: goal_layout_from_msg,
    ifc.Scene: scene_from_msg,
    ifc.PlanAction: action_from_msg,
    ifc.Plan: plan_from_msg,
    ifc.ExecutorStatus: executor_status_from_msg,
    ifc.PlannerStatus: planner_status_from_msg,
    PlanScene.Request: plan_request_from_msg,
    PlanScene.Response: plan_reply_from_msg,
    Rearrange.Goal: rearrange_goal_from_msg,
    Rearrange.Feedback: rearrange_feedback_from_msg,
    Rearrange.Result: rearrange_result_from_msg,
    ifc.BlockError: block_error_from_msg,
    ifc.GripperStatus: gripper_status_from_msg,
    ifc.Placement: placement_from_msg,
    ifc.SimFault: sim_fault_from_msg,
    ifc.SimEvent: sim_event_from_msg,
    ifc.SimEvents: sim_events_from_msg,
    ifc.Disturbance: disturbance_from_msg,
}


def to_msg(obj: Any) -> Any:
    """The message form of a msgs_py record. A ``Scene`` is a ``Scene`` message; for a goal
    layout (no blocks) call ``goal_layout_to_msg`` or ``rearrange_goal_to_msg``."""
    if isinstance(obj, Scene):
        return scene_to_msg(obj)
    try:
        encoder = ENCODERS[type(obj)]
    except KeyError:
        raise TypeError(f"no densepack_interfaces form for {type(obj).__name__}") from None
    return encoder(obj)


def from_msg(msg: Any) -> Any:
    """The msgs_py record of a densepack_interfaces message (validated)."""
    try:
        decoder = DECODERS[type(msg)]
    except KeyError:
        raise TypeError(f"no msgs_py record for {type(msg).__name__}") from None
    return decoder(msg)

