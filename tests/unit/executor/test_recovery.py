"""Finding somewhere to set down a block the fingers were found holding."""

from __future__ import annotations

import math

import pytest

from msgs_py import Pose2D, Workspace
from msgs_py.cell import GripperGeometry
from nodes.executor.recovery import free_spot, holds_block, outside
from nodes.robot.reach import ur10e_reach

GEO = GripperGeometry.from_params({})
WS = Workspace(0.45, 0.95, -0.35, 0.35)


def test_gap_says_whether_a_block_is_held():
    assert holds_block(0.0505) and not holds_block(0.0) and not holds_block(GEO.approach_opening)
    assert not holds_block(0.02) and not holds_block(None)


def test_an_empty_table_gives_the_wanted_spot():
    spot = free_spot({}, WS, GEO, 0.0, (0.70, 0.10))
    assert (spot.x, spot.y) == pytest.approx((0.70, 0.10))


def test_the_spot_keeps_block_and_fingers_clear_of_perceived_blocks():
    perceived = {1: Pose2D(0.70, 0.10, 0.0)}
    spot = free_spot(perceived, WS, GEO, 0.0, (0.70, 0.10))
    # fingers close along x (tool yaw 0): the spot moves away along y, by a block + margin
    assert abs(spot.y - 0.10) >= 0.0508 + 0.008 - 1e-9 or abs(spot.x - 0.70) >= (
        0.0508 / 2 + GEO.finger_offset + GEO.finger_thickness / 2)


def test_a_full_table_gives_none():
    full = {k: Pose2D(0.47 + 0.03 * (k % 17), -0.33 + 0.03 * (k // 17), 0.0)
            for k in range(17 * 23)}
    assert free_spot(full, WS, GEO, 0.0, (0.7, 0.0)) is None


def test_no_spot_is_given_past_the_arms_working_reach():
    """A workspace whose far corner lies past the reach a plan may use (1.14 m out, as the
    25-block cell's): the spot nearest that corner is pulled back within it."""
    big = Workspace(0.36, 1.04, -0.475, 0.475)
    reach = ur10e_reach()
    spot = free_spot({}, big, GEO, 0.0, (1.04, 0.475))
    assert spot is not None
    assert reach.contains((spot.x, spot.y))
    assert math.hypot(spot.x, spot.y) > reach.r_max - 0.02  # as near the corner as it may be


def test_a_block_past_the_working_reach_counts_as_one_to_bring_in():
    big = Workspace(0.36, 1.04, -0.475, 0.475)
    perceived = {1: Pose2D(0.70, 0.0, 0.0), 2: Pose2D(1.00, 0.42, 0.0)}  # 1.08 m out
    assert big.contains_square(perceived[2], GEO.block_size)
    assert outside(perceived, big, GEO.block_size) == [2]
