"""One dispatch table for the ``densepack_interfaces`` codecs: ``to_msg`` and ``from_msg``
find a record's encoder or a message's decoder by type."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from densepack_interfaces import msg as ifc
from densepack_interfaces.action import Rearrange
from densepack_interfaces.srv import PlanScene

from msgs_py.actions import PickPlace, Plan, Push
from msgs_py.detection import BlockSet
from msgs_py.goal import Goal, GridSpec
from msgs_py.placement import Placement
from msgs_py.poses import BlockPose, Pose2D
from msgs_py.ros.plan import (
    action_from_msg,
    action_to_msg,
    plan_from_msg,
    plan_reply_from_msg,
    plan_reply_to_msg,
    plan_request_from_msg,
    plan_request_to_msg,
    plan_to_msg,
)
from msgs_py.ros.rearrange import (
    block_error_from_msg,
    block_error_to_msg,
    rearrange_feedback_from_msg,
    rearrange_feedback_to_msg,
    rearrange_goal_from_msg,
    rearrange_result_from_msg,
    rearrange_result_to_msg,
)
from msgs_py.ros.scene import (
    block_pose_from_msg,
    block_pose_to_msg,
    block_set_from_msg,
    block_set_to_msg,
    goal_from_msg,
    goal_layout_from_msg,
    goal_to_msg,
    grid_from_msg,
    grid_to_msg,
    pose_from_msg,
    pose_to_msg,
    scene_from_msg,
    scene_to_msg,
    workspace_from_msg,
    workspace_to_msg,
)
from msgs_py.ros.sim import (
    disturbance_from_msg,
    disturbance_to_msg,
    placement_from_msg,
    placement_to_msg,
    sim_event_from_msg,
    sim_event_to_msg,
    sim_events_from_msg,
    sim_events_to_msg,
    sim_fault_from_msg,
    sim_fault_to_msg,
)
from msgs_py.ros.status import (
    arm_status_from_msg,
    arm_status_to_msg,
    executor_status_from_msg,
    executor_status_to_msg,
    gripper_status_from_msg,
    gripper_status_to_msg,
    planner_status_from_msg,
    planner_status_to_msg,
)
from msgs_py.scene import Scene, Workspace
from msgs_py.sim import Disturbance, SimEvent, SimEvents, SimFault
from msgs_py.status import ArmStatus, ExecutorStatus, GripperStatus, PlannerStatus
from msgs_py.tasks import BlockError, PlanReply, PlanRequest, RearrangeFeedback, RearrangeResult

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
    ArmStatus: arm_status_to_msg,
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
    ifc.ArmStatus: arm_status_from_msg,
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

