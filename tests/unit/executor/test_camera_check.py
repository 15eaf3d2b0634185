"""Which block the start-of-run camera check grips in place, and how."""

from __future__ import annotations

import math

from msgs_py import PickPlace, Pose2D, Workspace
from msgs_py.cell import GripperGeometry
from nodes.executor.camera_check import probe_actions, probe_block, probe_steps
from nodes.executor.config import ExecutorConfig
from nodes.executor.steps import Grip, Move, Rise

TABLE = Workspace(0.45, 0.95, -0.35, 0.35)
GEO = GripperGeometry()


def test_the_block_with_room_on_every_side_nearest_the_centre_is_chosen():
    perceived = {
        1: Pose2D(0.70, 0.00, 0.0), 2: Pose2D(0.7538, 0.0, 0.0),  # a tight pair in the centre
        3: Pose2D(0.60, -0.25, 0.3),  # alone, near a corner
        4: Pose2D(0.80, 0.20, 0.0),  # alone, nearer the centre
    }
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.015) == 4


def test_a_neighbour_across_either_closing_axis_rules_a_block_out():
    # block 2 stands 95 mm from block 1 along y: fingers closing along y come within 15 mm
    perceived = {1: Pose2D(0.70, 0.00, 0.0), 2: Pose2D(0.70, 0.095, 0.0)}
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.015) is None
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.0) is not None


def test_a_block_whose_fingers_leave_the_table_is_not_chosen():
    perceived = {1: Pose2D(0.46, 0.0, 0.0)}
    assert probe_block(perceived, GEO, TABLE, clearance=0.016, margin=0.015) is None


def test_the_check_is_one_entry_that_leaves_the_block_where_it_stands():
    at = Pose2D(0.7, 0.1, 0.4)
    assert probe_actions(3, at) == (PickPlace(3, at, at, 0),)


def test_the_fingers_grip_along_one_axis_then_turn_over_the_block_and_grip_along_the_other():
    cfg = ExecutorConfig()
    at = Pose2D(0.7, 0.1, 0.4)
    steps = probe_steps(3, at, GEO, cfg, opening=0.085)
    grips = [s for s in steps if isinstance(s, Grip) and s.holds is not None]
    assert [(g.holds, g.squares) for g in grips] == [(3, False), (3, True)]
    # follow the commanded tool: x, y never leave the block; the yaw turns a quarter turn
    # between the grips, only with the fingertips over the block's top
    z, yaw, yaws_at_grip = cfg.travel_height, None, []
    for step in steps:
        if isinstance(step, Move):
            assert (step.target.x, step.target.y) == (at.x, at.y)
            if yaw is not None and abs(step.target.yaw - yaw) > 1e-9:
                assert min(z, step.target.z) > GEO.block_size, step.label
            z, yaw = step.target.z, step.target.yaw
        elif isinstance(step, Rise):
            z = max(z, step.z)
        elif step in grips:
            assert z == cfg.grasp_height
            yaws_at_grip.append(yaw)
    turn = math.remainder(yaws_at_grip[1] - yaws_at_grip[0], math.pi)
    assert abs(abs(turn) - math.pi / 2) < 1e-9
    assert math.remainder(yaws_at_grip[0] - at.theta, math.pi / 2) == 0.0
    # the fingers open fully after each grip, and the tool ends at travel height
    after = [steps[steps.index(g) + 1] for g in grips]
    assert all(isinstance(s, Grip) and s.holds is None and s.opening == 0.085 for s in after)
    assert z == cfg.travel_height
