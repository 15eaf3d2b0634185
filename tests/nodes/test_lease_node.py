"""One commander at a time, over DDS: the arm and gripper nodes spun against the drivers'
stand-in, leases taken through /arm/lease and /gripper/lease. A stray publisher on the public
topic is refused and named on the status, a second holder is refused with the holder's name,
the same holder asking again gets a new private topic, a holder that leaves the graph loses
the lease, the executor's side (LeaseClient) takes it again after an arm node restart, and its
gripper side sends a command refused before the lease was taken again once it is."""

from __future__ import annotations

import math
import time

import pytest
from densepack_interfaces.msg import ArmStatus, GripperStatus
from densepack_interfaces.srv import ControlLease
from geometry_msgs.msg import PoseStamped
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Float64

from msgs_py.ros import ns_to_stamp
from nodes.arm.node import ArmNode
from nodes.common.harness import RosHarness
from nodes.common.lease_ros import LeaseClient
from nodes.common.qos import LATCHED, RELIABLE
from nodes.common.standard_msgs import pose_stamped_msg
from nodes.common.transforms import tool_down_quaternion
from nodes.gripper.node import GripperNode
from nodes.sim.config import HOME_JOINTS
from tests.conformance.standin import DriverStandIn

pytestmark = pytest.mark.ros

FAST_GRAPH = [Parameter("lease.check_period_s", value=0.2)]
SIM_TIME = [Parameter("use_sim_time", value=True)]


def ask(ros, device: str, holder: str, release: bool = False, token: str = ""):
    return ros.call_service(f"/{device}/lease", ControlLease, ControlLease.Request(
        holder=holder, release=release, token=token))


def arm_status(ros, predicate, timeout: float = 20.0):
    return ros.wait_for_message("/arm/status", ArmStatus, predicate, timeout=timeout,
                                qos=LATCHED)


def gripper_status(ros, predicate, timeout: float = 20.0):
    return ros.wait_for_message("/gripper/status", GripperStatus, predicate, timeout=timeout)


def wait_until(condition, what: str, timeout: float = 20.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise TimeoutError(f"{what} not within {timeout} s")
        time.sleep(0.02)


def setpoint(driver, x: float = 0.6) -> PoseStamped:
    return pose_stamped_msg(ns_to_stamp(round(driver.t * 1e9)), [x, 0.1, 0.3],
                            tool_down_quaternion(0.0))


@pytest.fixture
def cell(ros):
    driver = ros.add(DriverStandIn(HOME_JOINTS, object_width=None, context=ros.context))
    ros.add(ArmNode(context=ros.context, parameter_overrides=SIM_TIME + FAST_GRAPH))
    ros.add(GripperNode(context=ros.context, parameter_overrides=SIM_TIME + FAST_GRAPH))
    arm_status(ros, lambda m: m.state == ArmStatus.STATE_READY)
    return driver


def publisher(ros, node: Node, topic: str, msg_type: type):
    pub = node.create_publisher(msg_type, topic, RELIABLE)
    ros.wait_for_subscribers(pub)
    return pub


def test_a_stray_setpoint_is_refused_and_its_publisher_named_while_a_node_holds_the_arm(
        ros, cell):
    holder = ros.add(Node("test_executor", context=ros.context))
    lease = ask(ros, "arm", "/test_executor")
    assert lease.granted and lease.holder == "/test_executor"
    assert lease.command_topic == f"/arm/lease/{lease.token}/cartesian_setpoint"
    private = publisher(ros, holder, lease.command_topic, PoseStamped)
    private.publish(setpoint(cell))  # the holder streams: the arm follows it
    arm_status(ros, lambda m: not math.isnan(m.stream_time))
    stray = ros.add(Node("stray_tool", context=ros.context))
    public = publisher(ros, stray, "/arm/cartesian_setpoint", PoseStamped)
    for _ in range(3):
        public.publish(setpoint(cell, x=0.9))
    status = arm_status(ros, lambda m: m.refused_commands == 3)
    assert status.lease_holder == "/test_executor"
    assert "/stray_tool" in status.refused_commanders
    assert "/test_executor" not in status.refused_commanders
    assert status.rejected_setpoints == 0  # refused at the gate: nothing reached the arm


def test_a_second_holder_is_refused_with_the_holders_name_and_named(ros, cell):
    ros.add(Node("test_executor", context=ros.context))  # on the graph: its lease lasts
    assert ask(ros, "arm", "/test_executor").granted
    second = ask(ros, "arm", "/other_executor")
    assert not second.granted and second.token == "" and second.command_topic == ""
    assert second.holder == "/test_executor" and "/test_executor holds" in second.message
    status = arm_status(ros, lambda m: "/other_executor" in m.refused_commanders)
    assert status.lease_holder == "/test_executor"
    back = ask(ros, "arm", "/other_executor", release=True)  # not its lease to give back
    assert not back.granted and back.holder == "/test_executor"


def test_the_same_holder_asking_again_gets_a_new_topic_and_the_old_one_is_dropped(ros, cell):
    ros.add(Node("test_executor", context=ros.context))  # on the graph: its lease lasts
    first = ask(ros, "arm", "/test_executor")
    wait_until(lambda: ros.probe.count_subscribers(first.command_topic) == 1, "old topic")
    again = ask(ros, "arm", "/test_executor")  # an executor that came back under its name
    assert again.granted and again.token != first.token
    wait_until(lambda: ros.probe.count_subscribers(again.command_topic) == 1, "new topic")
    wait_until(lambda: ros.probe.count_subscribers(first.command_topic) == 0, "old dropped")
    late = ask(ros, "arm", "/test_executor", release=True, token=first.token)
    assert not late.granted and late.holder == "/test_executor"  # the new lease stands
    given = ask(ros, "arm", "/test_executor", release=True, token=again.token)
    assert given.holder == ""
    arm_status(ros, lambda m: m.lease_holder == "")


def test_a_holder_that_leaves_the_graph_loses_the_lease_and_the_public_topic_works_again(
        ros, cell):
    with RosHarness(domain_id=ros.domain_id) as visitor:  # another process, in effect
        visitor.add(Node("visiting_executor", context=visitor.context))
        lease = visitor.call_service("/arm/lease", ControlLease, ControlLease.Request(
            holder="/visiting_executor"))
        assert lease.granted
        arm_status(ros, lambda m: m.lease_holder == "/visiting_executor")
    arm_status(ros, lambda m: m.lease_holder == "")  # it left: the arm let it go
    tool = ros.add(Node("calibration_tool", context=ros.context))
    public = publisher(ros, tool, "/arm/cartesian_setpoint", PoseStamped)
    public.publish(setpoint(cell))
    status = arm_status(ros, lambda m: not math.isnan(m.stream_time))
    assert status.refused_commands == 0


def test_the_fingers_take_only_the_holders_commands_and_name_a_stray_close(ros, cell):
    holder = ros.add(Node("test_executor", context=ros.context))
    lease = ask(ros, "gripper", "/test_executor")
    assert lease.granted and lease.command_topic == f"/gripper/lease/{lease.token}/command"
    private = publisher(ros, holder, lease.command_topic, Float64)
    private.publish(Float64(data=0.06))
    gripper_status(ros, lambda m: abs(m.requested_gap - 0.06) < 1e-6)
    stray = ros.add(Node("stray_tool", context=ros.context))
    public = publisher(ros, stray, "/gripper/command", Float64)
    public.publish(Float64(data=0.02))  # the benchmark's misfire: a stray close
    status = gripper_status(ros, lambda m: m.refused_commands == 1)
    assert status.lease_holder == "/test_executor"
    assert "/stray_tool" in status.refused_commanders
    assert abs(status.requested_gap - 0.06) < 1e-6  # the fingers never got it
    assert ask(ros, "gripper", "/test_executor", release=True, token=lease.token).holder == ""
    gripper_status(ros, lambda m: m.lease_holder == "")
    public.publish(Float64(data=0.02))  # no lease: the public topic commands the fingers
    gripper_status(ros, lambda m: abs(m.requested_gap - 0.02) < 1e-6)


def test_the_holders_side_takes_the_lease_again_after_an_arm_node_restart(ros):
    holder = ros.add(Node("test_executor", context=ros.context))
    control = LeaseClient(holder, "arm", "cartesian_setpoint", PoseStamped, retry_s=0.2)
    lines: list[str] = []

    def run_until(condition, what: str, want: bool = True) -> None:
        def step() -> bool:
            lines.extend(control.update(want))
            return condition()
        wait_until(step, what)

    for restart in range(2):
        with RosHarness(domain_id=ros.domain_id) as arm_side:
            arm_side.add(ArmNode(context=arm_side.context, parameter_overrides=FAST_GRAPH))
            run_until(lambda: control.keeper.connected, f"connected ({restart})")
            arm_status(ros, lambda m: m.lease_holder == "/test_executor")
            if restart == 1:
                run_until(lambda: not control.keeper.holds, "given back", want=False)
                arm_status(ros, lambda m: m.lease_holder == "")
        if restart == 0:  # the arm node is gone: the executor's side notices, asks again
            run_until(lambda: not control.keeper.holds, "lost")
    assert any("lost" in line for line in lines)
    assert sum("lease taken" in line for line in lines) == 2


def test_a_respawned_holder_sees_its_predecessors_lease_as_inherited_until_it_takes_it(ros, cell):
    ros.add(Node("test_executor", context=ros.context))  # the predecessor, still on the graph
    assert ask(ros, "arm", "/test_executor").granted
    arm_status(ros, lambda m: m.lease_holder == "/test_executor")
    successor = ros.add(Node("test_executor", context=ros.context))  # back under its name
    control = LeaseClient(successor, "arm", "cartesian_setpoint", PoseStamped, retry_s=0.2)
    assert control.inherited("/test_executor")
    assert not control.inherited("") and not control.inherited("/other_executor")

    def take() -> bool:
        control.update(True)
        return control.keeper.connected

    wait_until(take, "the lease taken again")
    control.update(True)
    assert not control.inherited("/test_executor")
    assert control.takes_my_commands("/test_executor")


def test_the_fingers_command_refused_before_the_lease_goes_again_once_it_is_taken(ros, cell):
    """The executor's gripper side resends its last command at the switch to a new lease: an
    open sent while the fingers answered only another holder (a gripper node that restarted
    with its lease book still naming the old one) is not lost."""
    other = ros.add(Node("other_executor", context=ros.context))  # holds the lease first
    taken = ask(ros, "gripper", "/other_executor")
    assert taken.granted
    publisher(ros, other, taken.command_topic, Float64)  # the lease is in force from here
    holder = ros.add(Node("test_executor", context=ros.context))
    control = LeaseClient(holder, "gripper", "command", Float64, retry_s=0.2,
                          resend_s=math.inf)
    ros.wait_for_subscribers(control.public)
    control.publish(Float64(data=0.06))  # on the public topic, closed by the other's lease
    refused = gripper_status(ros, lambda m: m.refused_commands >= 1)
    assert "/test_executor" in refused.refused_commanders
    assert abs(refused.requested_gap - 0.06) > 1e-3
    ask(ros, "gripper", "/other_executor", release=True, token=taken.token)

    def take() -> bool:
        control.update(True)
        return control.keeper.connected

    wait_until(take, "the gripper lease taken")
    assert control.resends == 1
    status = gripper_status(ros, lambda m: abs(m.requested_gap - 0.06) < 1e-6)
    assert status.lease_holder == "/test_executor"
