"""The other process of test_interfaces_roundtrip: serves densepack_interfaces types over DDS.

* ``/interfaces_test/plan`` (Plan) in -> decoded and encoded again -> ``/interfaces_test/plan_echo``
  (latched), so both codec directions run in this process too;
* ``/interfaces_test/plan_scene`` (PlanScene): a valid scene gets a one-action plan carrying the
  request's scene and overrides; a malformed one a refusal naming the field;
* ``/interfaces_test/rearrange`` (Rearrange): a goal that does not decode is rejected; an
  accepted one gets ``STEPS`` feedback messages ``STEP_S`` apart, then a result; a cancel
  request is honoured between steps.

Prints ``READY <ROS_DOMAIN_ID> <ROS_AUTOMATIC_DISCOVERY_RANGE>`` once everything is up.
Run as ``python -m tests.tools.interfaces_peer`` from the checkout; stopped with SIGTERM.
"""

from __future__ import annotations

import os
import time

import rclpy
from densepack_interfaces.action import Rearrange
from densepack_interfaces.msg import Plan as PlanMsg
from densepack_interfaces.srv import PlanScene
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.callback_groups import ReentrantCallbackGroup
from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor

from msgs_py import MessageError, PickPlace, Plan
from msgs_py import ros as msg_codecs
from msgs_py.tasks import BlockError, PlanReply, RearrangeFeedback, RearrangeResult
from nodes.common.qos import LATCHED, RELIABLE

PREFIX = "/interfaces_test"
STEPS = 5
STEP_S = 0.3


def plan_scene(request: PlanScene.Request, _response: PlanScene.Response) -> PlanScene.Response:
    try:
        req = msg_codecs.plan_request_from_msg(request)
    except MessageError as err:
        reply = PlanReply.refused("invalid_scene", err.reason, failed_field=err.field)
    else:
        first = req.scene.blocks[0]
        target = req.scene.goal_assignment()[first.id]
        plan = Plan((PickPlace(first.id, first.pose, target),), params=req.overrides,
                    plan_id="peer-plan", scene=req.scene)
        reply = PlanReply.planned(plan)
    return msg_codecs.plan_reply_to_msg(reply)


def accept_goal(node: rclpy.node.Node, goal: Rearrange.Goal) -> GoalResponse:
    try:
        msg_codecs.rearrange_goal_from_msg(goal)
    except MessageError as err:
        node.get_logger().warning(f"goal rejected: {err}")
        return GoalResponse.REJECT
    return GoalResponse.ACCEPT


def rearrange(handle) -> Rearrange.Result:
    layout = msg_codecs.rearrange_goal_from_msg(handle.request)
    for k in range(1, STEPS + 1):
        if handle.is_cancel_requested:
            handle.canceled()
            return msg_codecs.rearrange_result_to_msg(
                RearrangeResult("canceled", f"stopped safely before action {k}"))
        handle.publish_feedback(msg_codecs.rearrange_feedback_to_msg(RearrangeFeedback(
            "running", k, STEPS, block=k - 1, corrections=k // 3, detail=f"action {k}")))
        time.sleep(STEP_S)
    handle.succeed()
    errors = tuple(BlockError(slot.id, 0.0004, 0.01) for slot in layout.goal.slots)
    return msg_codecs.rearrange_result_to_msg(RearrangeResult(
        "succeeded", "every block verified", errors, {"actions_executed": float(STEPS)}))


def main() -> None:
    rclpy.init()
    node = rclpy.create_node("interfaces_peer")
    group = ReentrantCallbackGroup()
    echo = node.create_publisher(PlanMsg, f"{PREFIX}/plan_echo", LATCHED)
    node.create_subscription(
        PlanMsg, f"{PREFIX}/plan", lambda msg: echo.publish(
            msg_codecs.plan_to_msg(msg_codecs.plan_from_msg(msg))),
        RELIABLE)
    node.create_service(PlanScene, f"{PREFIX}/plan_scene", plan_scene, callback_group=group)
    server = ActionServer(node, Rearrange, f"{PREFIX}/rearrange", execute_callback=rearrange,
                          goal_callback=lambda goal: accept_goal(node, goal),
                          cancel_callback=lambda _handle: CancelResponse.ACCEPT,
                          callback_group=group)
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(node)
    print("READY", os.environ.get("ROS_DOMAIN_ID"),
          os.environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE"), flush=True)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        server.destroy()
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
