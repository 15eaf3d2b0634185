"""Codecs of plans: actions, typed plan parameters (``rcl_interfaces/Parameter[]``), plans,
and the ``PlanScene`` service's request and reply.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from densepack_interfaces import msg as ifc
from densepack_interfaces.srv import PlanScene
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue

from msgs_py.actions import Action, PickPlace, Plan, Push
from msgs_py.errors import MessageError
from msgs_py.ros.fields import (
    INT64_MAX,
    INT64_MIN,
    block_id_at,
    check_version,
    code_from,
    code_to,
    constants_of,
    field_paths,
    float_at,
    int_at,
    join_path,
    optional_block_from,
    optional_block_to,
    text_at,
)
from msgs_py.ros.scene import pose_from_msg, pose_to_msg, scene_from_msg, scene_to_msg
from msgs_py.tasks import PLAN_ERRORS, PlanReply, PlanRequest, check_params

PLAN_ERROR_CODES = constants_of(PlanScene.Response, "ERROR_", PLAN_ERRORS)
ACTION_TYPE_CODES = {"pick_place": ifc.PlanAction.PICK_PLACE, "push": ifc.PlanAction.PUSH}


def action_to_msg(action: Action, where: str = "action") -> ifc.PlanAction:
    msg = ifc.PlanAction(block=block_id_at(f"{where}.block", action.block),
                     from_pose=pose_to_msg(action.from_, f"{where}.from_pose"),
                     to_pose=pose_to_msg(action.to, f"{where}.to_pose"))
    if isinstance(action, PickPlace):
        msg.type = ifc.PlanAction.PICK_PLACE
        msg.grasp = int_at(f"{where}.grasp", action.grasp, 0, 1)
    elif isinstance(action, Push):
        msg.type = ifc.PlanAction.PUSH
        msg.direction_x = float_at(f"{where}.direction_x", action.direction[0])
        msg.direction_y = float_at(f"{where}.direction_y", action.direction[1])
        msg.distance = float_at(f"{where}.distance", action.distance)
    else:
        raise MessageError(f"{where}.type", type(action).__name__, "not a PickPlace or a Push")
    return msg


_ACTION_RENAMES = (("from", "from_pose"), ("to", "to_pose"), ("direction", "direction_x"))


def action_from_msg(msg: ifc.PlanAction, where: str = "action") -> Action:
    block = block_id_at(f"{where}.block", msg.block)
    start = pose_from_msg(msg.from_pose, f"{where}.from_pose")
    end = pose_from_msg(msg.to_pose, f"{where}.to_pose")
    with field_paths(where, _ACTION_RENAMES):
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
            direction = (float_at("direction_x", msg.direction_x),
                         float_at("direction_y", msg.direction_y))
            return Push(block, start, end, direction, float_at("distance", msg.distance))
    raise MessageError(f"{where}.type", msg.type, "expected PICK_PLACE (1) or PUSH (2)")


def params_to_msg(params: dict[str, Any], where: str = "params") -> list[Parameter]:
    """Typed ROS parameters, in the dict's order. Lists must hold one type (or be empty)."""
    check_params(where, params)
    return [Parameter(name=text_at(where, name), value=_param_value(f"{where}.{name}", value))
            for name, value in params.items()]


def _param_value(where: str, value: Any) -> ParameterValue:
    if value is None:
        return ParameterValue(type=ParameterType.PARAMETER_NOT_SET)
    if isinstance(value, bool):
        return ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
    if isinstance(value, int):
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER,
                              integer_value=int_at(where, value, INT64_MIN, INT64_MAX))
    if isinstance(value, float):
        return ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    if isinstance(value, str):
        return ParameterValue(type=ParameterType.PARAMETER_STRING,
                              string_value=text_at(where, value))
    items = list(value)
    if items and isinstance(items[0], bool):
        return ParameterValue(type=ParameterType.PARAMETER_BOOL_ARRAY, bool_array_value=items)
    if items and isinstance(items[0], int):
        ints = [int_at(f"{where}[{k}]", v, INT64_MIN, INT64_MAX) for k, v in enumerate(items)]
        return ParameterValue(type=ParameterType.PARAMETER_INTEGER_ARRAY,
                              integer_array_value=ints)
    if items and isinstance(items[0], str):
        return ParameterValue(type=ParameterType.PARAMETER_STRING_ARRAY,
                              string_array_value=[text_at(f"{where}[{k}]", s)
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
        return float_at(f"{where}.double_value", v.double_value)
    if t == ParameterType.PARAMETER_STRING:
        return str(v.string_value)
    if t == ParameterType.PARAMETER_BOOL_ARRAY:
        return [bool(b) for b in v.bool_array_value]
    if t == ParameterType.PARAMETER_INTEGER_ARRAY:
        return [int(i) for i in v.integer_array_value]
    if t == ParameterType.PARAMETER_DOUBLE_ARRAY:
        return [float_at(f"{where}.double_array_value[{k}]", d)
                for k, d in enumerate(v.double_array_value)]
    if t == ParameterType.PARAMETER_STRING_ARRAY:
        return [str(s) for s in v.string_array_value]
    raise MessageError(f"{where}.type", t, "expected NOT_SET, a bool, integer, double or string "
                       "(array) parameter; byte arrays are not used")


def plan_to_msg(plan: Plan) -> ifc.Plan:
    check_version("version", plan.version)
    msg = ifc.Plan(plan_id=text_at("plan_id", plan.plan_id),
                   planner=text_at("planner", plan.planner),
                  seed=int_at("seed", plan.seed, INT64_MIN, INT64_MAX),
                  planning_time_s=float_at("planning_time_s", plan.planning_time_s),
                  cost=float_at("cost", plan.cost), params=params_to_msg(plan.params))
    if plan.scene is not None:
        msg.has_scene = True
        msg.scene = scene_to_msg(plan.scene)
    msg.actions = [action_to_msg(a, f"actions[{k}]") for k, a in enumerate(plan.actions)]
    return msg


def plan_from_msg(msg: ifc.Plan, where: str = "") -> Plan:
    planning_time = float_at(join_path(where, "planning_time_s"), msg.planning_time_s)
    if planning_time < 0.0:
        raise MessageError(join_path(where, "planning_time_s"), planning_time, "must be >= 0")
    scene = None
    if msg.has_scene:
        scene = scene_from_msg(msg.scene, join_path(where, "scene"))
    elif msg.scene != ifc.Scene():
        raise MessageError(join_path(where, "scene"), "...",
                           "must be empty when has_scene is false")
    return Plan(
        actions=tuple(action_from_msg(a, join_path(where, f"actions[{k}]"))
                      for k, a in enumerate(msg.actions)),
        planner=msg.planner,
        params=params_from_msg(msg.params, join_path(where, "params")),
        seed=int(msg.seed),
        planning_time_s=planning_time,
        cost=float_at(join_path(where, "cost"), msg.cost),
        plan_id=msg.plan_id,
        scene=scene,
    )


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
        error_code=code_to("error", PLAN_ERROR_CODES, reply.error),
        failed_block=optional_block_to("failed_block", reply.failed_block),
        failed_field=text_at("failed_field", reply.failed_field),
        message=text_at("message", reply.message),
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
    with field_paths("", [("error", "error_code")]):
        return PlanReply(
            success=bool(msg.success),
            plan=plan,
            error=code_from("error_code", PLAN_ERROR_CODES, msg.error_code),
            failed_block=optional_block_from("failed_block", msg.failed_block),
            failed_field=msg.failed_field,
            message=msg.message,
        )
