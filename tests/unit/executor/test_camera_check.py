"""Which block the start-of-run camera check re-grips, and how."""

from __future__ import annotations

from msgs_py import PickPlace, Pose2D, Workspace
from msgs_py.cell import GripperGeometry
from nodes.executor.camera_check import probe_actions, probe_block

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


def test_the_probe_sets_the_block_down_where_it_stands_once_per_closing_axis():
    at = Pose2D(0.7, 0.1, 0.4)
    assert probe_actions(3, at) == (PickPlace(3, at, at, 0), PickPlace(3, at, at, 1))
