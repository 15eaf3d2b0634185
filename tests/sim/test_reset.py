"""A new scene under a running cell (``lay_out``, what /sim/reset does in config/cell.yaml)
against the full reset: what each keeps and what each clears."""

from __future__ import annotations

import numpy as np

from msgs_py import BlockPose, Scene

from .conftest import WORKSPACE

NEW = Scene(WORKSPACE, 0.0508, (BlockPose(3, 0.80, 0.20, 0.4), BlockPose(5, 0.55, -0.2, 0.0)))


def _knock_out(world) -> None:
    """Push block 2 off the workspace: an event to be cleared."""
    world.hand.disturb(2, 0.09, 0.0)
    world.step(round(4.0 / world.config.dt))
    assert world.monitor.blocks_lost == 1


def test_a_new_scene_replaces_the_blocks_and_clears_the_events_but_keeps_clock_and_arm(
        world_factory):
    world = world_factory([(2, 0.92, 0.0, 0.0)])
    _knock_out(world)
    arm_before = np.array(world.arm_q())
    t_before = world.time_s
    world.lay_out(NEW)
    assert world.time_s == t_before  # the clock the cell's nodes run on does not go back
    assert np.allclose(world.arm_q(), arm_before)
    assert sorted(b.id for b in world.block_poses()) == [3, 5]
    assert world.monitor.blocks_lost == 0 and world.monitor.events == []
    world.step(24)
    poses = {b.id: b.pose for b in world.block_poses()}
    assert poses[3].distance_to(NEW.blocks[0].pose) < 1e-3
    assert world.time_s > t_before


def test_the_full_reset_also_starts_the_clock_again(world_factory):
    world = world_factory([(2, 0.92, 0.0, 0.0)])
    _knock_out(world)
    world.reset(NEW)
    assert world.time_s == 0.0
    assert sorted(b.id for b in world.block_poses()) == [3, 5]
    assert world.monitor.blocks_lost == 0
