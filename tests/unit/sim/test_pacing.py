"""Simulated time: lockstep with the motion commands, a real-time floor when none is in force."""

from __future__ import annotations

import pytest

from nodes.sim.pacing import Pacer


def test_without_commands_time_follows_the_real_time_factor():
    pacer = Pacer(real_time_factor=2.0, margin=0.02)
    pacer.restart(0.0, wall_time=100.0)
    assert pacer.wait_before_step(0.0, 100.0) == 0.0
    assert pacer.wait_before_step(1.0, 100.0) == pytest.approx(0.5)  # 1 sim s = 0.5 wall s
    assert pacer.wait_before_step(1.0, 100.5) == pytest.approx(0.0)


def test_while_commands_come_it_runs_free_but_never_outruns_the_newest_one():
    pacer = Pacer(real_time_factor=1.0, margin=0.02)
    pacer.restart(0.0, wall_time=100.0)
    pacer.on_command(5.08)
    assert pacer.wait_before_step(5.05, 100.0) == 0.0  # 5 s ahead of the wall: lockstep
    # the commander is behind: time goes on only at the real-time rate from where it stopped
    assert pacer.wait_before_step(5.07, 100.0) == pytest.approx(0.02, abs=1e-9)
    pacer.on_command(5.18)
    assert pacer.wait_before_step(5.07, 100.001) == 0.0
    pacer.on_command(4.0)  # an older stamp changes nothing
    assert pacer.commanded_until == 5.18


def test_stalled_commands_fall_back_to_real_time_from_where_it_stalled():
    pacer = Pacer(real_time_factor=1.0, margin=0.02)
    pacer.restart(0.0, wall_time=100.0)
    pacer.on_command(5.08)
    assert pacer.wait_before_step(5.0, 100.0) == 0.0
    # nothing new for a wall second: time goes on at the real-time rate from 5.0 s
    assert pacer.wait_before_step(5.07, 100.0) > 0.0
    assert pacer.wait_before_step(5.5, 101.0) == 0.0
    assert pacer.wait_before_step(6.5, 101.0) == pytest.approx(0.5, abs=1e-9)


def test_a_zero_factor_runs_free():
    pacer = Pacer(real_time_factor=0.0, margin=0.02)
    assert pacer.wait_before_step(123.0, 0.0) == 0.0
