"""Worlds for the PyBullet tests (no ROS), driven through the arm node's own logic
(``SimArm``): the tests stream Cartesian setpoints as the executor does."""

from __future__ import annotations

import pytest

from msgs_py import BlockPose, Scene, Workspace
from nodes.bench.sim_arm import SimArm
from nodes.sim.config import CameraConfig, SimConfig
from nodes.sim.world import SimWorld

WORKSPACE = Workspace(0.45, 0.95, -0.35, 0.35)


def make_world(blocks, **config) -> SimArm:
    scene = Scene(WORKSPACE, 0.0508, tuple(BlockPose(*b) for b in blocks))
    return SimArm(SimWorld(SimConfig(**config), CameraConfig().model(), scene))


@pytest.fixture
def world_factory():
    worlds = []

    def factory(blocks, **config):
        worlds.append(make_world(blocks, **config))
        return worlds[-1]

    yield factory
    for w in worlds:
        w.close()
