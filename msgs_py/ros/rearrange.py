"""Codecs of the ``Rearrange`` action: its goal (a goal layout), feedback and result."""

from __future__ import annotations

from densepack_interfaces import msg as ifc
from densepack_interfaces.action import Rearrange

from msgs_py.ros.fields import (
    UINT32_MAX,
    block_id_at,
    code_from,
    code_to,
    constants_of,
    field_paths,
    float_at,
    int_at,
    optional_block_from,
    optional_block_to,
    text_at,
)
from msgs_py.ros.scene import goal_layout_from_msg, goal_layout_to_msg
from msgs_py.ros.status import EXECUTOR_STATE_CODES, metrics_from_msg, metrics_to_msg
from msgs_py.scene import Scene
from msgs_py.tasks import REARRANGE_OUTCOMES, BlockError, RearrangeFeedback, RearrangeResult

OUTCOME_CODES = constants_of(Rearrange.Result, "OUTCOME_", REARRANGE_OUTCOMES)


def rearrange_goal_to_msg(layout: Scene, stamp_ns: int = 0) -> Rearrange.Goal:
    return Rearrange.Goal(layout=goal_layout_to_msg(layout, stamp_ns))


def rearrange_goal_from_msg(msg: Rearrange.Goal) -> Scene:
    return goal_layout_from_msg(msg.layout, "layout")


def rearrange_feedback_to_msg(feedback: RearrangeFeedback) -> Rearrange.Feedback:
    return Rearrange.Feedback(
        state=code_to("state", EXECUTOR_STATE_CODES, feedback.state),
        action_index=int_at("action_index", feedback.action_index, 0, UINT32_MAX),
        action_total=int_at("action_total", feedback.action_total, 0, UINT32_MAX),
        block=optional_block_to("block", feedback.block),
        corrections=int_at("corrections", feedback.corrections, 0, UINT32_MAX),
        detail=text_at("detail", feedback.detail),
    )


def rearrange_feedback_from_msg(msg: Rearrange.Feedback) -> RearrangeFeedback:
    return RearrangeFeedback(
        state=code_from("state", EXECUTOR_STATE_CODES, msg.state),
        action_index=int(msg.action_index),
        action_total=int(msg.action_total),
        block=optional_block_from("block", msg.block),
        corrections=int(msg.corrections),
        detail=msg.detail,
    )


def block_error_to_msg(error: BlockError, where: str = "block_error") -> ifc.BlockError:
    return ifc.BlockError(block_id=block_id_at(f"{where}.block_id", error.block_id),
                         found=bool(error.found),
                         position_error_m=float_at(f"{where}.position_error_m",
                                                 error.position_error_m),
                         yaw_error_rad=float_at(f"{where}.yaw_error_rad", error.yaw_error_rad))


def block_error_from_msg(msg: ifc.BlockError, where: str = "block_error") -> BlockError:
    block = block_id_at(f"{where}.block_id", msg.block_id)
    position = float_at(f"{where}.position_error_m", msg.position_error_m)
    yaw = float_at(f"{where}.yaw_error_rad", msg.yaw_error_rad)
    with field_paths(where):
        return BlockError(block, position, yaw, bool(msg.found))


def rearrange_result_to_msg(result: RearrangeResult) -> Rearrange.Result:
    return Rearrange.Result(
        outcome=code_to("outcome", OUTCOME_CODES, result.outcome),
        detail=text_at("detail", result.detail),
        block_errors=[block_error_to_msg(e, f"block_errors[{k}]")
                      for k, e in enumerate(result.block_errors)],
        metrics=metrics_to_msg(result.metrics),
    )


def rearrange_result_from_msg(msg: Rearrange.Result) -> RearrangeResult:
    errors = tuple(block_error_from_msg(e, f"block_errors[{k}]")
                   for k, e in enumerate(msg.block_errors))
    return RearrangeResult(
        outcome=code_from("outcome", OUTCOME_CODES, msg.outcome),
        detail=msg.detail,
        block_errors=errors,
        metrics=metrics_from_msg(msg.metrics),
    )
