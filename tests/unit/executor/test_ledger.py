"""Where a run's simulated time goes, charged per activity."""

from __future__ import annotations

import pytest

from nodes.executor.core import ExecutorCore
from nodes.executor.states import State
from tests.unit.executor.world import (
    CFG,
    START,
    World,
    two_action_plan,
)


def test_simulated_time_is_charged_to_actions_and_looking():
    core = ExecutorCore(CFG)
    world = World(core, START)
    core.on_plan(two_action_plan())
    world.run(lambda: core.state is State.DONE)
    metrics = core.status().metrics
    assert metrics["time_pick_place_s"] > 0 and metrics["time_push_s"] > 0
    assert metrics["time_look_s"] > 4 * 0.3  # four looks, each waiting for the camera
    charged = sum(v for k, v in metrics.items() if k.startswith("time_"))
    assert charged == pytest.approx(world.t_end, abs=0.1)
