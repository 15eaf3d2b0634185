"""Playing scripts on the setpoint stream: a held-up executor keeps its path."""

from __future__ import annotations

import pytest

from nodes.executor.core import ExecutorCore
from nodes.executor.decisions import ActionDone, Script
from nodes.executor.motion import ToolPose
from nodes.executor.player import MAX_BACKFILL_S, Player
from nodes.executor.states import State
from nodes.executor.steps import Move
from tests.unit.executor.world import (
    CFG,
    DT,
    START,
    World,
    two_action_plan,
)


def test_a_held_up_executor_resumes_its_trajectory_where_it_was():
    """Ticks that come late (a loaded machine) must not make the setpoints jump along the
    path: consecutive setpoints stay within two ticks of travel of each other."""
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.RUNNING)
    t, last, biggest = 50.0, core.player.commanded, 0.0
    for k in range(400):
        t += DT if k % 10 else 0.5  # every tenth tick comes half a second late
        out = core.tick(t)
        if out.setpoint is not None:
            biggest = max(biggest, out.setpoint.distance_to(last))
            last = out.setpoint
            core.on_tcp(out.setpoint)
    assert 0.0 < biggest <= 2.0 * DT * CFG.speed * 1.01


def _play(tick_times: list[float]) -> tuple[list[tuple[float, ToolPose]], Player]:
    """(time, setpoint) streamed for a corner, a blended corner and a converged end, ticked
    at ``tick_times``, the arm tracking every setpoint the moment it is streamed."""
    r = CFG.blend_radius
    steps = [Move(ToolPose(0.6, 0.0, 0.1, 0.0), CFG.travel_limits, "out", blend=r),
             Move(ToolPose(0.6, 0.3, 0.1, 0.5), CFG.travel_limits, "across", converge=False),
             Move(ToolPose(0.6, 0.3, 0.02, 0.5), CFG.vertical_limits, "down")]
    player = Player(CFG)
    player.start(Script(steps, ActionDone()), tick_times[0], ToolPose(0.4, 0.0, 0.1, 0.0))
    streamed: list[tuple[float, ToolPose]] = []
    tcp = None
    for t in tick_times:
        tick = player.advance(t, tcp, None if tcp is None else streamed[-1][0], [])
        streamed += [*tick.missed, (t, tick.setpoint)]
        tcp = tick.setpoint
        if tick.done:
            break
    return streamed, player


def test_a_tick_that_comes_a_few_periods_late_streams_the_ticks_it_missed():
    """A tick 2-7 periods late (the sim's lockstep lets its clock run on while a tick computes)
    streams the setpoints the missed ticks would have, at their times: the script keeps the
    clock's pace and the path its corners. Only the end comes later: it waits for the arm to
    be measured there, and the late ticks bring measurements later."""
    on_time = [k * DT for k in range(400)]
    late = [t for k, t in enumerate(on_time) if k % 7 not in (3, 4, 5)]  # every 7th: 4 late
    expected, _ = _play(on_time)
    streamed, _ = _play(late)
    assert len(expected) - 1 <= len(streamed) <= len(expected) + 4
    moving = len(expected) - 1
    for (t, pose), (t_expected, pose_expected) in zip(streamed[:moving], expected[:moving],
                                                       strict=True):
        assert t == pytest.approx(t_expected)
        assert pose.distance_to(pose_expected) < 1e-9 and pose.yaw == pytest.approx(
            pose_expected.yaw)


def test_a_tick_later_than_the_backfill_resumes_the_script_where_it_was():
    """Half a second without a tick (the arm has stopped at the end of its stream): nothing
    missed is streamed, the script goes on two ticks further than it was."""
    on_time = [k * DT for k in range(30)]
    _, player = _play(on_time)
    before = player.commanded
    tick = player.advance(on_time[-1] + MAX_BACKFILL_S + 0.3, before, on_time[-1], [])
    assert tick.missed == ()
    assert 0.0 < tick.setpoint.distance_to(before) <= 2 * DT * CFG.speed * 1.01
