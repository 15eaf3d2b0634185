"""densepack_interfaces across two processes over DDS: a topic, PlanScene, and Rearrange.

The other process is ``tests/tools/interfaces_peer.py``; both run on this session's private
ROS_DOMAIN_ID with discovery kept to this host (tests/conftest.py). Built by pip from the
ros-jazzy-* wheels, the package must publish, serve and run an action with feedback, result and
cancel: a new wheel release that breaks the generated code or its typesupport fails here.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import threading
import time

import pytest
from action_msgs.msg import GoalStatus
from densepack_interfaces.msg import Plan as PlanMsg
from densepack_interfaces.srv import PlanScene

from msgs_py import BlockPose, Goal, GoalSlot, PickPlace, Plan, Pose2D, Push, Scene, Workspace
from msgs_py import ros as msg_codecs
from msgs_py.tasks import PlanRequest
from nodes.common.qos import LATCHED, RELIABLE
from tests.actions import Goals, wait_future
from tests.helpers import REPO

pytestmark = pytest.mark.ros

PREFIX = "/interfaces_test"
TIMEOUT = 30.0  # a loaded 2-core machine: discovery alone can take seconds


def a_scene() -> Scene:
    blocks = (BlockPose(3, 0.55, -0.2, 0.4), BlockPose(7, 0.65, -0.2, -0.1))
    goal = Goal(slots=(GoalSlot(0.8, 0.1, 0.0, 3), GoalSlot(0.8, 0.2, 0.0, 7)), yaw_exact=True)
    return Scene(Workspace(0.45, 0.95, -0.35, 0.35), 0.0508, blocks, goal)


@pytest.fixture(scope="module")
def peer():
    proc = subprocess.Popen([sys.executable, "-m", "tests.tools.interfaces_peer"], cwd=REPO,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"), stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    lines: list[str] = []
    ready = threading.Event()

    def read() -> None:
        for line in proc.stdout:
            lines.append(line)
            if line.startswith("READY"):
                ready.set()

    threading.Thread(target=read, daemon=True).start()
    try:
        if not ready.wait(60.0):
            raise AssertionError("peer never got ready:\n" + "".join(lines))
        yield lines
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=15.0)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def test_the_peer_runs_on_this_sessions_private_loopback_domain(peer):
    words = next(line for line in peer if line.startswith("READY")).split()
    assert words[1:] == [os.environ["ROS_DOMAIN_ID"], "LOCALHOST"]
    assert os.environ["ROS_DOMAIN_ID"] != "0"


def test_a_plan_survives_a_topic_round_trip_through_the_other_process(ros, peer):
    plan = Plan(
        (PickPlace(3, Pose2D(0.55, -0.2, 0.4), Pose2D(0.8, 0.1, 0.0), 1),
         Push.between(7, Pose2D(0.65, -0.2, -0.1), Pose2D(0.65, 0.05, -0.1))),
        planner="pirs", params={"block_size": 0.0508, "n_samples": 80, "shortcut": True,
                                "unlabeled.method": "pebble_graphs", "push_lengths": [0.5, 1.0]},
        seed=7, planning_time_s=0.36, cost=2.5 + math.pi, plan_id="roundtrip", scene=a_scene())
    pub = ros.publisher(f"{PREFIX}/plan", PlanMsg, RELIABLE)
    ros.wait_for_subscribers(pub, timeout=TIMEOUT)
    pub.publish(msg_codecs.plan_to_msg(plan))
    echo = ros.wait_for_message(f"{PREFIX}/plan_echo", PlanMsg,
                                lambda m: m.plan_id == "roundtrip", timeout=TIMEOUT, qos=LATCHED)
    assert msg_codecs.plan_from_msg(echo) == plan


def test_plan_scene_answers_a_plan_or_a_refusal_naming_the_field(ros, peer):
    request = PlanRequest(a_scene(), {"budget_s": 5.0, "seed": 3})
    response = ros.call_service(f"{PREFIX}/plan_scene", PlanScene,
                                msg_codecs.plan_request_to_msg(request), timeout=TIMEOUT)
    reply = msg_codecs.plan_reply_from_msg(response)
    assert reply.success and reply.error == "none"
    assert reply.plan.scene == request.scene and reply.plan.params == request.overrides
    assert reply.plan.actions[0].block == 3

    bad = msg_codecs.plan_request_to_msg(request)
    bad.scene.blocks[1].pose.x = 0.56  # overlaps block 3
    refusal = msg_codecs.plan_reply_from_msg(
        ros.call_service(f"{PREFIX}/plan_scene", PlanScene, bad, timeout=TIMEOUT))
    assert not refusal.success and refusal.error == "invalid_scene"
    assert refusal.failed_field == "scene.blocks[1]" and "overlaps" in refusal.message


def test_rearrange_runs_with_feedback_and_result(ros, peer):
    goals = Goals(ros, f"{PREFIX}/rearrange", TIMEOUT)
    handle = goals.send(msg_codecs.rearrange_goal_to_msg(a_scene().with_blocks(())))
    assert handle.accepted
    answer = wait_future(handle.get_result_async(), "result")
    assert answer.status == GoalStatus.STATUS_SUCCEEDED
    result = msg_codecs.rearrange_result_from_msg(answer.result)
    assert result.outcome == "succeeded" and result.metrics == {"actions_executed": 5.0}
    assert [e.block_id for e in result.block_errors] == [3, 7]
    assert [(f.action_index, f.action_total) for f in goals.feedback] == [(k, 5)
                                                                          for k in range(1, 6)]
    assert {f.state for f in goals.feedback} == {"running"}
    assert goals.feedback[-1].corrections == 1 and goals.feedback[0].block == 0


def test_rearrange_is_canceled_after_its_first_feedback(ros, peer):
    goals = Goals(ros, f"{PREFIX}/rearrange", TIMEOUT)
    handle = goals.send(msg_codecs.rearrange_goal_to_msg(a_scene().with_blocks(())))
    assert handle.accepted
    deadline = time.monotonic() + TIMEOUT
    while not goals.feedback:
        assert time.monotonic() < deadline, "no feedback before the cancel"
        time.sleep(0.01)
    cancel = wait_future(handle.cancel_goal_async(), "cancel")
    assert len(cancel.goals_canceling) == 1
    answer = wait_future(handle.get_result_async(), "result")
    assert answer.status == GoalStatus.STATUS_CANCELED
    result = msg_codecs.rearrange_result_from_msg(answer.result)
    assert result.outcome == "canceled" and "stopped safely" in result.detail
    assert len(goals.feedback) < 5


def test_a_malformed_rearrange_goal_is_rejected_when_sent(ros, peer):
    goal = msg_codecs.rearrange_goal_to_msg(a_scene().with_blocks(()))
    goal.layout.goal.slots[1].pose.x = math.nan
    assert not Goals(ros, f"{PREFIX}/rearrange", TIMEOUT).send(goal).accepted
