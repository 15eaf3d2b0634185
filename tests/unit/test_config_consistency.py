"""The nodes' parameter files agree where they describe the same physical thing."""

from __future__ import annotations

import math

import pytest
import yaml

from nodes.common.paths import config_path
from nodes.sim import robot_model as rm


def params(name: str) -> dict:
    return yaml.safe_load(config_path(name).read_text())["/**"]["ros__parameters"]


def test_planner_fingers_are_the_sims_fingers():
    planner = params("planner.yaml")
    assert planner["finger_thickness"] == pytest.approx(rm.FINGER_THICKNESS)
    assert planner["finger_width"] == pytest.approx(rm.FINGER_WIDTH)
    opening = 0.0508 + 2 * planner["approach_clearance"]
    assert opening <= 0.085  # the 2F-85's stroke


def test_executor_and_planner_agree_on_what_counts_as_placed():
    planner, executor = params("planner.yaml"), params("executor.yaml")
    assert planner["goal_tolerance_xy"] == pytest.approx(executor["pos_tolerance"])
    assert planner["goal_tolerance_yaw"] == pytest.approx(
        math.radians(executor["yaw_tolerance_deg"]), abs=1e-4)


def test_executor_accepts_what_the_planner_leaves_near_its_goal():
    planner, executor = params("planner.yaml"), params("executor.yaml")
    assert planner["near_goal_tolerance_xy"] == pytest.approx(executor["accept_pos_tolerance"])
    assert planner["near_goal_tolerance_yaw"] == pytest.approx(
        math.radians(executor["accept_yaw_tolerance_deg"]), abs=1e-4)


def test_executor_parks_where_the_sim_keeps_the_camera_clear():
    sim, executor = params("sim.yaml"), params("executor.yaml")
    assert executor["park_pose"][:3] == pytest.approx(sim["park_position"])
