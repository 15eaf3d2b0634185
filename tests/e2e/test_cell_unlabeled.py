"""End to end, the latched-topic style: the whole cell (sim, detector, planner, executor and
the goal node publishing /goal_layout) fills an unlabeled 2x2 grid in simulation; every slot
ends with some block on it (ground truth)."""

from __future__ import annotations

import math

import pytest
from densepack_interfaces.msg import BlockPoseArray, ExecutorStatus
from densepack_interfaces.msg import Plan as PlanMsg

from msgs_py import interface_codecs as ic
from msgs_py import load_scene
from nodes.common.paths import config_path
from nodes.common.qos import LATCHED
from nodes.planner.unlabeled.goal_check import unfilled_slots

from .cell import start_cell

pytestmark = [pytest.mark.ros, pytest.mark.slow]

SCENE = "scenes/unlabeled_small.yaml"
#: Ground-truth tolerance: the executor's own check (1 mm / 1.5 deg on the detection) plus
#: the detector's error against the truth.
TOL_XY, TOL_YAW = 0.004, math.radians(3.0)


def test_cell_fills_an_unlabeled_grid(ros):
    start_cell(ros, config_path(SCENE))

    plan = ros.wait_for_message("/plan", PlanMsg, timeout=120, qos=LATCHED)
    assert plan.planner in ("pebble_graphs", "assignment_pirs")
    final = ros.wait_for_message(
        "/executor/status", ExecutorStatus, qos=LATCHED, timeout=900,
        predicate=lambda m: m.state in (ExecutorStatus.STATE_DONE, ExecutorStatus.STATE_FAILED))
    assert final.state == ExecutorStatus.STATE_DONE, final.last_error
    truth = ic.block_set_from_msg(ros.wait_for_message("/sim/ground_truth", BlockPoseArray,
                                                       timeout=30))
    scene = load_scene(config_path(SCENE))
    assert unfilled_slots(scene, [b.pose for b in truth.blocks], TOL_XY, TOL_YAW) == []
