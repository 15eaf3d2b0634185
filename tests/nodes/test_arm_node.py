"""The arm node over DDS against the drivers' stand-in: what it refuses and says when the
driver's reports go wrong (joint states incomplete or gone, the slider at 0), and that it
never sends the driver a bad trajectory."""

from __future__ import annotations

import itertools
import time

import numpy as np
import pytest
from densepack_interfaces.msg import ArmStatus
from geometry_msgs.msg import PoseStamped
from rclpy.parameter import Parameter
from trajectory_msgs.msg import JointTrajectory

from msgs_py import drivers
from msgs_py.ros import ns_to_stamp
from nodes.arm.node import ArmNode
from nodes.common.qos import LATCHED
from nodes.common.standard_msgs import pose_stamped_msg
from nodes.common.transforms import tool_down_quaternion
from nodes.robot import ur10e
from nodes.sim.config import HOME_JOINTS
from tests.conformance.standin import DriverStandIn

pytestmark = pytest.mark.ros


def status(ros, state: str, timeout: float = 20.0, words: str = ""):
    code = getattr(ArmStatus, f"STATE_{state.upper()}")
    return ros.wait_for_message("/arm/status", ArmStatus,
                                lambda m: m.state == code and words in m.reason,
                                timeout=timeout, qos=LATCHED)


@pytest.fixture
def cell(ros):
    driver = ros.add(DriverStandIn(HOME_JOINTS, context=ros.context))
    ros.add(ArmNode(context=ros.context,
                    parameter_overrides=[Parameter("use_sim_time", value=True)]))
    sent: list[JointTrajectory] = []
    ros.probe.create_subscription(JointTrajectory, drivers.TRAJECTORY_TOPIC, sent.append, 10)
    status(ros, "ready")
    return driver, sent


def test_joint_states_that_lack_a_joint_or_stop_coming_stop_the_commands(ros, cell):
    driver, sent = cell
    driver.dropped_joint = "wrist_2_joint"
    status(ros, "no_joint_states", words="lacks wrist_2_joint")
    driver.dropped_joint = None
    status(ros, "ready")
    driver.joint_states = False
    stale = status(ros, "no_joint_states", words="no /joint_states for")
    assert stale.reason.endswith("(timeout 0.5 s)")
    count = len(sent)
    setpoints = ros.publisher("/arm/cartesian_setpoint", PoseStamped)
    ros.wait_for_subscribers(setpoints)
    setpoints.publish(pose_stamped_msg(ns_to_stamp(round(driver.t * 1e9)), [0.6, 0.1, 0.3],
                                       tool_down_quaternion(0.0)))
    time.sleep(0.5)
    assert len(sent) == count  # nothing sent to the driver while the arm's state is unknown
    driver.joint_states = True
    status(ros, "ready")


def test_the_slider_at_zero_pauses_and_says_so(ros, cell):
    driver, _ = cell
    driver.speed_percent = 0.0
    paused = status(ros, "paused", words="speed slider is at 0")
    assert paused.speed_scaling == 0.0
    driver.speed_percent = 30.0
    assert status(ros, "ready").speed_scaling == pytest.approx(0.3)


def test_every_trajectory_sent_is_one_the_controller_accepts(ros, cell):
    driver, sent = cell
    setpoints = ros.publisher("/arm/cartesian_setpoint", PoseStamped)
    ros.wait_for_subscribers(setpoints)
    for k in range(40):  # a line, then an unreachable setpoint the node must refuse
        t = driver.t
        target = [0.5 + 0.005 * k, 0.0, 0.3] if k < 30 else [2.5, 0.0, 0.3]
        setpoints.publish(pose_stamped_msg(ns_to_stamp(round(t * 1e9)), target,
                                           tool_down_quaternion(0.0)))
        time.sleep(0.02)
    time.sleep(0.5)
    assert sent and not driver.refused
    for msg in sent:
        assert sorted(msg.joint_names) == sorted(ur10e.ARM_JOINTS)
        positions = np.array([p.positions for p in msg.points])
        assert np.all(np.isfinite(positions)) and np.all(np.abs(positions) <= ur10e.JOINT_LIMIT)
        assert np.allclose(msg.points[-1].velocities, 0.0)
        times = [p.time_from_start.sec + 1e-9 * p.time_from_start.nanosec for p in msg.points]
        assert all(b > a for a, b in itertools.pairwise(times))
