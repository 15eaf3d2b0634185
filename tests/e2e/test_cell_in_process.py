"""End to end through the /rearrange action: sim, detector, planner and executor in one
process, over DDS, driven as densepack-run drives them.

A seeded 4-block scene: the goal is canceled while the arm carries a block (a safe stop,
result CANCELED), sent again, and must then end with every block within 3 mm / 2 degrees of
its 2x2 goal by the simulator's ground truth, none lost, no unintended contact.
"""

from __future__ import annotations

import pytest
from action_msgs.msg import GoalStatus
from densepack_interfaces.msg import BlockPoseArray, ExecutorStatus, GripperStatus, SimEvents
from geometry_msgs.msg import PoseStamped

from msgs_py import ros as msg_codecs
from msgs_py import save_scene
from nodes.common.qos import LATCHED
from nodes.goal.node import goal_layout
from nodes.sim.layout import random_sim_scene
from tests.actions import Goals, wait_future

from .cell import assert_every_block_at_its_goal, start_cell

pytestmark = [pytest.mark.slow, pytest.mark.ros]


def test_four_blocks_reach_their_grid_through_the_action_after_a_cancel(ros, tmp_path):
    scene = random_sim_scene(4, 0.08, seed=3)
    scene_file = save_scene(scene, tmp_path / "four.yaml")
    start_cell(ros, scene_file, action=True)
    ros.wait_for_message("/blocks/detected", BlockPoseArray, timeout=120)
    goals = Goals(ros, timeout=60)
    goal = msg_codecs.rearrange_goal_to_msg(goal_layout(scene))

    first = goals.send(goal)
    assert first.accepted
    goals.wait_feedback(lambda f: f.state == "running", timeout=300)
    ros.wait_for_message("/gripper/status", GripperStatus,
                         lambda m: m.object == GripperStatus.OBJECT_STOPPED_CLOSING, timeout=120)
    ros.wait_for_message("/arm/tcp_pose", PoseStamped, lambda m: m.pose.position.z > 0.05,
                         timeout=60)  # lifting it: carrying
    wait_future(first.cancel_goal_async(), "cancel")
    status, canceled = goals.result(first, timeout=180)
    assert status == GoalStatus.STATUS_CANCELED, canceled.detail
    assert canceled.outcome == "canceled"
    ros.wait_for_message("/executor/status", ExecutorStatus,
                         lambda m: m.state == ExecutorStatus.STATE_STOPPED, timeout=30,
                         qos=LATCHED)

    again = goals.send(goal)
    assert again.accepted
    status, result = goals.result(again, timeout=900)
    assert status == GoalStatus.STATUS_SUCCEEDED, result.detail
    assert len(result.block_errors) == 4 and all(e.found for e in result.block_errors)
    assert result.metrics["actions_executed"] >= 4

    assert_every_block_at_its_goal(ros, scene, 4)
    events_msg = ros.wait_for_message("/sim/events", SimEvents, timeout=30, qos=LATCHED)
    events = msg_codecs.sim_events_from_msg(events_msg)
    assert events.blocks_lost == 0
    assert events.unintended_contacts == 0, events.to_dict()["events"]
