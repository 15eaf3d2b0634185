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
    # four looks, each at rest for the camera (World's detection comes 0.3 s after a trigger)
    assert metrics["time_look_wait_s"] > 4 * 0.3
    assert metrics["time_look_s"] > 0  # getting out of view
    charged = sum(v for k, v in metrics.items() if k.startswith("time_"))
    assert charged == pytest.approx(world.t_end, abs=0.1)
