"""The planner node plans every goal kind: unlabeled, retrieval and (as before) labeled."""

from __future__ import annotations

import pytest
from densepack_interfaces.msg import BlockPoseArray, GoalLayout, PlannerStatus
from densepack_interfaces.msg import Plan as PlanMsg
from rclpy.parameter import Parameter

from msgs_py import BlockSet, load_scene
from msgs_py import interface_codecs as ic
from nodes.common.paths import config_path
from nodes.common.qos import LATCHED
from nodes.common.scenes import random_scene
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.node import PlannerNode
from nodes.tools.goal import goal_layout

pytestmark = pytest.mark.ros


def plan_for(ros, scene, overrides=()):
    ros.add(PlannerNode(context=ros.context, parameter_overrides=list(overrides)))
    goal_pub = ros.publisher("/goal_layout", GoalLayout, LATCHED)
    det_pub = ros.publisher("/blocks/detected", BlockPoseArray)
    goal_pub.publish(ic.goal_layout_to_msg(goal_layout(scene)))
    ros.wait_for_subscribers(det_pub)
    det_pub.publish(ic.block_set_to_msg(BlockSet(scene.blocks)))
    msg = ros.wait_for_message("/plan", PlanMsg, timeout=60, qos=LATCHED)
    plan = ic.plan_from_msg(msg)
    assert validate_plan(plan).ok
    return plan


def test_an_unlabeled_goal_is_planned_with_pebble_graphs(ros):
    plan = plan_for(ros, random_scene(4, 0.2, seed=3, labeled=False))
    assert plan.planner in ("pebble_graphs", "assignment_pirs") and not plan.scene.goal.labeled
    status = ros.wait_for_message(
        "/planner/status", PlannerStatus, lambda m: m.state == PlannerStatus.STATE_PLANNED,
        timeout=10, qos=LATCHED)
    assert ic.planner_status_from_msg(status).metrics["hypernodes"] >= 1


def test_the_baseline_is_a_parameter_away(ros):
    plan = plan_for(ros, random_scene(4, 0.2, seed=3, labeled=False),
                    [Parameter("unlabeled.method", value="assignment")])
    assert plan.planner == "assignment_pirs"


def test_a_retrieval_goal_names_one_block_and_leaves_the_others_free(ros):
    scene = load_scene(config_path("scenes/retrieval.yaml"))
    plan = plan_for(ros, scene)
    assert plan.planner == "pebble_graphs_retrieval"
    assert plan.actions[-1].block == 0
