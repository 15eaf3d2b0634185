"""End to end: the whole cell (sim, detector, planner, executor, goal) fills an unlabeled
2x2 grid in simulation; every slot ends with some block on it (ground truth)."""

from __future__ import annotations

import json
import math

import pytest
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from msgs_py import load_scene
from msgs_py.ros_codecs import block_set_from_markers
from nodes.common.paths import config_path
from nodes.common.qos import LATCHED
from nodes.planner.unlabeled.goal_check import unfilled_slots

from .cell import start_cell

pytestmark = [pytest.mark.ros, pytest.mark.slow]

SCENE = "scenes/unlabeled_small.yaml"
#: Ground-truth tolerance: the executor's own check (2 mm / 1.5 deg on the detection) plus
#: the detector's error against the truth.
TOL_XY, TOL_YAW = 0.004, math.radians(3.0)


def test_cell_fills_an_unlabeled_grid(ros):
    start_cell(ros, config_path(SCENE))

    plan = json.loads(ros.wait_for_message("/plan", String, timeout=120, qos=LATCHED).data)
    assert plan["planner"] == "pebble_graphs"
    final = ros.wait_for_message(
        "/executor/status", String, qos=LATCHED, timeout=900,
        predicate=lambda m: json.loads(m.data)["state"] in ("done", "failed"))
    status = json.loads(final.data)
    assert status["state"] == "done", status["last_error"]
    truth = block_set_from_markers(ros.wait_for_message("/sim/ground_truth", MarkerArray,
                                                        timeout=30))
    scene = load_scene(config_path(SCENE))
    assert unfilled_slots(scene, [b.pose for b in truth.blocks], TOL_XY, TOL_YAW) == []
