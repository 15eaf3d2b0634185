"""The executor node over real DDS against a fake cell (perfect arm, scripted camera) and a
fake planner: plans from /plan, the /rearrange action (goal, feedback, result, cancel while
carrying, goals rejected when sent), malformed input on every subscribed topic."""

from __future__ import annotations

import math
import time
import uuid

import pytest
from action_msgs.msg import GoalStatus
from densepack_interfaces.msg import ArmStatus, BlockPoseArray, GoalLayout, GripperStatus
from densepack_interfaces.msg import ExecutorStatus as ExecutorStatusMsg
from densepack_interfaces.msg import Plan as PlanMsg
from densepack_interfaces.msg import PlannerStatus as PlannerStatusMsg
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import Log
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import CameraInfo, JointState
from std_msgs.msg import Float64, Header
from std_srvs.srv import Trigger

from msgs_py import (
    BlockPose,
    BlockSet,
    Goal,
    GoalSlot,
    PickPlace,
    Plan,
    PlannerStatus,
    Pose2D,
    Scene,
)
from msgs_py import ros as msg_codecs
from msgs_py.ros import ns_to_stamp
from msgs_py.scene import Workspace
from nodes.common.lease import LeaseConfig
from nodes.common.lease_ros import LeaseServer
from nodes.common.qos import CAMERA, LATCHED, RELIABLE
from nodes.executor.node import ExecutorNode, tool_pose_from_msg
from tests.actions import Goals, wait_future

pytestmark = pytest.mark.ros

START = {1: Pose2D(0.55, -0.2, 0.3), 2: Pose2D(0.80, 0.2, 0.0)}
GOAL = {1: Pose2D(0.70, 0.0, 0.0), 2: Pose2D(0.7538, 0.0, 0.0)}
WORKSPACE = Workspace(0.45, 0.95, -0.35, 0.35)


class FakeCell(Node):
    """Tracks setpoints perfectly (the arm node's /arm/tcp_pose); a closed gripper low over a
    block carries it; asked for a frame (the sim's /sim/render_request), the camera takes one
    (camera_info) and the detector publishes the blocks."""

    def __init__(self, leases: bool = False, **kwargs):
        super().__init__("fake_cell", **kwargs)
        self.blocks = dict(START)
        self.tcp = None
        self.held = None
        self.tcp_pub = self.create_publisher(PoseStamped, "/arm/tcp_pose", RELIABLE)
        self.det_pub = self.create_publisher(BlockPoseArray, "/blocks/detected", RELIABLE)
        self.info_pub = self.create_publisher(CameraInfo, "/camera/camera_info", CAMERA)
        if leases:  # as the arm and gripper nodes take commands: one commander at a time
            self.arm_lease = LeaseServer(self, "arm", "cartesian_setpoint", PoseStamped,
                                         self.on_setpoint, LeaseConfig())
            self.gripper_lease = LeaseServer(self, "gripper", "command", Float64,
                                             self.on_gripper, LeaseConfig())
        else:
            self.create_subscription(PoseStamped, "/arm/cartesian_setpoint", self.on_setpoint,
                                     RELIABLE)
            self.create_subscription(Float64, "/gripper/command", self.on_gripper, RELIABLE)
        self.create_subscription(Header, "/sim/render_request", self.on_render_request, RELIABLE)
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

    def on_render_request(self, msg):
        self.triggers += 1
        stamp = self.get_clock().now().nanoseconds
        info = CameraInfo()
        info.header.stamp = ns_to_stamp(stamp)
        self.info_pub.publish(info)
        blocks = tuple(BlockPose(i, p.x, p.y, p.theta) for i, p in self.blocks.items())
        self.det_pub.publish(msg_codecs.block_set_to_msg(BlockSet(blocks, stamp)))


class FakePlanner(Node):
    """Answers every goal layout on /goal_layout with one pick-and-place per block, from where
    the fake cell's blocks stand to their slots (the scene carries the layout, as the real
    planner's plans do)."""

    def __init__(self, cell: FakeCell, **kwargs):
        super().__init__("fake_planner", **kwargs)
        self.cell = cell
        self.layouts: list[Scene] = []
        self.plan_pub = self.create_publisher(PlanMsg, "/plan", LATCHED)
        self.status_pub = self.create_publisher(PlannerStatusMsg, "/planner/status", LATCHED)
        self.create_subscription(GoalLayout, "/goal_layout", self.on_goal, LATCHED)
        self.create_service(Trigger, "/planner/replan", lambda req, res: res)

    def on_goal(self, msg):
        layout = msg_codecs.goal_layout_from_msg(msg)
        self.layouts.append(layout)
        scene = layout.with_blocks(tuple(BlockPose(i, p.x, p.y, p.theta)
                                         for i, p in self.cell.blocks.items()))
        actions = tuple(PickPlace(b, scene.block(b).pose, pose, 0)
                        for b, pose in sorted(scene.goal_assignment().items()))
        self.plan_pub.publish(msg_codecs.plan_to_msg(Plan(actions, plan_id=uuid.uuid4().hex[:12],
                                                  scene=scene, params={"block_size": 0.0508})))


FAST = [Parameter("speed", value=2.0), Parameter("accel", value=20.0),
        Parameter("descend_speed", value=1.0), Parameter("gripper_settle_s", value=0.05),
        Parameter("yaw_rate", value=20.0), Parameter("detection_timeout_s", value=2.0),
        Parameter("camera_check", value=False)]  # unit-tested; the fake cell is exact


def layout(goal: dict[int, Pose2D] = GOAL, workspace: Workspace = WORKSPACE) -> Scene:
    return Scene(workspace, 0.0508, (),
                 Goal(slots=tuple(GoalSlot(p.x, p.y, p.theta, i) for i, p in goal.items())))


def plan():
    scene = layout().with_blocks(tuple(BlockPose(i, p.x, p.y, p.theta)
                                       for i, p in START.items()))
    return Plan((PickPlace(1, START[1], GOAL[1], 0), PickPlace(2, START[2], GOAL[2], 1)),
                plan_id="t1", scene=scene, params={"block_size": 0.0508})


def status_is(state):
    return lambda msg: msg_codecs.executor_status_from_msg(msg).state == state


def wait_status(ros, state, timeout=60):  # a bound on a hang (a run takes about 6 s)
    msg = ros.wait_for_message("/executor/status", ExecutorStatusMsg, status_is(state),
                               timeout=timeout, qos=LATCHED)
    return msg_codecs.executor_status_from_msg(msg)


def test_executor_runs_a_plan_to_a_verified_goal(ros):
    cell = ros.add(FakeCell(context=ros.context))
    ros.add(ExecutorNode(context=ros.context, parameter_overrides=FAST))
    pub = ros.publisher("/plan", PlanMsg, LATCHED)
    pub.publish(msg_codecs.plan_to_msg(plan()))
    status = wait_status(ros, "done")
    assert status.action_index == status.action_total == 2
    assert status.metrics["actions_executed"] == 2
    assert cell.blocks[1].distance_to(GOAL[1]) < 0.002
    assert cell.triggers == 3  # before the first action and after each


def wait_until(condition, what: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"{what} not within {timeout} s"
        time.sleep(0.01)


def test_the_executor_holds_the_arm_and_the_fingers_through_a_run_and_gives_them_back(ros):
    cell = ros.add(FakeCell(context=ros.context, leases=True))
    executor = ros.add(ExecutorNode(context=ros.context, parameter_overrides=FAST))
    stray = ros.publisher("/gripper/command", Float64)
    ros.publisher("/plan", PlanMsg, LATCHED).publish(msg_codecs.plan_to_msg(plan()))
    wait_until(lambda: cell.gripper_lease._in_force() is not None, "the gripper's lease")
    assert cell.arm_lease.status().holder == "/executor"
    wait_until(lambda: executor.gripper_control.keeper.connected, "the executor switched")
    stray.publish(Float64(data=0.0))  # another program closes the fingers mid-run
    wait_until(lambda: cell.gripper_lease.status().refused_commands == 1, "the refusal")
    assert cell.gripper_lease.status().refused_commanders == ("/harness_probe",)
    status = wait_status(ros, "done")
    assert status.metrics["actions_executed"] == 2 and cell.held is None
    assert cell.blocks[2].distance_to(GOAL[2]) < 0.002
    wait_until(lambda: cell.arm_lease.status().holder == cell.gripper_lease.status().holder
               == "", "both given back")
    assert cell.arm_lease.status().refused_commanders == ()  # nobody else on the arm


def rosout(ros) -> list[str]:
    """Every log line of the nodes from now on."""
    logged: list[str] = []
    ros.probe.create_subscription(Log, "/rosout", lambda m: logged.append(m.msg), RELIABLE)
    time.sleep(0.5)
    return logged


def wait_logged(logged: list[str], texts, timeout=10.0) -> None:
    deadline = time.monotonic() + timeout
    while not all(any(text in line for line in logged) for text in texts):
        assert time.monotonic() < deadline, [t for t in texts
                                             if not any(t in line for line in logged)]
        time.sleep(0.05)


def test_malformed_messages_on_every_subscribed_topic_do_not_kill_the_executor(ros):
    ros.add(FakeCell(context=ros.context))
    node = ros.add(ExecutorNode(context=ros.context, parameter_overrides=FAST))
    logged = rosout(ros)
    bad_plan = msg_codecs.plan_to_msg(plan())
    bad_plan.actions[1].type = 7
    ros.publisher("/plan", PlanMsg, LATCHED).publish(bad_plan)
    detections = ros.publisher("/blocks/detected", BlockPoseArray, RELIABLE)
    ros.wait_for_subscribers(detections)
    detections.publish(BlockPoseArray(missing_ids=[-1]))
    bad_status = msg_codecs.planner_status_to_msg(PlannerStatus("failed"))
    bad_status.state = 42
    ros.publisher("/planner/status", PlannerStatusMsg, LATCHED).publish(bad_status)
    tcp = ros.publisher("/arm/tcp_pose", PoseStamped, RELIABLE)
    ros.wait_for_subscribers(tcp)
    nan_pose = PoseStamped()
    nan_pose.pose.orientation.w = math.nan
    tcp.publish(nan_pose)
    arm = ros.publisher("/arm/status", ArmStatus, LATCHED)
    ros.wait_for_subscribers(arm)
    arm.publish(ArmStatus(state=99))
    gripper = ros.publisher("/gripper/status", GripperStatus, RELIABLE)
    ros.wait_for_subscribers(gripper)
    gripper.publish(GripperStatus(gap=math.inf))
    joints = ros.publisher("/joint_states", JointState, RELIABLE)
    ros.wait_for_subscribers(joints)
    joints.publish(JointState(name=["shoulder_pan_joint", "elbow_joint"], position=[0.1]))
    wait_logged(logged, ["malformed /plan: actions[1].type", "malformed /blocks/detected: "
                         "missing_ids[0]", "malformed /planner/status: state",
                         "malformed /arm/tcp_pose: pose.orientation.w",
                         "malformed /arm/status: state", "malformed /gripper/status: gap",
                         "malformed /joint_states: position"])
    wait_status(ros, "idle", timeout=20)
    answer = ros.call_service("/executor/stop", Trigger)
    assert answer.success
    wait_status(ros, "stopped", timeout=20)
    assert node.core.plan is None


def test_executor_refuses_a_plan_with_an_unseen_block(ros):
    ros.add(FakeCell(context=ros.context))  # no planner: no replan (each would look again)
    ros.add(ExecutorNode(context=ros.context, parameter_overrides=[
        *FAST, Parameter("max_replans", value=0)]))
    bad = Plan((PickPlace(9, Pose2D(0.6, 0.0), Pose2D(0.7, 0.1), 0),), plan_id="bad",
               scene=plan().scene)
    ros.publisher("/plan", PlanMsg, LATCHED).publish(msg_codecs.plan_to_msg(bad))
    assert "[9]" in wait_status(ros, "failed").last_error


# --- the /rearrange action ----------------------------------------------------------------------
def action_cell(ros):
    """Fake cell, fake planner and the executor, waiting until the executor has seen the
    blocks (its idle look), as a client should before sending a goal."""
    cell = ros.add(FakeCell(context=ros.context))
    planner = ros.add(FakePlanner(cell, context=ros.context))
    node = ros.add(ExecutorNode(context=ros.context, parameter_overrides=[
        *FAST, Parameter("auto_start", value=False)]))
    ros.wait_for_message("/blocks/detected", BlockPoseArray, timeout=30)
    return cell, planner, node, Goals(ros)


def test_a_rearrange_goal_runs_with_feedback_to_a_verified_result(ros):
    cell, planner, _node, goals = action_cell(ros)
    handle = goals.send(msg_codecs.rearrange_goal_to_msg(layout()))
    assert handle.accepted
    status, result = goals.result(handle, timeout=90)
    assert status == GoalStatus.STATUS_SUCCEEDED
    assert result.outcome == "succeeded" and "verified" in result.detail
    assert [e.block_id for e in result.block_errors] == [1, 2]
    assert all(e.found and e.position_error_m < 0.002 for e in result.block_errors)
    assert result.metrics["actions_executed"] == 2 and result.metrics["corrections"] == 0
    assert planner.layouts == [layout()]  # the goal reached the planner as a layout
    steps = [(f.state, f.action_index, f.action_total, f.block) for f in goals.feedback]
    assert ("running", 1, 2, 1) in steps and ("running", 2, 2, 2) in steps
    assert steps.index(("running", 1, 2, 1)) < steps.index(("running", 2, 2, 2))
    assert goals.feedback[0].state == "idle" and "plan" in goals.feedback[0].detail
    assert cell.blocks[2].distance_to(GOAL[2]) < 0.002


def test_cancel_while_carrying_stops_safely_and_a_second_goal_meanwhile_is_rejected(ros):
    cell, _planner, _node, goals = action_cell(ros)
    handle = goals.send(msg_codecs.rearrange_goal_to_msg(layout()))
    assert handle.accepted
    goals.wait_feedback(lambda f: f.state == "running", timeout=60)
    assert not goals.send(msg_codecs.rearrange_goal_to_msg(layout())).accepted  # not preempted
    deadline = time.monotonic() + 60
    while cell.held is None:
        assert time.monotonic() < deadline, "the arm never carried a block"
        time.sleep(0.005)
    carried = cell.held
    cancel = wait_future(handle.cancel_goal_async(), "cancel")
    assert len(cancel.goals_canceling) == 1
    status, result = goals.result(handle, timeout=60)
    assert status == GoalStatus.STATUS_CANCELED
    assert result.outcome == "canceled" and "stopped safely" in result.detail
    stopped = wait_status(ros, "stopped", timeout=10)
    assert stopped.action_index <= 1 and carried == 1
    assert result.metrics["actions_executed"] < 2


def test_bad_goals_are_rejected_when_sent_with_the_reason_logged(ros):
    _cell, planner, _node, goals = action_cell(ros)
    logged = rosout(ros)
    nan = msg_codecs.rearrange_goal_to_msg(layout())
    nan.layout.goal.slots[0].pose.y = math.nan
    overlap = msg_codecs.rearrange_goal_to_msg(layout())
    overlap.layout.goal.slots[1].pose.x = 0.72
    duplicate = msg_codecs.rearrange_goal_to_msg(layout())
    duplicate.layout.goal.slots[1].block_id = 1
    unknown = msg_codecs.rearrange_goal_to_msg(layout({1: GOAL[1], 9: GOAL[2]}))
    far = msg_codecs.rearrange_goal_to_msg(layout(workspace=Workspace(0.45, 1.30, -0.35, 0.35)))
    expected = {"layout.goal.slots[0].pose.y": nan, "overlaps": overlap,
                "layout.goal.slots[1].block_id: duplicate": duplicate,
                "layout.goal.slots[1].block_id: unknown block": unknown,
                "beyond its reach": far}
    for text, goal in expected.items():
        assert not goals.send(goal).accepted, text
    wait_logged(logged, [f"goal rejected: {text}" if text.startswith("layout") else text
                         for text in expected])
    assert planner.layouts == []  # none of them reached the planner
