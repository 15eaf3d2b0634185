"""The placement benchmark's measurement: a planned scene played on the simulated arm."""

from __future__ import annotations

import math

from msgs_py import Pose2D
from nodes.bench.placement import run_scene, yaw_error


def test_a_half_turn_is_no_yaw_error_and_a_quarter_turn_is():
    goal = Pose2D(0.6, 0.0, 0.3)
    assert yaw_error(Pose2D(0.6, 0.0, 0.3 + math.pi), goal) < 1e-9
    assert abs(yaw_error(Pose2D(0.6, 0.0, 0.3 + math.pi / 2), goal) - math.pi / 2) < 1e-9
    assert abs(yaw_error(Pose2D(0.6, 0.0, 0.29), goal) - 0.01) < 1e-9


def test_a_planned_scene_is_played_and_each_placement_measured():
    placed, why = run_scene(4, 0.1, 0)
    assert why == ""
    assert placed  # the plan has pick-and-places, each measured against the ground truth
    assert all(p.position_error < 0.002 and math.degrees(p.yaw_error) < 1.5 and p.stalls == 0
               for p in placed)
