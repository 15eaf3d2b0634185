"""Playing scripts on the setpoint stream: a held-up executor keeps its path."""

from __future__ import annotations

from nodes.executor.core import ExecutorCore
from nodes.executor.states import State
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


def test_the_setpoints_ahead_follow_the_script_and_hold_where_it_waits():
    """Ahead of the clock the script streams what it will do if nothing happens: along a
    move, then holding where a move waits for the measured tool or a grip for the fingers."""
    from nodes.executor.decisions import ActionDone, Script
    from nodes.executor.motion import ToolPose
    from nodes.executor.player import Player
    from nodes.executor.steps import Grip, Move

    start = ToolPose(0.5, 0.0, 0.1, 0.0)
    end = ToolPose(0.6, 0.0, 0.1, 0.0)
    lift = ToolPose(0.6, 0.0, 0.2, 0.0)
    player = Player(CFG)
    player.start(Script([Move(end, CFG.travel_limits, "out"), Grip(0.0, 0.3, "grip"),
                         Move(lift, CFG.travel_limits, "up")], ActionDone()), 0.0, start)
    player.advance(0.0, start, 0.0, [])
    ahead = player.ahead(0.0, 0.1, 0.02)
    assert [round(t, 3) for t, _ in ahead] == [0.02, 0.04, 0.06, 0.08, 0.1]
    xs = [p.x for _, p in ahead]
    assert all(a <= b for a, b in zip(xs, xs[1:], strict=False)) and xs[-1] > start.x
    # at the move's end: it holds there (the measured tool has not come), never lifts
    t = 0.0
    while player.runner.current_step.label == "out":
        t += 0.02
        tick = player.advance(t, tick.setpoint if t > 0.02 else start, t, [])
    far = player.ahead(t, 0.5, 0.02)
    assert len(far) == 1 and far[0][1].distance_to(end) < 1e-9  # no hold streamed ahead
