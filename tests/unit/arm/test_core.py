"""The arm node's logic against a kinematic stand-in of the driver: IK path, by-name joint
reading, the driver's state, the unlock sequence, the commands it sends."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py.drivers import ROBOT_RUNNING, SAFETY_NORMAL, SAFETY_PROTECTIVE_STOP
from nodes.arm.commands import setpoint_tick_gap
from nodes.arm.config import ArmConfig
from nodes.arm.core import ArmCore
from nodes.arm.readiness import DriverState, judge
from nodes.arm.unlock import UnlockSequence
from nodes.common.joints import values_by_name
from nodes.common.transforms import tool_down_quaternion
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik, tcp_pose
from nodes.sim.config import HOME_JOINTS
from nodes.sim.joint_control import TrajectoryController

#: The order ur_robot_driver's broadcaster uses (not the kinematic one).
DRIVER_ORDER = ("shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
                "wrist_3_joint", "shoulder_pan_joint")


def driver_joint_state(q) -> tuple[list[str], list[float]]:
    return list(DRIVER_ORDER), [float(q[ur10e.ARM_JOINTS.index(n)]) for n in DRIVER_ORDER]


def ready_core(cfg: ArmConfig | None = None, q=HOME_JOINTS) -> ArmCore:
    core = ArmCore(cfg or ArmConfig())
    core.on_joint_state(*driver_joint_state(q), 0.0)
    core.on_safety_mode(SAFETY_NORMAL)
    core.on_robot_mode(ROBOT_RUNNING)
    core.on_program_running(True)
    core.on_speed_scaling(100.0)
    core.tick(0.0)
    assert core.state.state == "ready"
    return core


def test_joints_are_read_by_name_never_by_order():
    names, values = driver_joint_state(HOME_JOINTS)
    q, missing = values_by_name(names, values, ur10e.ARM_JOINTS)
    assert missing == () and np.allclose(q, HOME_JOINTS)
    q, missing = values_by_name(names[:-1], values[:-1], ur10e.ARM_JOINTS)
    assert q is None and missing == ("shoulder_pan_joint",)
    q, missing = values_by_name([*names, "elbow_joint"], [*values, 0.0], ur10e.ARM_JOINTS)
    assert missing == ("elbow_joint",)  # listed twice: which one is it?


def test_the_tool_pose_comes_from_the_measured_joints():
    core = ArmCore(ArmConfig())
    tcp = core.on_joint_state(*driver_joint_state(HOME_JOINTS), 0.0)
    assert tcp is not None and np.allclose(tcp, tcp_pose(HOME_JOINTS))


@pytest.mark.parametrize(("driver", "age", "missing", "state", "words"), [
    (DriverState(1, 7, True, 1.0), None, (), "no_joint_states", "no /joint_states"),
    (DriverState(1, 7, True, 1.0), 2.0, (), "no_joint_states", "for 2.0 s"),
    (DriverState(1, 7, True, 1.0), 0.0, ("wrist_3_joint",), "no_joint_states", "wrist_3"),
    (DriverState(3, 7, False, 1.0), 0.0, (), "protective_stop", "protective stop"),
    (DriverState(5, 7, True, 1.0), 0.0, (), "stopped", "safeguard_stop"),
    (DriverState(1, 3, False, 1.0), 0.0, (), "stopped", "power_off"),
    (DriverState(1, 7, False, 1.0), 0.0, (), "stopped", "program is not running"),
    (DriverState(None, None, None, None), 0.0, (), "stopped", "waiting for the driver"),
    (DriverState(1, 7, True, 0.0), 0.0, (), "paused", "speed slider is at 0"),
    (DriverState(2, 7, True, 0.5), 0.0, (), "ready", ""),
])
def test_the_driver_state_is_judged_and_named(driver, age, missing, state, words):
    judged = judge(driver, age, missing, joint_state_timeout_s=0.5)
    assert judged.state == state and words in judged.reason


def play(core: ArmCore, ctrl: TrajectoryController, q0, seconds: float, setpoints=None,
         rate=50.0):
    """The core and a kinematic stand-in of the trajectory controller (a perfect arm: the
    measured joints are the commanded ones), ticking at ``rate``; ``setpoints(t)`` gives
    (position, yaw) to stream."""
    q = np.array(q0, dtype=float)
    t, dt, sent = 0.0, 1.0 / 240.0, 0
    next_tick = 0.0
    while t < seconds:
        if t + 1e-9 >= next_tick:
            next_tick += 1.0 / rate
            if setpoints is not None:
                target = setpoints(t)
                if target is not None:
                    assert core.on_setpoint(target[0], tool_down_quaternion(target[1]), "world",
                                            t).accepted
            core.on_joint_state(*driver_joint_state(q), t)
            out = core.tick(t)
            if out.trajectory is not None:
                sent += 1
                snippet = out.trajectory
                assert np.allclose(snippet.velocities[-1], 0.0)  # it ends at rest
                assert ctrl.receive(ur10e.ARM_JOINTS, snippet.start_s, snippet.as_points(),
                                    t) == ""
        q, _ = ctrl.update(t + dt, dt, 1.0, q, np.zeros(6))
        t += dt
    return q, sent


def test_a_cartesian_line_is_tracked_through_the_trajectory_controller():
    core = ready_core()
    ctrl = TrajectoryController(HOME_JOINTS)
    start = tcp_pose(HOME_JOINTS)[:3, 3]
    end = np.array([0.75, 0.10, 0.20])

    def line(t):  # 1.2 s along a straight line, then holding its end
        u = min(t / 1.2, 1.0)
        s = 0.5 - 0.5 * math.cos(math.pi * u)
        return start + s * (end - start), 0.0

    q, sent = play(core, ctrl, HOME_JOINTS, 3.0, line)
    assert sent > 50
    assert np.linalg.norm(tcp_pose(q)[:3, 3] - end) < 1e-4
    # and nothing is sent once the arm stands still
    _, more = play(core, ctrl, q, 1.0)
    assert more <= 1


def test_setpoints_are_refused_while_the_arm_cannot_move():
    core = ready_core()
    core.on_safety_mode(SAFETY_PROTECTIVE_STOP)
    core.on_program_running(False)
    core.tick(0.1)
    assert core.state.state == "protective_stop"
    assert core.request_unlock(0.1)[0] and core.request_unlock(0.11) == (
        True, "unlocking: already under way")
    result = core.on_setpoint([0.7, 0.0, 0.2], tool_down_quaternion(0.0), "world", 0.1)
    assert not result.accepted and "not ready" in result.reason
    assert core.tick(0.12).trajectory is None


def test_stale_joint_states_stop_the_commands():
    core = ready_core()
    core.on_setpoint([0.7, 0.0, 0.2], tool_down_quaternion(0.0), "world", 0.0)
    out = core.tick(2.0)  # the last joint state is 2 s old
    assert core.state.state == "no_joint_states" and out.trajectory is None
    assert "no /joint_states for 2.0 s" in core.status(0).reason


def test_the_unlock_is_the_urs_sequence_and_ends_with_the_program_running():
    core = ready_core()
    core.on_safety_mode(SAFETY_PROTECTIVE_STOP)
    core.on_program_running(False)
    core.on_joint_state(*driver_joint_state(HOME_JOINTS), 1.0)
    core.tick(1.0)
    ok, _ = core.request_unlock(1.0)
    assert ok
    calls = []
    t = 1.0
    for _ in range(10):
        t += 0.02
        core.on_joint_state(*driver_joint_state(HOME_JOINTS), t)
        out = core.tick(t)
        for call in out.dashboard_calls:
            calls.append(call)
            if call == "unlock_protective_stop":
                core.on_safety_mode(SAFETY_NORMAL)
            core.on_dashboard_answer(call, True, "ok", t)
            if call == "play":
                core.on_program_running(True)
    assert calls == ["close_safety_popup", "unlock_protective_stop", "stop", "play"]
    core.on_joint_state(*driver_joint_state(HOME_JOINTS), t + 0.02)
    core.tick(t + 0.02)
    assert core.state.state == "ready"


def test_a_refused_unlock_fails_and_may_be_asked_again():
    seq = UnlockSequence(0.0)
    seq.on_answer("close_safety_popup", False, "no popup", 0.1)  # may have none to close
    assert seq.next_call() == "unlock_protective_stop"
    seq.on_answer("unlock_protective_stop", False, "Cannot unlock protective stop until 5s", 0.2)
    assert seq.finished and "until 5s" in seq.failure
    played = UnlockSequence(0.0, program_timeout_s=1.0)
    for call in ("close_safety_popup", "unlock_protective_stop", "stop", "play"):
        played.on_answer(call, True, "ok", 0.5)
    played.on_program_running(False, 2.0)
    assert "did not start" in played.failure


def test_the_slider_at_zero_pauses_the_arm_on_its_path():
    core = ready_core()
    core.on_speed_scaling(0.0)
    core.tick(0.02)
    assert core.state.state == "paused"
    ctrl = TrajectoryController(HOME_JOINTS)
    target = np.array([0.75, 0.10, 0.20])
    q, _ = play(core, ctrl, HOME_JOINTS, 1.0, lambda t: (target, 0.0))
    assert np.allclose(q, HOME_JOINTS, atol=1e-9)  # accepted, but waiting


def test_ik_failures_are_refused_with_the_reason():
    core = ready_core()
    result = core.on_setpoint([2.5, 0.0, 0.2], tool_down_quaternion(0.0), "world", 0.0)
    assert not result.accepted and "reach" in result.reason
    assert solve_tcp_ik(tcp_pose(HOME_JOINTS), HOME_JOINTS).ok


def test_a_setpoint_on_a_held_clock_is_sent_on_at_once_else_at_most_one_per_half_tick():
    rate = 50.0
    assert setpoint_tick_gap(10.0, 10.0, rate) == 0.0  # the sim holds its clock: no tick comes
    assert setpoint_tick_gap(10.005, 10.0, rate) == pytest.approx(0.01)  # a wall clock runs on
