"""The sim node spun in-process over real DDS, as the drivers it stands in for: joint states by
the driver's order, joint trajectories checked as the controller checks them, the safety mode,
program and dashboard, the knuckle joint, render requests, reset, robustness."""

from __future__ import annotations

import math
import os
import subprocess
import time

import numpy as np
import pytest
from densepack_interfaces.msg import BlockPoseArray, Disturbance, SimEvents
from densepack_interfaces.msg import ExecutorStatus as ExecutorStatusMsg
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.srv import SetParameters
from rclpy.parameter import Parameter
from rclpy.qos import qos_profile_sensor_data
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_msgs.msg import Bool, Float64, Float64MultiArray, Header
from std_srvs.srv import Trigger
from trajectory_msgs.msg import JointTrajectory
from ur_dashboard_msgs.msg import RobotMode, SafetyMode
from visualization_msgs.msg import MarkerArray

from msgs_py import ExecutorStatus, drivers
from msgs_py import ros as msg_codecs
from msgs_py.ros import ns_to_stamp, stamp_to_ns
from msgs_py.sim import Disturbance as DisturbanceRecord
from msgs_py.sim import SimEvents as SimEventsRecord
from nodes.common.joints import values_by_name
from nodes.common.qos import LATCHED
from nodes.common.standard_msgs import trajectory_msg
from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik
from nodes.sim.config import HOME_JOINTS, PARK_POSITION
from nodes.sim.layout import random_sim_scene
from nodes.sim.node import SimNode
from tests.helpers import script, spawn_python

pytestmark = pytest.mark.ros


def make_sim(ros, **overrides):
    params = {"real_time_factor": 0.0, "camera.rate_hz": 0.0, **overrides}
    node = SimNode(context=ros.context,
                   parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
    return ros.add(node)


def send(ros, topic, msg_type, msg):
    pub = ros.publisher(topic, msg_type)
    ros.wait_for_subscribers(pub)
    pub.publish(msg)
    return pub


def joints_for(x, y, z, yaw=0.0, q_ref=HOME_JOINTS) -> np.ndarray:
    ik = solve_tcp_ik(pose_matrix([x, y, z], tool_down_quaternion(yaw)), q_ref)
    assert ik.ok, ik.reason
    return ik.q


def trajectory_to(q, seconds=2.0, names=ur10e.ARM_JOINTS) -> JointTrajectory:
    """A one-point trajectory starting now (stamp 0), values in the order of ``names``."""
    order = [ur10e.ARM_JOINTS.index(n) for n in names]
    return trajectory_msg(ns_to_stamp(0), names, [seconds], [np.asarray(q)[order]],
                          [np.zeros(len(names))])


def arm_at(q, tol=2e-3):
    def check(msg: JointState) -> bool:
        values, missing = values_by_name(msg.name, msg.position, ur10e.ARM_JOINTS)
        return not missing and float(np.max(np.abs(values - q))) < tol
    return check


def test_a_render_request_publishes_image_and_camera_info_with_one_stamp(ros):
    make_sim(ros)
    got: dict[str, object] = {}
    ros.probe.create_subscription(Image, "/camera/image_raw",
                                  lambda m: got.setdefault("image", m), qos_profile_sensor_data)
    ros.probe.create_subscription(CameraInfo, "/camera/camera_info",
                                  lambda m: got.setdefault("info", m), qos_profile_sensor_data)
    time.sleep(0.5)
    send(ros, "/sim/render_request", Header, Header())
    deadline = time.monotonic() + 20
    while len(got) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    image, info = got["image"], got["info"]
    assert stamp_to_ns(image.header.stamp) == stamp_to_ns(info.header.stamp) > 0
    assert image.header.frame_id == info.header.frame_id == "camera_optical_frame"
    assert (image.width, image.height, image.encoding) == (1280, 960, "rgb8")
    assert len(image.data) == 1280 * 960 * 3
    assert list(info.k)[:3] == [1400.0, 0.0, 639.5]


def test_the_drivers_state_topics_flow_under_their_names(ros):
    make_sim(ros)
    assert ros.wait_for_message("/clock", Clock, timeout=10)
    joints = ros.wait_for_message(drivers.JOINT_STATES, JointState, timeout=10)
    assert sorted(joints.name) == sorted(ur10e.ARM_JOINTS)
    assert list(joints.name) not in (list(ur10e.ARM_JOINTS), sorted(ur10e.ARM_JOINTS))
    assert arm_at(HOME_JOINTS)(joints)
    knuckle = ros.wait_for_message(drivers.GRIPPER_JOINT_STATES, JointState, timeout=10)
    assert list(knuckle.name) == [g85.KNUCKLE_JOINT] and abs(knuckle.position[0]) < 1e-3
    tcp = ros.wait_for_message(drivers.TCP_POSE_TOPIC, PoseStamped, timeout=10)
    assert tcp.header.frame_id == "base"
    assert math.dist((tcp.pose.position.x, tcp.pose.position.y, tcp.pose.position.z),
                     PARK_POSITION) < 1e-3
    assert ros.wait_for_message(drivers.SPEED_SCALING_TOPIC, Float64, timeout=10).data == 100.0
    assert ros.wait_for_message(drivers.SAFETY_MODE_TOPIC, SafetyMode, qos=LATCHED,
                                timeout=10).mode == SafetyMode.NORMAL
    assert ros.wait_for_message(drivers.ROBOT_MODE_TOPIC, RobotMode, qos=LATCHED,
                                timeout=10).mode == RobotMode.RUNNING
    assert ros.wait_for_message(drivers.PROGRAM_RUNNING_TOPIC, Bool, qos=LATCHED,
                                timeout=10).data is True
    truth = msg_codecs.block_set_from_msg(ros.wait_for_message("/sim/ground_truth", BlockPoseArray))
    assert sorted(truth.ids) == list(range(9))
    markers = ros.wait_for_message("/sim/ground_truth/markers", MarkerArray)
    assert sorted(m.id for m in markers.markers) == list(range(9))


def test_a_trajectory_in_any_joint_order_moves_the_arm_and_a_new_one_replaces_it(ros):
    make_sim(ros)
    target = joints_for(0.7, 0.1, 0.2, 0.3)
    pub = send(ros, drivers.TRAJECTORY_TOPIC, JointTrajectory,
               trajectory_to(target, names=tuple(reversed(ur10e.ARM_JOINTS))))
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(target), timeout=30)
    far, back = joints_for(0.8, -0.2, 0.2), joints_for(0.6, 0.2, 0.25)
    pub.publish(trajectory_to(far, seconds=3.0))
    pub.publish(trajectory_to(back, seconds=1.0))  # forgets `far`
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(back), timeout=30)


@pytest.mark.parametrize("bad", ["names", "nan", "limit", "moving_end"])
def test_bad_trajectories_are_refused_and_the_arm_holds(ros, bad):
    sim = make_sim(ros)
    start = joints_for(0.6, -0.2, 0.25)
    pub = send(ros, drivers.TRAJECTORY_TOPIC, JointTrajectory, trajectory_to(start))
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(start), timeout=30)
    msg = trajectory_to(joints_for(0.7, 0.1, 0.2))
    if bad == "names":
        msg.joint_names[5] = "tool0_joint"
    elif bad == "nan":
        msg.points[0].positions[2] = math.nan
    elif bad == "limit":
        msg.points[0].positions[0] = 7.0
    else:
        msg.points[0].velocities[1] = 0.3
    pub.publish(msg)
    time.sleep(1.0)
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(start), timeout=10)
    assert not sim.world.motion.active  # nothing of it kept
    ros.check()


def test_malformed_messages_do_not_kill_the_node(ros):
    make_sim(ros)
    send(ros, drivers.GRIPPER_COMMAND_TOPIC, Float64MultiArray,
         Float64MultiArray(data=[0.1, 0.2]))  # one value per joint: one joint
    send(ros, drivers.GRIPPER_COMMAND_TOPIC, Float64MultiArray,
         Float64MultiArray(data=[math.nan]))
    send(ros, drivers.FORWARD_POSITION_TOPIC, Float64MultiArray,
         Float64MultiArray(data=[0.0] * 6))  # not the active controller
    send(ros, "/sim/speed_slider", Float64, Float64(data=3.0))
    disturb = send(ros, "/sim/disturb", Disturbance, Disturbance(block=-3, dx=0.01))
    disturb.publish(Disturbance(block=99, dx=0.01, dy=0.0))  # no such block
    disturb.publish(Disturbance(block=1, dx=float("nan"), dy=0.0))
    status = send(ros, "/executor/status", ExecutorStatusMsg, ExecutorStatusMsg(state=0))
    status.publish(ExecutorStatusMsg(state=ExecutorStatusMsg.STATE_RUNNING, block=-7))
    time.sleep(1.0)
    target = joints_for(0.65, 0.05, 0.22)  # a good command still works
    send(ros, drivers.TRAJECTORY_TOPIC, JointTrajectory, trajectory_to(target))
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(target), timeout=30)
    ros.check()


def test_a_knuckle_command_moves_the_fingers_and_reset_restores_the_cell(ros):
    make_sim(ros)
    closed = g85.gap_to_knuckle(0.03)
    send(ros, drivers.GRIPPER_COMMAND_TOPIC, Float64MultiArray, Float64MultiArray(data=[closed]))
    ros.wait_for_message(drivers.GRIPPER_JOINT_STATES, JointState,
                         lambda m: abs(m.position[0] - closed) < 5e-3, timeout=20)
    target = joints_for(0.7, 0.2, 0.3)
    send(ros, drivers.TRAJECTORY_TOPIC, JointTrajectory, trajectory_to(target))
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(target), timeout=30)
    response = ros.call_service("/sim/reset", Trigger, timeout=30)
    assert response.success, response.message
    # the clock starts again (read from the answer: with real_time_factor 0 the sim runs on
    # as fast as it can, so its time by the next check depends on the machine's load)
    assert float(response.message.split("t = ")[1].split(" s")[0]) < 0.1, response.message
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(HOME_JOINTS), timeout=10)
    events = ros.wait_for_message("/sim/events", SimEvents, qos=LATCHED, timeout=10)
    assert msg_codecs.sim_events_from_msg(events) == SimEventsRecord(stamp_ns=stamp_to_ns(
        events.header.stamp))


def test_executor_status_names_the_manipulated_block(ros):
    sim = make_sim(ros)
    pub = send(ros, "/executor/status", ExecutorStatusMsg, msg_codecs.executor_status_to_msg(
        ExecutorStatus("running", action_index=1, action_total=3, block=3)))
    deadline = time.monotonic() + 10
    while sim.world.monitor.manipulated != 3 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert sim.world.monitor.manipulated == 3
    pub.publish(msg_codecs.executor_status_to_msg(ExecutorStatus("observing")))
    deadline = time.monotonic() + 10
    while sim.world.monitor.manipulated is not None and time.monotonic() < deadline:
        time.sleep(0.05)
    assert sim.world.monitor.manipulated is None


def test_disturb_pushes_a_block(ros):
    make_sim(ros)
    send(ros, "/sim/disturb", Disturbance, msg_codecs.disturbance_to_msg(
        DisturbanceRecord(4, 0.02, 0.0)))

    def moved(msg: BlockPoseArray) -> bool:
        block = msg_codecs.block_set_from_msg(msg).by_id()[4]
        return abs(block.x - 0.75) < 0.004 and abs(block.y - 0.12) < 0.004

    ros.wait_for_message("/sim/ground_truth", BlockPoseArray, moved, timeout=30)


def test_densepack_sim_runs_and_echo_shows_camera_info_across_processes():
    sim = subprocess.Popen([script("densepack-sim"), "--ros-args", "-p", "camera.rate_hz:=4.0"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    listener = spawn_python("""
        import time, rclpy
        from sensor_msgs.msg import Image
        from nodes.common.qos import CAMERA
        rclpy.init(); node = rclpy.create_node("image_listener"); got = []
        # (reliable, as the detector: best effort loses a 3.7 MB frame to one dropped fragment)
        node.create_subscription(Image, "/camera/image_raw", got.append, CAMERA)
        end = time.time() + 40
        while not got and time.time() < end:
            rclpy.spin_once(node, timeout_sec=0.1)
        print("IMAGE", got[0].width, got[0].height, len(got[0].data) if got else "none")
    """)
    try:
        out = subprocess.run([script("densepack-echo"), "/camera/camera_info", "--once",
                              "--timeout", "40"], capture_output=True, text=True, timeout=60)
        listened, _ = listener.communicate(timeout=60)
    finally:
        sim.terminate()
        log, _ = sim.communicate(timeout=30)
        listener.kill()
    assert out.returncode == 0, out.stderr + log
    assert "camera_optical_frame" in out.stdout and "rational_polynomial" in out.stdout
    assert "IMAGE 1280 960 3686400" in listened, listened + log
    assert sim.returncode == 0, log


def test_camera_blackout_drops_frames_for_a_while(ros):
    """Fault injection for the cell benchmark: render requests are taken, no frame comes."""
    make_sim(ros)
    frames: list[Image] = []
    ros.probe.create_subscription(Image, "/camera/image_raw", frames.append,
                                  qos_profile_sensor_data)
    time.sleep(0.5)
    pub = send(ros, "/sim/camera_blackout", Float64, Float64(data=1e6))
    time.sleep(0.5)
    render = send(ros, "/sim/render_request", Header, Header())
    time.sleep(2.0)
    assert frames == []
    pub.publish(Float64(data=0.0))  # blackout over
    time.sleep(0.5)
    render.publish(Header())
    deadline = time.monotonic() + 20
    while not frames and time.monotonic() < deadline:
        time.sleep(0.05)
    assert len(frames) == 1


def test_the_speed_slider_is_reported_in_percent(ros):
    make_sim(ros)
    send(ros, "/sim/speed_slider", Float64, Float64(data=0.25))
    ros.wait_for_message(drivers.SPEED_SCALING_TOPIC, Float64, lambda m: m.data == 25.0,
                         timeout=10)


def test_a_protective_stop_holds_until_unlocked_and_the_program_played_again(ros):
    make_sim(ros, protective_stop_unlock_after_s=2.0, real_time_factor=1.0)
    block = msg_codecs.block_set_from_msg(ros.wait_for_message("/sim/ground_truth", BlockPoseArray))
    x, y = block.blocks[0].x, block.blocks[0].y
    send(ros, drivers.GRIPPER_COMMAND_TOPIC, Float64MultiArray,
         Float64MultiArray(data=[g85.KNUCKLE_CLOSED]))  # closed: the tips land on top
    above = joints_for(x, y, 0.2)
    pub = send(ros, drivers.TRAJECTORY_TOPIC, JointTrajectory, trajectory_to(above))
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(above), timeout=30)
    pub.publish(trajectory_to(joints_for(x, y, 0.02, q_ref=above), seconds=1.0))  # into it
    ros.wait_for_message(drivers.SAFETY_MODE_TOPIC, SafetyMode, qos=LATCHED,
                         predicate=lambda m: m.mode == SafetyMode.PROTECTIVE_STOP, timeout=30)
    ros.wait_for_message(drivers.PROGRAM_RUNNING_TOPIC, Bool, qos=LATCHED,
                         predicate=lambda m: not m.data, timeout=10)
    pub.publish(trajectory_to(above))  # not executed while stopped: the arm stays on the block
    time.sleep(0.5)
    tcp = ros.wait_for_message(drivers.TCP_POSE_TOPIC, PoseStamped, timeout=10)
    assert tcp.pose.position.z < 0.06
    unlock = drivers.dashboard_service("unlock_protective_stop")
    answers = [ros.call_service(unlock, Trigger, timeout=10)]
    while not answers[-1].success and len(answers) < 60:
        time.sleep(0.25)
        answers.append(ros.call_service(unlock, Trigger, timeout=10))
    assert "after occurrence" in answers[0].message  # too soon after the stop: refused
    assert answers[-1].success and answers[-1].message == "Protective stop releasing"
    ros.wait_for_message(drivers.SAFETY_MODE_TOPIC, SafetyMode, qos=LATCHED,
                         predicate=lambda m: m.mode == SafetyMode.NORMAL, timeout=10)
    assert ros.call_service(drivers.dashboard_service("stop"), Trigger, timeout=10).success
    assert ros.call_service(drivers.dashboard_service("play"), Trigger, timeout=10).success
    ros.wait_for_message(drivers.PROGRAM_RUNNING_TOPIC, Bool, qos=LATCHED,
                         predicate=lambda m: m.data, timeout=10)
    pub.publish(trajectory_to(above))
    ros.wait_for_message(drivers.JOINT_STATES, JointState, arm_at(above), timeout=30)
    again = ros.call_service(unlock, Trigger, timeout=10)
    assert not again.success and "normal" in again.message


def test_a_free_running_sim_leaves_other_threads_the_gil(ros):
    """Counted, not timed: while the sim's loop held the GIL through back-to-back physics
    steps, another thread got it back only at the interpreter's forced switches (every 5 ms,
    some 15 steps), once per blocking call: rclpy's logger made thousands and took minutes.
    Sharing the GIL, a thread making blocking calls (os.stat) gets many in per step."""
    sim = make_sim(ros)
    ros.wait_for_message("/clock", Clock, timeout=10)
    start = sim.world.step_count
    calls = 0
    while sim.world.step_count - start < 2400 and calls < 10_000_000:
        os.stat(__file__)
        calls += 1
    assert calls >= sim.world.step_count - start  # starved: about one call per 15 steps


def _set_sim_parameters(ros, **values):
    request = SetParameters.Request(
        parameters=[Parameter(k, value=v).to_parameter_msg() for k, v in values.items()])
    reply = ros.call_service("/sim/set_parameters", SetParameters, request, timeout=30)
    assert all(r.successful for r in reply.results), reply.results


def test_reset_lays_out_the_scene_its_parameters_name_now_and_keeps_the_clock(ros):
    make_sim(ros, reset_scene_only=True)
    _set_sim_parameters(ros, **{"random.n_blocks": 4, "random.density": 0.1, "random.seed": 4})
    response = ros.call_service("/sim/reset", Trigger, timeout=30)
    assert response.success, response.message
    assert response.message.startswith("reset: 4 blocks")
    assert float(response.message.split("t = ")[1].split(" s")[0]) > 0.0  # the clock ran on
    expected = {b.id: b.pose for b in random_sim_scene(4, 0.1, 4).blocks}
    truth = msg_codecs.block_set_from_msg(ros.wait_for_message(
        "/sim/ground_truth", BlockPoseArray, lambda m: len(m.blocks) == 4, timeout=30))
    for block in truth.blocks:
        assert block.pose.distance_to(expected[block.id]) < 2e-3

    _set_sim_parameters(ros, **{"random.seed": "seven"})  # dynamically typed: taken ...
    response = ros.call_service("/sim/reset", Trigger, timeout=30)
    assert not response.success and "random.seed" in response.message  # ... refused here
    ros.wait_for_message("/sim/ground_truth", BlockPoseArray, lambda m: len(m.blocks) == 4,
                         timeout=30)  # nothing half-applied


def test_a_render_request_for_a_moment_to_come_is_rendered_when_the_clock_gets_there(ros):
    make_sim(ros, real_time_factor=1.0)
    stamps: list[int] = []
    ros.probe.create_subscription(CameraInfo, "/camera/camera_info",
                                  lambda m: stamps.append(stamp_to_ns(m.header.stamp)),
                                  qos_profile_sensor_data)
    now = stamp_to_ns(ros.wait_for_message("/clock", Clock, timeout=10).clock)
    at = now + 1_500_000_000  # 1.5 s of simulated time from now
    send(ros, "/sim/render_request", Header, Header(stamp=ns_to_stamp(at)))
    deadline = time.monotonic() + 20
    while not stamps and time.monotonic() < deadline:
        time.sleep(0.05)
    assert stamps and at <= stamps[0] < at + 50_000_000  # the first physics step after it


def test_a_sim_started_paused_holds_its_clock_until_started(ros):
    make_sim(ros, start_paused=True)
    first = ros.wait_for_message("/clock", Clock, timeout=10)
    assert ros.wait_for_message(drivers.JOINT_STATES, JointState, timeout=10)  # topics flow
    time.sleep(0.5)
    assert stamp_to_ns(ros.wait_for_message("/clock", Clock, timeout=10).clock) == \
        stamp_to_ns(first.clock) == 0
    answer = ros.call_service("/sim/start", Trigger, timeout=10)
    assert answer.success and answer.message == "started"
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        if stamp_to_ns(ros.wait_for_message("/clock", Clock, timeout=10).clock) > 0:
            break
    else:
        raise AssertionError("the clock did not start")
    assert ros.call_service("/sim/start", Trigger, timeout=10).message == "running already"
