"""The planner node over DDS: plans from a detection + goal layout, reports bad input."""

from __future__ import annotations

import json

import pytest
from std_msgs.msg import String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import BlockSet, Plan
from msgs_py.ros_codecs import block_set_to_markers, to_string_msg
from nodes.common.qos import LATCHED
from nodes.common.scenes import random_scene
from nodes.planner.node import PlannerNode
from nodes.planner.validator import validate_plan
from nodes.tools.goal import goal_layout

pytestmark = pytest.mark.ros


def status_is(state, text=""):
    def check(msg):
        data = json.loads(msg.data)
        return data["state"] == state and text in data["last_error"]
    return check


def start(ros, scene, detection):
    ros.add(PlannerNode(context=ros.context))
    goal_pub = ros.publisher("/goal_layout", String, LATCHED)
    det_pub = ros.publisher("/blocks/detected", MarkerArray)
    goal_pub.publish(to_string_msg(goal_layout(scene)))
    ros.wait_for_subscribers(det_pub)
    det_pub.publish(block_set_to_markers(detection))
    return det_pub


def test_plans_once_it_has_goal_and_detection_and_replans_on_request(ros):
    scene = random_scene(4, 0.1, seed=2)
    start(ros, scene, BlockSet(scene.blocks))
    msg = ros.wait_for_message("/plan", String, timeout=30, qos=LATCHED)
    plan = Plan.from_dict(json.loads(msg.data))
    assert validate_plan(plan).ok and len(plan.actions) >= 4
    markers = ros.wait_for_message("/plan/markers", MarkerArray, timeout=10, qos=LATCHED)
    assert {m.ns for m in markers.markers} >= {"plan_start", "plan_goal", "plan_actions"}
    ros.wait_for_message("/planner/status", String, status_is("planned"), timeout=10,
                         qos=LATCHED)
    reply = ros.call_service("/planner/replan", Trigger, timeout=10)
    assert reply.success, reply.message
    again = ros.wait_for_message("/plan", String,
                                 lambda m: json.loads(m.data)["plan_id"] != plan.plan_id,
                                 timeout=30, qos=LATCHED)
    assert json.loads(again.data)["actions"]


def test_occluded_blocks_make_it_wait(ros):
    scene = random_scene(4, 0.1, seed=2)
    seen = BlockSet(scene.blocks[1:], missing=(scene.blocks[0].id,))
    start(ros, scene, seen)
    ros.wait_for_message("/planner/status", String, status_is("waiting", "occluded"),
                         timeout=20, qos=LATCHED)


def test_goal_naming_an_unseen_block_is_a_clear_failure(ros):
    from msgs_py import Goal, GoalSlot, Scene

    scene = random_scene(4, 0.1, seed=2)
    slots = tuple(GoalSlot(p.x, p.y, p.theta, b) for b, p in
                  zip([0, 1, 2, 42], scene.goal.slot_poses(scene.block_size), strict=True))
    ros.add(PlannerNode(context=ros.context))
    goal_pub = ros.publisher("/goal_layout", String, LATCHED)
    det_pub = ros.publisher("/blocks/detected", MarkerArray)
    goal_pub.publish(to_string_msg(Scene(scene.workspace, scene.block_size, (),
                                         Goal(slots=slots))))
    ros.wait_for_subscribers(det_pub)
    det_pub.publish(block_set_to_markers(BlockSet(scene.blocks)))
    msg = ros.wait_for_message("/planner/status", String, status_is("failed", "42"),
                               timeout=20, qos=LATCHED)
    assert "never detected" in json.loads(msg.data)["last_error"]


def test_blocks_that_do_not_fit_the_layout_are_a_clear_failure(ros):
    from msgs_py import BlockPose

    scene = random_scene(4, 0.1, seed=2)
    outside = (*scene.blocks[:-1], BlockPose(scene.blocks[-1].id, 5.0, 5.0, 0.0))
    start(ros, scene, BlockSet(outside))
    msg = ros.wait_for_message("/planner/status", String, status_is("failed", "workspace"),
                               timeout=20, qos=LATCHED)
    assert "cannot plan" in json.loads(msg.data)["last_error"]


def test_blocks_moving_while_it_plans_make_it_plan_again_from_where_they_stand(ros):
    """A replan request can overtake the detection it was made for; the plan must then start
    from that newer detection, not from the one planning began with."""
    scene = random_scene(25, 0.2, seed=1)  # over a second of planning: time to move a block
    det_pub = start(ros, scene, BlockSet(scene.blocks, stamp_ns=1))
    ros.wait_for_message("/planner/status", String, status_is("planning"), timeout=30,
                         qos=LATCHED)
    moved = _moved_to_free_space(scene)
    det_pub.publish(block_set_to_markers(BlockSet(moved, stamp_ns=2)))
    msg = ros.wait_for_message("/plan", String, timeout=120, qos=LATCHED)
    plan = Plan.from_dict(json.loads(msg.data))
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
