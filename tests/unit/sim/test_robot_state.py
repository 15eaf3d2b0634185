"""The simulated UR's safety mode, program and dashboard, as its driver reports them."""

from __future__ import annotations

import pytest

from msgs_py.drivers import (
    ROBOT_POWER_OFF,
    ROBOT_RUNNING,
    SAFETY_NORMAL,
    SAFETY_PROTECTIVE_STOP,
)
from nodes.sim.robot_state import PROGRAM_START_S, RobotState


def test_a_protective_stop_needs_unlock_then_stop_and_play():
    state = RobotState(unlock_after_s=5.0)
    assert state.can_move
    state.protective_stop(10.0, "30 N on the robot")
    assert state.safety_mode == SAFETY_PROTECTIVE_STOP and not state.program_running
    assert not state.can_move
    early = state.dashboard("unlock_protective_stop", 12.0)
    assert not early.success and "5s after occurrence" in early.message
    assert not state.dashboard("play", 12.0).success  # still stopped: play fails
    assert state.dashboard("unlock_protective_stop", 15.5).success
    assert state.safety_mode == SAFETY_NORMAL and not state.can_move  # the program is paused
    assert state.dashboard("stop", 15.6).success
    answer = state.dashboard("play", 15.7)
    assert answer.success and answer.message == "Starting program"
    state.step(15.7 + PROGRAM_START_S / 2)
    assert not state.program_running  # it takes a moment to start
    state.step(15.7 + PROGRAM_START_S + 0.01)
    assert state.program_running and state.can_move


def test_unlock_outside_a_protective_stop_is_refused():
    answer = RobotState().dashboard("unlock_protective_stop", 1.0)
    assert not answer.success and "normal" in answer.message


def test_power_off_needs_power_on_and_brake_release():
    state = RobotState()
    state.dashboard("power_off", 1.0)
    assert state.robot_mode == ROBOT_POWER_OFF and not state.can_move
    assert not state.dashboard("brake_release", 1.1).success
    state.dashboard("power_on", 1.2)
    assert state.dashboard("brake_release", 1.3).success and state.robot_mode == ROBOT_RUNNING
    state.dashboard("play", 1.4)
    state.step(1.4 + PROGRAM_START_S + 0.01)
    assert state.can_move


def test_the_slider_is_a_fraction_and_unknown_calls_are_refused():
    state = RobotState(speed_slider=0.3)
    assert state.speed_scaling == 0.3
    with pytest.raises(ValueError):
        state.set_speed_slider(1.5)
    assert not state.dashboard("self_destruct", 0.0).success
