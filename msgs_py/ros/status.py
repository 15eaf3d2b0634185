"""Codecs of the nodes' status: figures (``Metric[]``), executor, planner, gripper and arm (with
the lease fields the last two share)."""

from __future__ import annotations

import math
from collections.abc import Sequence

from densepack_interfaces import msg as ifc

from msgs_py.errors import MessageError
from msgs_py.ros.fields import (
    UINT32_MAX,
    check_version,
    code_from,
    code_to,
    constants_of,
    float_at,
    int_at,
    optional_block_from,
    optional_block_to,
    text_at,
)
from msgs_py.ros.stamps import ns_to_stamp, stamp_to_ns
from msgs_py.status import (
    ARM_STATES,
    EXECUTOR_STATES,
    GRIPPER_OBJECT_STATES,
    PLANNER_STATES,
    ArmStatus,
    ExecutorStatus,
    GripperStatus,
    PlannerStatus,
)

EXECUTOR_STATE_CODES = constants_of(ifc.ExecutorStatus, "STATE_", EXECUTOR_STATES)
PLANNER_STATE_CODES = constants_of(ifc.PlannerStatus, "STATE_", PLANNER_STATES)
GRIPPER_OBJECT_CODES = constants_of(ifc.GripperStatus, "OBJECT_", GRIPPER_OBJECT_STATES)
ARM_STATE_CODES = constants_of(ifc.ArmStatus, "STATE_", ARM_STATES)


def metrics_to_msg(metrics: dict[str, float], where: str = "metrics") -> list[ifc.Metric]:
    return [ifc.Metric(name=text_at(where, name), value=float_at(f"{where}.{name}", value))
            for name, value in metrics.items()]


def metrics_from_msg(msgs: Sequence[ifc.Metric], where: str = "metrics") -> dict[str, float]:
    out: dict[str, float] = {}
    for k, m in enumerate(msgs):
        if m.name in out:
            raise MessageError(f"{where}[{k}].name", m.name, "duplicate metric name")
        out[m.name] = float_at(f"{where}[{k}].value", m.value)
    return out


def executor_status_to_msg(status: ExecutorStatus, stamp_ns: int = 0) -> ifc.ExecutorStatus:
    check_version("version", status.version)
    return ifc.ExecutorStatus(
        stamp=ns_to_stamp(stamp_ns),
        state=code_to("state", EXECUTOR_STATE_CODES, status.state),
        plan_id=text_at("plan_id", status.plan_id),
        action_index=int_at("action_index", status.action_index, 0, UINT32_MAX),
        action_total=int_at("action_total", status.action_total, 0, UINT32_MAX),
        block=optional_block_to("block", status.block),
        last_error=text_at("last_error", status.last_error),
        detail=text_at("detail", status.detail),
        metrics=metrics_to_msg(status.metrics),
    )


def executor_status_from_msg(msg: ifc.ExecutorStatus) -> ExecutorStatus:
    return ExecutorStatus(
        state=code_from("state", EXECUTOR_STATE_CODES, msg.state),
        plan_id=msg.plan_id,
        action_index=int(msg.action_index),
        action_total=int(msg.action_total),
        block=optional_block_from("block", msg.block),
        last_error=msg.last_error,
        detail=msg.detail,
        metrics=metrics_from_msg(msg.metrics),
    )


def planner_status_to_msg(status: PlannerStatus, stamp_ns: int = 0) -> ifc.PlannerStatus:
    check_version("version", status.version)
    return ifc.PlannerStatus(
        stamp=ns_to_stamp(stamp_ns),
        state=code_to("state", PLANNER_STATE_CODES, status.state),
        plan_id=text_at("plan_id", status.plan_id),
        n_actions=int_at("n_actions", status.n_actions, 0, UINT32_MAX),
        planning_time_s=float_at("planning_time_s", status.planning_time_s),
        last_error=text_at("last_error", status.last_error),
        failed_block=optional_block_to("failed_block", status.failed_block),
        metrics=metrics_to_msg(status.metrics),
    )


def planner_status_from_msg(msg: ifc.PlannerStatus) -> PlannerStatus:
    return PlannerStatus(
        state=code_from("state", PLANNER_STATE_CODES, msg.state),
        plan_id=msg.plan_id,
        n_actions=int(msg.n_actions),
        planning_time_s=float_at("planning_time_s", msg.planning_time_s),
        last_error=msg.last_error,
        failed_block=optional_block_from("failed_block", msg.failed_block),
        metrics=metrics_from_msg(msg.metrics),
    )


def lease_to_msg(status: ArmStatus | GripperStatus) -> dict[str, object]:
    """The lease fields of the arm's and the gripper's status, checked for the wire."""
    return dict(
        lease_holder=text_at("lease_holder", status.lease_holder),
        refused_commands=int_at("refused_commands", status.refused_commands, 0, UINT32_MAX),
        refused_commanders=[text_at(f"refused_commanders[{k}]", name)
                            for k, name in enumerate(status.refused_commanders)])


def lease_from_msg(msg: ifc.ArmStatus | ifc.GripperStatus) -> dict[str, object]:
    return dict(lease_holder=str(msg.lease_holder),
                refused_commands=int(msg.refused_commands),
                refused_commanders=tuple(str(name) for name in msg.refused_commanders))


def gripper_status_to_msg(status: GripperStatus) -> ifc.GripperStatus:
    msg = ifc.GripperStatus(gap=float_at("gap", status.gap),
                            requested_gap=float_at("requested_gap", status.requested_gap),
                            object=code_to("object", GRIPPER_OBJECT_CODES, status.object),
                            **lease_to_msg(status))
    msg.header.stamp = ns_to_stamp(status.stamp_ns, "stamp_ns")
    return msg


def gripper_status_from_msg(msg: ifc.GripperStatus) -> GripperStatus:
    return GripperStatus(float_at("gap", msg.gap), float_at("requested_gap", msg.requested_gap),
                         code_from("object", GRIPPER_OBJECT_CODES, msg.object),
                         stamp_to_ns(msg.header.stamp), **lease_from_msg(msg))


def arm_status_to_msg(status: ArmStatus) -> ifc.ArmStatus:
    msg = ifc.ArmStatus(
        state=code_to("state", ARM_STATE_CODES, status.state),
        reason=text_at("reason", status.reason),
        speed_scaling=float_at("speed_scaling", status.speed_scaling),
        program_running=bool(status.program_running),
        safety_mode=int_at("safety_mode", status.safety_mode, 0, 255),
        robot_mode=int_at("robot_mode", status.robot_mode, -128, 127),
        stream_time=math.nan if status.stream_time is None else float(status.stream_time),
        rejected_setpoints=int_at("rejected_setpoints", status.rejected_setpoints, 0, UINT32_MAX),
        **lease_to_msg(status))
    msg.header.stamp = ns_to_stamp(status.stamp_ns, "stamp_ns")
    return msg


def arm_status_from_msg(msg: ifc.ArmStatus) -> ArmStatus:
    stream = float(msg.stream_time)
    if math.isinf(stream):
        raise MessageError("stream_time", stream, "must be finite, or NaN for no stream")
    return ArmStatus(
        code_from("state", ARM_STATE_CODES, msg.state), str(msg.reason),
        float_at("speed_scaling", msg.speed_scaling), bool(msg.program_running),
        int(msg.safety_mode), int(msg.robot_mode), None if math.isnan(stream) else stream,
        int(msg.rejected_setpoints), stamp_to_ns(msg.header.stamp), **lease_from_msg(msg))
