"""Dense starts: where uniform draws jam, the generator searches the gaps left."""

from __future__ import annotations

import numpy as np

from msgs_py import BlockPose, Workspace
from msgs_py.cell import BLOCK_SIZE
from msgs_py.footprint import block_polygon
from nodes.bench import instances
from nodes.common.scenes import random_scene

S = BLOCK_SIZE


def test_a_gap_too_small_for_uniform_draws_is_found():
    # a row of blocks in a strip 1.6 blocks deep (any yaw fits), one gap 1.6 blocks wide
    depth, pitch = 1.6 * S, S + 0.005
    ws = Workspace(0.60, 0.60 + 4 * pitch + depth, 0.0, depth)
    xs = [0.60 + 0.5 * pitch + k * pitch for k in (0, 1)]
    xs += [xs[-1] + 0.5 * pitch + depth + 0.5 * pitch + k * pitch for k in (0, 1)]
    taken = [block_polygon(x, ws.center[1], 0.0, S + 2 * instances.MIN_GAP) for x in xs]
    pose = instances.gap_pose(7, ws, taken, np.random.default_rng(0))
    assert pose is not None and ws.contains_square(pose, S)
    mine = block_polygon(pose.x, pose.y, pose.theta, S + 2 * instances.MIN_GAP)
    assert not any(mine.intersects(t) for t in taken)
    full = [*taken, mine]
    assert instances.gap_pose(8, ws, full, np.random.default_rng(0)) is None


def test_seeds_that_drew_before_keep_their_scene():
    ours = instances.instance("random", 9, 0.3, 4)
    assert ours.blocks == random_scene(9, 0.3, seed=4).blocks


def test_dense_starts_keep_their_gaps(monkeypatch):
    monkeypatch.setattr(instances, "ATTEMPTS", 30)  # jam early: the gap search places most
    scene = instances.instance("random", 9, 0.3, 1)
    grown = [block_polygon(b.x, b.y, b.theta, S + 2 * instances.MIN_GAP - 1e-6)
             for b in scene.blocks]
    assert all(not a.intersects(b) for i, a in enumerate(grown) for b in grown[i + 1:])
    assert all(isinstance(b, BlockPose) and scene.workspace.contains_square(b, S)
               for b in scene.blocks)
