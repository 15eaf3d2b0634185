"""Simulated time: lockstep with the motion commands, a real-time floor when none is in force."""

from __future__ import annotations

import pytest

from nodes.sim.pacing import HOLD_LEAD_S, LOCKSTEP_POLL_S, Pacer


def test_without_commands_time_follows_the_real_time_factor():
    pacer = Pacer(real_time_factor=2.0, margin=0.03)
    pacer.restart(0.0, wall_time=100.0)
    assert pacer.wait_before_step(0.0, 100.0) == 0.0
    assert pacer.wait_before_step(1.0, 100.0) == pytest.approx(0.5)  # 1 sim s = 0.5 wall s
    assert pacer.wait_before_step(1.0, 100.5) == pytest.approx(0.0)


def test_while_the_arm_moves_the_sim_waits_for_its_next_command():
    pacer = Pacer(real_time_factor=1.0, margin=0.03)
    pacer.restart(0.0, wall_time=100.0)
    pacer.on_command(5.08, moving=True, wall_time=100.0)
    assert pacer.wait_before_step(5.04, 100.0) == 0.0  # 5 s ahead of the wall: lockstep
    assert pacer.wait_before_step(5.05, 100.01) == LOCKSTEP_POLL_S  # its next piece is due
    pacer.on_command(5.18, moving=True, wall_time=100.02)
    assert pacer.wait_before_step(5.05, 100.02) == 0.0
    pacer.on_command(4.0, moving=False, wall_time=100.03)  # an older one changes nothing
    assert pacer.commanded_until == 5.18 and pacer.moving


def test_a_commander_holding_still_is_waited_for_while_it_keeps_sending():
    """The executor holds the arm while the fingers close: the robot's time, kept in lockstep
    so the nodes' latency does not become simulated time."""
    pacer = Pacer(real_time_factor=1.0, margin=0.03, hold_stall_wall_s=0.1)
    pacer.restart(0.0, wall_time=100.0)
    pacer.on_command(5.08, moving=False, wall_time=100.0)
    assert pacer.wait_before_step(5.0, 100.0) == 0.0
    assert pacer.wait_before_step(5.05, 100.05) == LOCKSTEP_POLL_S  # its next hold is due
    pacer.on_command(5.10, moving=False, wall_time=100.06)
    assert pacer.wait_before_step(5.05, 100.06) == 0.0


def test_a_commander_that_goes_quiet_holding_still_lets_time_pass_at_the_floor():
    pacer = Pacer(real_time_factor=1.0, margin=0.03, hold_stall_wall_s=0.1)
    pacer.restart(0.0, wall_time=100.0)
    pacer.on_command(5.08, moving=False, wall_time=100.0)
    assert pacer.wait_before_step(5.05, 100.05) == LOCKSTEP_POLL_S
    # quiet for longer than the hold stall: time goes on at the real-time rate
    assert pacer.wait_before_step(5.05, 100.2) == 0.0
    assert pacer.wait_before_step(5.4, 100.2) > 0.0


def test_a_commander_that_stops_mid_motion_falls_back_to_the_floor():
    pacer = Pacer(real_time_factor=1.0, margin=0.03, stall_wall_s=0.5)
    pacer.restart(0.0, wall_time=100.0)
    pacer.on_command(5.08, moving=True, wall_time=100.0)
    assert pacer.wait_before_step(5.06, 100.2) == LOCKSTEP_POLL_S
    # nothing for more than the stall time: time goes on at the real-time rate
    assert pacer.wait_before_step(5.06, 100.7) == 0.0
    assert pacer.wait_before_step(6.5, 100.7) > 0.0


def test_a_zero_factor_runs_free():
    pacer = Pacer(real_time_factor=0.0, margin=0.03)
    assert pacer.wait_before_step(123.0, 0.0) == 0.0


def test_a_hold_far_ahead_counts_only_a_short_lead_past_its_start():
    """A commander holding the arm waits for an event: the sim may not run far past it."""
    pacer = Pacer(real_time_factor=1.0, margin=0.03, hold_stall_wall_s=0.1)
    pacer.restart(0.0, wall_time=100.0)
    pacer.on_command(5.5, moving=False, wall_time=100.0, start=5.0)
    assert pacer.commanded_until == pytest.approx(5.0 + HOLD_LEAD_S)
    pacer.on_command(5.5, moving=True, wall_time=100.0, start=5.02)  # motion counts whole
    assert pacer.commanded_until == pytest.approx(5.5)
    pacer.on_command(5.6, moving=False, wall_time=100.0, start=5.04)  # the newest replaces it
    assert pacer.commanded_until == pytest.approx(5.04 + HOLD_LEAD_S) and not pacer.moving
    pacer.on_command(5.9, moving=True, wall_time=100.0, start=5.03)  # an older one: nothing
    assert pacer.commanded_until == pytest.approx(5.04 + HOLD_LEAD_S)
