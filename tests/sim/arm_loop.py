"""Play executor step scripts on a SimWorld for the sim tests: ``nodes.bench.sim_play``,
an error failing the test."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from nodes.bench.sim_play import play as play_steps
from nodes.bench.sim_play import tool_pose
from nodes.executor.config import ExecutorConfig
from nodes.executor.steps import Step, StepRunner
from nodes.sim.world import SimWorld

__all__ = ["play", "tool_pose"]


def play(world: SimWorld, steps: Sequence[Step], cfg: ExecutorConfig,
         on_label: Callable[[SimWorld, str], None] = lambda w, label: None,
         on_tick: Callable[[SimWorld], None] = lambda w: None) -> StepRunner:
    """Run ``steps`` to their end; ``on_label`` is called when a new step starts, ``on_tick``
    every tick (fault injection, measurements)."""
    runner, error = play_steps(world, steps, cfg, on_label, on_tick)
    assert not error, error
    return runner
