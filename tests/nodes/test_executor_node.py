"""The executor node over real DDS against a fake cell (perfect arm, scripted camera)."""

from __future__ import annotations

import math

import pytest
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Float64, String
from std_srvs.srv import Trigger
from visualization_msgs.msg import MarkerArray

from msgs_py import BlockPose, BlockSet, Goal, GoalSlot, PickPlace, Plan, Pose2D, Scene
from msgs_py.ros_codecs import block_set_to_markers, executor_status_from_string, to_string_msg
from msgs_py.scene import Workspace
from nodes.common.qos import LATCHED, RELIABLE
from nodes.executor.node import ExecutorNode, tool_pose_from_msg

pytestmark = pytest.mark.ros

START = {1: Pose2D(0.55, -0.2, 0.3), 2: Pose2D(0.80, 0.2, 0.0)}
GOAL = {1: Pose2D(0.70, 0.0, 0.0), 2: Pose2D(0.7538, 0.0, 0.0)}


class FakeCell(Node):
    """Tracks setpoints perfectly; a closed gripper low over a block carries it; the camera
    publishes the blocks when triggered."""

    def __init__(self, **kwargs):
        super().__init__("fake_cell", **kwargs)
        self.blocks = dict(START)
        self.tcp = None
        self.held = None
        self.opening = 0.085
        self.tcp_pub = self.create_publisher(PoseStamped, "/tcp_pose", RELIABLE)
        self.det_pub = self.create_publisher(MarkerArray, "/blocks/detected", RELIABLE)
        self.create_subscription(PoseStamped, "/arm/cartesian_setpoint", self.on_setpoint,
                                 RELIABLE)
        self.create_subscription(Float64, "/gripper/command", self.on_gripper, RELIABLE)
        self.create_service(Trigger, "/camera/trigger", self.on_trigger)
        self.create_timer(0.01, self.publish_tcp)
        self.triggers = 0

    def publish_tcp(self):
        msg = PoseStamped()
        if self.tcp is None:
            msg.pose.position.x, msg.pose.position.y, msg.pose.position.z = 0.3, -0.55, 0.45
            msg.pose.orientation.x = 1.0  # tool down, yaw 0
        else:
            msg = self.tcp
        self.tcp_pub.publish(msg)

    def on_setpoint(self, msg):
        self.tcp = msg
        if self.held is not None:
            pose = tool_pose_from_msg(msg)
            self.blocks[self.held] = Pose2D(pose.x, pose.y, self.blocks[self.held].theta)

    def on_gripper(self, msg):
        pose = tool_pose_from_msg(self.tcp) if self.tcp else None
        if msg.data < 0.05 and pose is not None and pose.z < 0.03:
            for block, p in self.blocks.items():
                if math.hypot(p.x - pose.x, p.y - pose.y) < 0.005:
                    self.held = block
        elif msg.data > 0.05 and self.held is not None:
            goal_yaw = GOAL[self.held].theta
            p = self.blocks[self.held]
            self.blocks[self.held] = Pose2D(p.x, p.y, goal_yaw)
            self.held = None

    def on_trigger(self, request, response):
        self.triggers += 1
        stamp = self.get_clock().now().nanoseconds
        blocks = tuple(BlockPose(i, p.x, p.y, p.theta) for i, p in self.blocks.items())
        self.det_pub.publish(block_set_to_markers(BlockSet(blocks, stamp)))
        response.success, response.message = True, str(stamp)
        return response


FAST = [Parameter("speed", value=2.0), Parameter("accel", value=20.0),
        Parameter("descend_speed", value=1.0), Parameter("gripper_settle_s", value=0.05),
        Parameter("yaw_rate", value=20.0), Parameter("detection_timeout_s", value=2.0)]


def plan():
    scene = Scene(Workspace(0.45, 0.95, -0.35, 0.35), 0.0508,
                  tuple(BlockPose(i, p.x, p.y, p.theta) for i, p in START.items()),
                  Goal(slots=tuple(GoalSlot(p.x, p.y, p.theta, i) for i, p in GOAL.items())))
    return Plan((PickPlace(1, START[1], GOAL[1], 0), PickPlace(2, START[2], GOAL[2], 1)),
                plan_id="t1", scene=scene, params={"block_size": 0.0508})


def status_is(state):
    return lambda msg: executor_status_from_string(msg).state == state


def test_executor_runs_a_plan_to_a_verified_goal(ros):
    cell = ros.add(FakeCell(context=ros.context))
    ros.add(ExecutorNode(context=ros.context, parameter_overrides=FAST))
    pub = ros.publisher("/plan", String, LATCHED)
    pub.publish(to_string_msg(plan()))
    msg = ros.wait_for_message("/executor/status", String, status_is("done"), timeout=60,
                               qos=LATCHED)
    status = executor_status_from_string(msg)
    assert status.action_index == status.action_total == 2
    assert status.metrics["actions_executed"] == 2
    assert cell.blocks[1].distance_to(GOAL[1]) < 0.002
    assert cell.triggers == 3  # before the first action and after each


def test_executor_survives_malformed_input_and_stops_on_request(ros):
    ros.add(FakeCell(context=ros.context))
    node = ros.add(ExecutorNode(context=ros.context, parameter_overrides=FAST))
    ros.publisher("/plan", String, LATCHED).publish(String(data='{"version": 1, "actions": 3}'))
    ros.publisher("/blocks/detected", MarkerArray, RELIABLE).publish(MarkerArray())
    ros.wait_for_message("/executor/status", String, status_is("idle"), timeout=20, qos=LATCHED)
    answer = ros.call_service("/executor/stop", Trigger)
    assert answer.success
    ros.wait_for_message("/executor/status", String, status_is("stopped"), timeout=20,
                         qos=LATCHED)
    assert node.core.plan is None


def test_executor_refuses_a_plan_with_an_unseen_block(ros):
    ros.add(FakeCell(context=ros.context))
    ros.add(ExecutorNode(context=ros.context, parameter_overrides=FAST))
    bad = Plan((PickPlace(9, Pose2D(0.6, 0.0), Pose2D(0.7, 0.1), 0),), plan_id="bad",
               scene=plan().scene)
    ros.publisher("/plan", String, LATCHED).publish(to_string_msg(bad))
    msg = ros.wait_for_message("/executor/status", String, status_is("failed"), timeout=60,
                               qos=LATCHED)
    assert "[9]" in executor_status_from_string(msg).last_error
