"""Blocks seen on the workspace's table margin are planned from just inside it."""

from __future__ import annotations

import pytest

from msgs_py import BlockPose, Goal, GoalSlot, Scene, Workspace
from nodes.planner.dispatch import pulled_inside

LAYOUT = Scene(Workspace(0.45, 0.95, -0.35, 0.35), 0.0508, (),
               Goal(slots=(GoalSlot(0.7, 0.0, 0.0, 1),)))


def test_a_block_over_the_edge_moves_straight_in_until_its_footprint_is_inside():
    over = BlockPose(1, 0.935, 0.1, 0.0)  # 10 mm over x_max
    inside = BlockPose(2, 0.7, 0.0, 0.3)
    pulled = pulled_inside((over, inside), LAYOUT, margin=0.05)
    assert pulled[1] == inside
    assert pulled[0].x == pytest.approx(0.95 - 0.0254, abs=1e-5)
    assert (pulled[0].y, pulled[0].theta) == (0.1, 0.0)
    assert LAYOUT.workspace.contains_square(pulled[0], 0.0508)
    LAYOUT.with_blocks(pulled)  # a valid scene now


def test_a_turned_block_is_pulled_in_by_its_turned_footprint():
    over = BlockPose(1, 0.7, -0.34, 0.785)  # 45 deg: reaches 35.9 mm from its centre
    pulled = pulled_inside((over,), LAYOUT, margin=0.05)[0]
    assert pulled.y == pytest.approx(-0.35 + 0.0359, abs=1e-4)


def test_a_block_beyond_the_margin_is_left_for_the_scene_to_refuse():
    far = BlockPose(1, 1.05, 0.0, 0.0)
    assert pulled_inside((far,), LAYOUT, margin=0.05) == (far,)
