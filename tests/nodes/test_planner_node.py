"""The planner node over DDS: plans from a detection + goal layout, serves /plan_scene,
reports bad input and survives malformed messages."""

from __future__ import annotations

import math

import pytest
from densepack_interfaces.msg import BlockPoseArray, GoalLayout, PlannerStatus
from densepack_interfaces.msg import Plan as PlanMsg
from densepack_interfaces.srv import PlanScene
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import BlockSet
from msgs_py import ros as msg_codecs
from msgs_py.tasks import PlanRequest
from nodes.common.qos import LATCHED
from nodes.common.scenes import random_scene
from nodes.goal.node import goal_layout
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.node import PlannerNode

pytestmark = pytest.mark.ros


def status_is(state, text=""):
    def check(msg):
        status = msg_codecs.planner_status_from_msg(msg)
        return status.state == state and text in status.last_error
    return check


def start(ros, scene, detection):
    ros.add(PlannerNode(context=ros.context))
    goal_pub = ros.publisher("/goal_layout", GoalLayout, LATCHED)
    det_pub = ros.publisher("/blocks/detected", BlockPoseArray)
    goal_pub.publish(msg_codecs.goal_layout_to_msg(goal_layout(scene)))
    ros.wait_for_subscribers(det_pub)
    det_pub.publish(msg_codecs.block_set_to_msg(detection))
    return det_pub


def test_plans_once_it_has_goal_and_detection_and_replans_on_request(ros):
    scene = random_scene(4, 0.1, seed=2)
    start(ros, scene, BlockSet(scene.blocks))
    msg = ros.wait_for_message("/plan", PlanMsg, timeout=30, qos=LATCHED)
    plan = msg_codecs.plan_from_msg(msg)
    assert validate_plan(plan).ok and len(plan.actions) >= 4
    markers = ros.wait_for_message("/plan/markers", MarkerArray, timeout=10, qos=LATCHED)
    assert {m.ns for m in markers.markers} >= {"plan_start", "plan_goal", "plan_actions"}
    ros.wait_for_message("/planner/status", PlannerStatus, status_is("planned"), timeout=10,
                         qos=LATCHED)
    reply = ros.call_service("/planner/replan", Trigger, timeout=10)
    assert reply.success, reply.message
    again = ros.wait_for_message("/plan", PlanMsg, lambda m: m.plan_id != plan.plan_id,
                                 timeout=30, qos=LATCHED)
    assert again.actions


def test_occluded_blocks_make_it_wait(ros):
    scene = random_scene(4, 0.1, seed=2)
    seen = BlockSet(scene.blocks[1:], missing=(scene.blocks[0].id,))
    start(ros, scene, seen)
    ros.wait_for_message("/planner/status", PlannerStatus, status_is("waiting", "occluded"),
                         timeout=20, qos=LATCHED)


def test_blocks_the_arm_covers_make_it_wait_for_a_frame_that_shows_them(ros):
    """A frame taken on the way lists the blocks under the arm as occluded, without poses:
    planning from it would lose them (a 9-slot goal with 7 blocks, refused as a failure and
    the run given up); the planner waits, and says it wants a detection (the executor looks)."""
    scene = random_scene(4, 0.1, seed=2)
    covered = BlockSet(scene.blocks[2:], occluded=(scene.blocks[0].id, scene.blocks[1].id))
    start(ros, scene, covered)
    status = msg_codecs.planner_status_from_msg(ros.wait_for_message(
        "/planner/status", PlannerStatus, status_is("waiting", "covered by the arm"),
        timeout=20, qos=LATCHED))
    assert status.wants_detection


def test_goal_naming_an_unseen_block_is_a_clear_failure(ros):
    from msgs_py import Goal, GoalSlot, Scene

    scene = random_scene(4, 0.1, seed=2)
    slots = tuple(GoalSlot(p.x, p.y, p.theta, b) for b, p in
                  zip([0, 1, 2, 42], scene.goal.slot_poses(scene.block_size), strict=True))
    ros.add(PlannerNode(context=ros.context))
    goal_pub = ros.publisher("/goal_layout", GoalLayout, LATCHED)
    det_pub = ros.publisher("/blocks/detected", BlockPoseArray)
    goal_pub.publish(msg_codecs.goal_layout_to_msg(Scene(scene.workspace, scene.block_size, (),
                                                 Goal(slots=slots))))
    ros.wait_for_subscribers(det_pub)
    det_pub.publish(msg_codecs.block_set_to_msg(BlockSet(scene.blocks)))
    msg = ros.wait_for_message("/planner/status", PlannerStatus, status_is("failed", "42"),
                               timeout=20, qos=LATCHED)
    assert "never detected" in msg.last_error


def test_blocks_that_do_not_fit_the_layout_are_a_clear_failure(ros):
    from msgs_py import BlockPose

    scene = random_scene(4, 0.1, seed=2)
    outside = (*scene.blocks[:-1], BlockPose(scene.blocks[-1].id, 5.0, 5.0, 0.0))
    start(ros, scene, BlockSet(outside))
    msg = ros.wait_for_message("/planner/status", PlannerStatus,
                               status_is("failed", "workspace"), timeout=20, qos=LATCHED)
    assert "cannot plan" in msg.last_error


def test_blocks_moving_while_it_plans_make_it_plan_again_from_where_they_stand(ros):
    """A replan request can overtake the detection it was made for; the plan must then start
    from that newer detection, not from the one planning began with."""
    scene = random_scene(25, 0.2, seed=1)  # over a second of planning: time to move a block
    det_pub = start(ros, scene, BlockSet(scene.blocks, stamp_ns=1))
    ros.wait_for_message("/planner/status", PlannerStatus, status_is("planning"), timeout=30,
                         qos=LATCHED)
    moved = _moved_to_free_space(scene)
    det_pub.publish(msg_codecs.block_set_to_msg(BlockSet(moved, stamp_ns=2)))
    msg = ros.wait_for_message("/plan", PlanMsg, timeout=120, qos=LATCHED)
    plan = msg_codecs.plan_from_msg(msg)
    assert validate_plan(plan).ok
    assert plan.scene.blocks[0].pose == moved[0].pose


def _moved_to_free_space(scene):
    """The scene's blocks with the first one moved to the free spot furthest from the rest."""
    import numpy as np

    from msgs_py import BlockPose

    ws, others = scene.workspace, np.array([[b.x, b.y] for b in scene.blocks[1:]])
    margin = scene.block_size
    xs = np.linspace(ws.x_min + margin, ws.x_max - margin, 60)
    ys = np.linspace(ws.y_min + margin, ws.y_max - margin, 60)
    grid = np.array([[x, y] for x in xs for y in ys])
    clearance = np.min(np.linalg.norm(grid[:, None] - others[None], axis=2), axis=1)
    x, y = grid[np.argmax(clearance)]
    assert clearance.max() > scene.block_size * 1.5, "no free spot in this scene"
    first = scene.blocks[0]
    return (BlockPose(first.id, float(x), float(y), first.theta), *scene.blocks[1:])


def plan_scene(ros, request: PlanScene.Request):
    return msg_codecs.plan_reply_from_msg(ros.call_service("/plan_scene", PlanScene, request,
                                                   timeout=60))


def test_plan_scene_answers_a_validated_plan_and_publishes_nothing(ros):
    scene = random_scene(4, 0.1, seed=2)
    ros.add(PlannerNode(context=ros.context))
    reply = plan_scene(ros, msg_codecs.plan_request_to_msg(PlanRequest(scene, {"seed": 5})))
    assert reply.success and reply.error == "none", reply.message
    assert reply.plan.scene == scene and reply.plan.seed == 5
    assert validate_plan(reply.plan).ok
    with pytest.raises(TimeoutError):
        ros.wait_for_message("/plan", PlanMsg, timeout=1.0, qos=LATCHED)


def test_plan_scene_refuses_a_bad_scene_naming_the_field_and_the_block(ros):
    scene = random_scene(4, 0.1, seed=2)
    ros.add(PlannerNode(context=ros.context))
    overlap = msg_codecs.plan_request_to_msg(PlanRequest(scene))
    overlap.scene.blocks[2].pose.x = overlap.scene.blocks[1].pose.x
    overlap.scene.blocks[2].pose.y = overlap.scene.blocks[1].pose.y
    reply = plan_scene(ros, overlap)
    assert not reply.success and reply.error == "invalid_scene"
    assert reply.failed_field == "scene.blocks[2]" and "overlaps" in reply.message
    assert reply.failed_block == scene.blocks[2].id

    nan = msg_codecs.plan_request_to_msg(PlanRequest(scene))
    nan.scene.goal.grid.center_x = math.nan
    reply = plan_scene(ros, nan)
    assert (reply.error, reply.failed_field) == ("invalid_scene", "scene.goal.grid.center_x")

    no_goal = msg_codecs.plan_request_to_msg(PlanRequest(scene))
    no_goal.scene.has_goal = False
    reply = plan_scene(ros, no_goal)
    assert (reply.error, reply.failed_field) == ("invalid_scene", "scene.has_goal")


def test_plan_scene_refuses_a_bad_override_naming_it(ros):
    scene = random_scene(4, 0.1, seed=2)
    ros.add(PlannerNode(context=ros.context))
    request = msg_codecs.plan_request_to_msg(PlanRequest(scene, {"seed": 1, "n_sampels": 80}))
    reply = plan_scene(ros, request)
    assert (reply.error, reply.failed_field) == ("invalid_parameter", "overrides[1]")
    assert "n_sampels" in reply.message
    request.overrides[1] = Parameter(name="budget_s", value=ParameterValue(
        type=ParameterType.PARAMETER_STRING, string_value="long"))
    reply = plan_scene(ros, request)
    assert (reply.error, reply.failed_field) == ("invalid_parameter", "overrides[1]")


def test_malformed_messages_on_every_topic_do_not_kill_the_planner(ros):
    """Each is dropped with a warning naming the topic and field; the node plans on."""
    scene = random_scene(4, 0.1, seed=2)
    ros.add(PlannerNode(context=ros.context))
    goal_pub = ros.publisher("/goal_layout", GoalLayout, LATCHED)
    det_pub = ros.publisher("/blocks/detected", BlockPoseArray)
    ros.wait_for_subscribers(det_pub)
    bad_goal = msg_codecs.goal_layout_to_msg(goal_layout(scene))
    bad_goal.goal.grid.gap = math.nan
    goal_pub.publish(bad_goal)
    ros.wait_for_message("/planner/status", PlannerStatus,
                         status_is("failed", "goal.grid.gap"), timeout=20, qos=LATCHED)
    bad_detection = msg_codecs.block_set_to_msg(BlockSet(scene.blocks))
    bad_detection.blocks[0].id = bad_detection.blocks[1].id
    det_pub.publish(bad_detection)
    det_pub.publish(BlockPoseArray(missing_ids=[-4]))
    goal_pub.publish(msg_codecs.goal_layout_to_msg(goal_layout(scene)))
    det_pub.publish(msg_codecs.block_set_to_msg(BlockSet(scene.blocks)))
    plan = msg_codecs.plan_from_msg(ros.wait_for_message("/plan", PlanMsg, timeout=30, qos=LATCHED))
    assert validate_plan(plan).ok
