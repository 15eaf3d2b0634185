"""End to end: sim, detector, planner, executor and goal publisher in one process, over DDS.

A seeded 4-block scene must end with every block within 3 mm / 2 degrees of its 2x2 goal
by the simulator's ground truth, none lost, no unintended contact.
"""

from __future__ import annotations

import json
import math

import pytest
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from msgs_py import save_scene
from msgs_py.ros_codecs import block_set_from_markers, executor_status_from_string
from nodes.common.qos import LATCHED, RELIABLE
from nodes.executor.verify import goal_errors
from nodes.sim.layout import random_sim_scene

from .cell import start_cell

pytestmark = [pytest.mark.slow, pytest.mark.ros]


def test_four_blocks_reach_their_grid_with_every_node_in_one_process(ros, tmp_path):
    scene = random_sim_scene(4, 0.08, seed=3)
    scene_file = save_scene(scene, tmp_path / "four.yaml")
    start_cell(ros, scene_file)

    final = ros.wait_for_message(
        "/executor/status", String,
        lambda m: executor_status_from_string(m).state in ("done", "failed"),
        timeout=600, qos=LATCHED)
    status = executor_status_from_string(final)
    assert status.state == "done", status.last_error

    truth = block_set_from_markers(ros.wait_for_message("/sim/ground_truth", MarkerArray,
                                                        timeout=30, qos=RELIABLE))
    errors = goal_errors({b.id: b.pose for b in truth.blocks}, scene)
    assert len(errors) == 4
    for e in errors:
        assert e.position_error <= 0.003, e.describe()
        assert math.degrees(e.yaw_error) <= 2.0, e.describe()
    events = ros.wait_for_message("/sim/events", String, timeout=30, qos=LATCHED)
    summary = json.loads(events.data)
    assert summary["blocks_lost"] == 0
    assert summary["unintended_contacts"] == 0
