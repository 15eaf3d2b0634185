"""The arm node's controller: setpoint validation, hold-on-reject, rate limits, the slider."""

from __future__ import annotations

import numpy as np
import pytest

from nodes.arm.controller import CATCH_UP_RAMP, ArmController
from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.executor.motion import Limits, LinearMove, ToolPose
from nodes.robot import ur10e
from nodes.robot.kinematics import pose_error, tcp_pose
from nodes.sim.config import HOME_JOINTS

DT = 1.0 / 240.0


def run(ctrl: ArmController, seconds: float) -> list[np.ndarray]:
    return [ctrl.step(DT)[0] for _ in range(round(seconds / DT))]


def test_reaches_an_accepted_setpoint_within_joint_limits():
    ctrl = ArmController(HOME_JOINTS)
    target = pose_matrix([0.7, 0.1, 0.05], tool_down_quaternion(0.4))
    assert ctrl.set_setpoint(target[:3, 3], tool_down_quaternion(0.4)).accepted
    qs = np.array([HOME_JOINTS, *run(ctrl, 5.0)])
    steps = np.abs(np.diff(qs, axis=0))
    assert np.all(steps <= np.asarray(ur10e.JOINT_VELOCITY_LIMIT) * DT * (1 + 1e-9))
    accel = np.abs(np.diff(np.diff(qs, axis=0), axis=0)) / DT**2
    # (the last step onto the target may exceed the limit by up to 10 %: the discrete
    # braking profile lands on the target in whole physics steps)
    assert np.all(accel <= np.asarray(ur10e.JOINT_ACCELERATION_LIMIT) * 1.10)
    dp, dr = pose_error(tcp_pose(qs[-1]), target)
    assert dp < 1e-6 and dr < 1e-6


@pytest.mark.parametrize(("position", "quat", "frame", "words"), [
    ([0.7, 0.0, 0.1], [0, 0, 0, 1], "base_link", "frame_id"),
    ([0.7, float("nan"), 0.1], [1, 0, 0, 0], "world", "non-finite"),
    ([0.7, 0.0, 0.1], [0, 0, 0, 0], "world", "norm"),
    ([0.7, 0.0, -0.01], [1, 0, 0, 0], "world", "safety plane"),
    ([2.0, 0.0, 0.1], [1, 0, 0, 0], "world", "reach"),
])
def test_bad_setpoints_are_rejected_and_the_arm_holds(position, quat, frame, words):
    ctrl = ArmController(HOME_JOINTS)
    ctrl.set_setpoint([0.7, 0.0, 0.2], tool_down_quaternion(0.0))
    run(ctrl, 0.3)  # moving now
    moving_at = ctrl.q_cmd.copy()
    result = ctrl.set_setpoint(position, quat, frame)
    assert not result.accepted and words in result.reason
    assert ctrl.rejected == 1 and words in ctrl.last_reason
    after = run(ctrl, 0.5)
    assert np.allclose(after[-1], moving_at)  # held still where it was


def test_speed_scale_slows_the_arm():
    fast, slow = ArmController(HOME_JOINTS), ArmController(HOME_JOINTS, speed_scale=0.25)
    for ctrl in (fast, slow):
        ctrl.set_setpoint([0.9, 0.3, 0.05], tool_down_quaternion(1.0))
    fast_q, slow_q = run(fast, 1.0)[-1], run(slow, 1.0)[-1]
    assert np.max(np.abs(slow_q - HOME_JOINTS)) < np.max(np.abs(fast_q - HOME_JOINTS))
    with pytest.raises(ValueError):
        ArmController(HOME_JOINTS, speed_scale=0.0)


def stream_line(ctrl: ArmController, start, end, speed: float, accel: float = 4.0,
                rate: float = 50.0, t0: float = 0.0, yaw: float = 0.0, tail_s: float = 1.0):
    """Stream a straight TCP line (the executor's profile: ``speed`` m/s, ``accel`` m/s^2) as
    stamped setpoints at ``rate`` while stepping physics at 240 Hz; returns the commanded
    joints per physics step, and the move."""
    a, b = (ToolPose(*np.asarray(p, float), yaw) for p in (start, end))
    move = LinearMove.plan(a, b, Limits(speed, accel))
    quat = tool_down_quaternion(yaw)
    qs, t, next_setpoint = [], t0, t0
    while t < t0 + move.duration + tail_s:
        if t >= next_setpoint - 1e-12:
            p = move.sample(next_setpoint - t0).position
            assert ctrl.set_setpoint(p, quat, stamp_s=next_setpoint).accepted
            next_setpoint += 1.0 / rate
        t += DT
        qs.append(ctrl.step(DT, t)[0])
    return np.array(qs), move


def off_line(qs, start, end) -> float:
    """Largest distance (m) of the TCP from the segment start-end."""
    a, b = np.asarray(start, float), np.asarray(end, float)
    d = (b - a) / np.linalg.norm(b - a)
    worst = 0.0
    for q in qs:
        p = tcp_pose(q)[:3, 3]
        along = np.clip((p - a) @ d, 0.0, np.linalg.norm(b - a))
        worst = max(worst, float(np.linalg.norm(p - (a + along * d))))
    return worst


def test_a_setpoint_stream_is_followed_on_its_line_a_servo_delay_behind():
    start, end = [0.6, -0.2, 0.1], [0.8, 0.2, 0.1]
    ctrl = ArmController(HOME_JOINTS, servo_delay_s=0.08)
    ctrl.set_setpoint(start, tool_down_quaternion(0.0), stamp_s=0.0)
    run(ctrl, 3.0)  # the first point of a stream is reached point to point
    ctrl.now = 10.0
    qs, move = stream_line(ctrl, start, end, speed=1.0, t0=10.0)
    assert off_line(qs, start, end) < 5e-4
    steps = np.abs(np.diff(qs, axis=0))
    assert np.all(steps <= np.asarray(ur10e.JOINT_VELOCITY_LIMIT) * DT * (1 + 1e-9))
    dp, _ = pose_error(tcp_pose(qs[-1]), pose_matrix(end, tool_down_quaternion(0.0)))
    assert dp < 1e-6
    # at time t the arm is where the stream was at t - servo_delay
    for k in range(0, len(qs), 10):
        expected = move.sample((k + 1) * DT - 0.08).position
        assert np.linalg.norm(tcp_pose(qs[k])[:3, 3] - expected) < 0.003
    assert ctrl.scaled_steps == 0


def test_a_stream_too_fast_for_the_joints_is_slowed_down_on_its_path():
    """Speed scaling, as on the UR: the joints never exceed their limits, the TCP stays on
    the line, it just arrives late."""
    start, end = [0.5, -0.3, 0.1], [0.5, 0.3, 0.1]  # tangential, close to the base
    ctrl = ArmController(HOME_JOINTS, servo_delay_s=0.08)
    ctrl.set_setpoint(start, tool_down_quaternion(0.0), stamp_s=0.0)
    run(ctrl, 3.0)
    ctrl.now = 10.0
    qs, _ = stream_line(ctrl, start, end, speed=3.0, accel=20.0, t0=10.0, tail_s=2.0)
    steps = np.abs(np.diff(qs, axis=0))
    assert np.all(steps <= np.asarray(ur10e.JOINT_VELOCITY_LIMIT) * DT * (1 + 1e-3))
    assert ctrl.scaled_steps > 0
    assert off_line(qs, start, end) < 5e-4
    dp, _ = pose_error(tcp_pose(qs[-1]), pose_matrix(end, tool_down_quaternion(0.0)))
    assert dp < 1e-6


def test_a_stream_that_pauses_and_resumes_from_where_it_stopped_does_not_jump():
    start, mid, end = [0.6, -0.2, 0.1], [0.7, 0.0, 0.1], [0.8, 0.2, 0.1]
    ctrl = ArmController(HOME_JOINTS, servo_delay_s=0.08)
    ctrl.set_setpoint(start, tool_down_quaternion(0.0), stamp_s=0.0)
    run(ctrl, 3.0)
    ctrl.now = 10.0
    first, _ = stream_line(ctrl, start, mid, speed=1.0, t0=10.0, tail_s=2.0)
    second, _ = stream_line(ctrl, mid, end, speed=1.0, t0=ctrl.now)  # after a 2 s pause
    qs = np.concatenate([first, second])
    assert off_line(qs, start, end) < 5e-4
    assert np.all(np.abs(np.diff(qs, axis=0)) <= np.asarray(ur10e.JOINT_VELOCITY_LIMIT) * DT * 1.01)


def test_a_protective_stop_holds_where_measured_and_refuses_setpoints_until_unlocked():
    ctrl = ArmController(HOME_JOINTS)
    down = tool_down_quaternion(0.0)
    ctrl.set_setpoint([0.7, 0.0, 0.2], down)
    run(ctrl, 0.3)  # moving now
    measured = ctrl.q_cmd - 0.01  # the arm trails its command
    ctrl.protective_stop(measured, "300 N on the robot")
    result = ctrl.set_setpoint([0.7, 0.0, 0.3], down)
    assert not result.accepted and "protective stop (300 N on the robot)" in result.reason
    assert np.allclose(run(ctrl, 0.5)[-1], measured)  # held where measured, not commanded
    assert ctrl.unlock() and not ctrl.stopped and not ctrl.unlock()
    assert ctrl.set_setpoint([0.7, 0.0, 0.3], down).accepted
    dp, _ = pose_error(tcp_pose(run(ctrl, 5.0)[-1]), pose_matrix([0.7, 0.0, 0.3], down))
    assert dp < 1e-6


def test_playback_that_fell_behind_late_setpoints_catches_up_to_a_servo_delay_behind():
    """Setpoints that come later than the servo delay starve the playback; it must then make
    up the time (within the joints' limits), or every later move ends that much late."""
    start, end = [0.5, -0.3, 0.1], [0.8, 0.3, 0.1]
    ctrl = ArmController(HOME_JOINTS, servo_delay_s=0.08)
    quat = tool_down_quaternion(0.0)
    ctrl.set_setpoint(start, quat, stamp_s=0.0)
    run(ctrl, 3.0)
    ctrl.now = 10.0
    move = LinearMove.plan(ToolPose(*start, 0.0), ToolPose(*end, 0.0), Limits(0.25, 4.0))
    t, sent, qs, times, played = 10.0, 0, [], [], []
    late_from, late_until = 10.3, 10.6  # nothing arrives in between, then all of it at once
    while t < 10.0 + move.duration + 1.0:
        stamp = 10.0 + sent * 0.02
        while stamp <= t + 1e-12 and not late_from <= t < late_until:
            p = move.sample(min(stamp - 10.0, move.duration)).position
            assert ctrl.set_setpoint(p, quat, stamp_s=stamp).accepted
            sent += 1
            stamp = 10.0 + sent * 0.02
        t += DT
        qs.append(ctrl.step(DT, t)[0])
        times.append(t)
        played.append(ctrl.playback)
    qs = np.array(qs)
    # once moving at the stream's pace again (the joints' limits set the start from rest), the
    # pace ramps up and back down to the stream's, never a jump in speed
    moving = [p for p, tt in zip(played, times, strict=True)
              if late_until + DT < tt < 10.0 + move.duration]
    pace = np.diff(moving)
    pace = pace[int(np.argmax(pace >= DT - 1e-12)) + 1:]
    assert pace.max() > 1.2 * DT and np.all(np.abs(np.diff(pace)) <= CATCH_UP_RAMP * DT + 1e-9)
    steps = np.abs(np.diff(qs, axis=0))
    assert np.all(steps <= np.asarray(ur10e.JOINT_VELOCITY_LIMIT) * DT * (1 + 1e-3))
    assert off_line(qs, start, end) < 5e-4

    def lag_at(k: int) -> float:
        """How far (s of stream time) the arm trails where the stream was at t - delay."""
        p = tcp_pose(qs[k])[:3, 3]
        along = float(np.dot(p - np.asarray(start), np.subtract(end, start))
                      / np.linalg.norm(np.subtract(end, start)))
        expected = move.sample(times[k] - 0.08 - 10.0)
        length = float(np.linalg.norm(np.subtract(end, start)))
        return (expected.position - np.asarray(start)) @ np.subtract(end, start) / length - along

    starved = [k for k, tt in enumerate(times) if abs(tt - late_until) < DT]
    assert lag_at(starved[0]) > 0.05  # the starved arm fell well behind (metres along)
    recovered = [k for k, tt in enumerate(times) if abs(tt - (late_until + 1.5)) < DT]
    assert times[recovered[0]] < 10.0 + move.duration  # still moving
    assert abs(lag_at(recovered[0])) < 0.003  # back on the stream, a servo delay behind


def test_time_the_speed_slider_took_is_not_caught_up():
    start, end = [0.6, -0.2, 0.1], [0.8, 0.2, 0.1]
    ctrl = ArmController(HOME_JOINTS, servo_delay_s=0.08)
    ctrl.set_setpoint(start, tool_down_quaternion(0.0), stamp_s=0.0)
    run(ctrl, 3.0)
    ctrl.now = 10.0
    ctrl.set_speed_scaling(0.5)
    stream_line(ctrl, start, end, speed=0.5, t0=10.0, tail_s=0.0)
    ctrl.set_speed_scaling(1.0)
    before = ctrl.playback
    run(ctrl, 0.1)
    # at full speed again the playback goes on at the clock's pace, no faster
    assert ctrl.playback - before == pytest.approx(0.1, abs=2 * DT)
