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
