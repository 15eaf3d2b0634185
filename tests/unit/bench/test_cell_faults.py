"""The cell benchmark's fault set-up: where a block is put, how far off the calibration is,
and what counts as success when a block is taken away."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from nodes.bench.cell import (
    CALIBRATION_TILT_DEG,
    FAULTS,
    calibration_off_args,
    free_spot_in,
)
from nodes.bench.cell_figures import is_success, summarise
from nodes.common.camera_model import load_camera_pose
from nodes.common.paths import config_path
from nodes.common.transforms import quaternion_to_matrix
from nodes.sim.layout import random_sim_scene


def test_the_added_block_lands_clear_of_every_block_and_goal_slot():
    scene = random_sim_scene(9, 0.10, 0)
    x, y = free_spot_in(scene)
    ws, s = scene.workspace, scene.block_size
    assert ws.x_min + s <= x <= ws.x_max - s and ws.y_min + s <= y <= ws.y_max - s
    taken = [(b.x, b.y) for b in scene.blocks] + [(p.x, p.y) for p in scene.goal.slot_poses(s)]
    assert min(math.hypot(x - tx, y - ty) for tx, ty in taken) > 2 * s


def test_the_calibration_fault_moves_the_detector_camera_5_mm_and_tilts_it_half_a_degree():
    args = calibration_off_args()
    assert args[0] == "-p" and args[1].startswith("detector:camera_pose.position:=")
    position = json.loads(args[1].split(":=")[1])
    quat = json.loads(args[3].split(":=")[1])
    true = load_camera_pose(config_path("camera_calibration.yaml"))
    assert math.dist(position, true.position) == pytest.approx(0.005, abs=1e-6)
    r = quaternion_to_matrix(true.orientation_xyzw).T @ quaternion_to_matrix(quat)
    angle = math.degrees(math.acos(np.clip((np.trace(r) - 1) / 2, -1, 1)))
    assert abs(angle - CALIBRATION_TILT_DEG) < 1e-3


def _metrics(**over):
    m = {"outcome": "done", "final_pos_err_max_m": 0.001, "final_yaw_err_max_deg": 0.5,
         "blocks_lost": [], "removed": None, "last_error": None}
    m.update(over)
    return m


def test_success_needs_every_block_home_and_none_lost():
    assert is_success(_metrics())
    assert not is_success(_metrics(final_pos_err_max_m=0.004))
    assert not is_success(_metrics(blocks_lost=[3]))
    assert not is_success(_metrics(outcome="failed"))


def test_a_block_left_in_the_fingers_is_no_success_even_as_a_documented_failure():
    assert is_success(_metrics(blocks_raised_at_end=[]))
    assert not is_success(_metrics(blocks_raised_at_end=[4]))
    named = "blocks [5] are no longer seen by the camera"
    assert not is_success(_metrics(outcome="failed", removed=5, last_error=named,
                                   blocks_raised_at_end=[5]))


def test_a_block_taken_away_succeeds_only_as_a_failure_that_names_it():
    named = "blocks [5] are no longer seen by the camera"
    assert is_success(_metrics(outcome="failed", removed=5, last_error=named))
    assert not is_success(_metrics(outcome="done", removed=5))
    assert not is_success(_metrics(outcome="failed", removed=6, last_error=named))


def test_all_is_every_kind_the_issue_names():
    assert {"grasp_miss", "slip", "drop", "misfire", "knuckle_misfire", "knock", "remove", "add",
            "detector_restart", "camera_noise", "calibration"} <= set(FAULTS)


def test_chaos_draws_a_node_and_a_moment_from_the_seed_and_fires_after_its_delay():
    from nodes.bench.cell import CHAOS_NODES, ChaosDraw

    draws = [ChaosDraw.of(seed, 9) for seed in range(30)]
    assert ChaosDraw.of(3, 9) == draws[3]  # the same seed, the same crash
    assert {d.node for d in draws} == set(CHAOS_NODES)  # every node gets its turn
    assert all(1 <= d.action < 9 and 0.0 <= d.delay_s <= 2.0 for d in draws)
    draw = ChaosDraw("arm", 2, "running", 1.0)
    assert not draw.due("running", 1, 10.0)  # not yet at its action
    assert not draw.due("observing", 2, 11.0)  # not in its state
    assert not draw.due("running", 2, 12.0)  # reached: its delay starts
    assert not draw.due("running", 2, 12.5)
    assert draw.due("observing", 3, 13.0)  # a second on, whatever the state by then


def test_the_look_pose_share_counts_the_looks_after_actions():
    from nodes.bench.cell_figures import look_pose_share

    assert look_pose_share({"on_the_way": 3, "from_waypoint": 5, "from_look_pose": 2}) == 0.2
    assert look_pose_share({}) is None
    # a look again from the park pose (a block the frame did not show) needed the arm away
    assert look_pose_share({"on_the_way": 3, "from_waypoint": 5, "from_look_pose": 1,
                            "again_from_park_pose": 1}) == 0.2


def test_a_stray_gripper_command_succeeds_only_when_the_gripper_refused_and_named_it():
    assert is_success(_metrics(fault="misfire", stray_refused=True))
    assert not is_success(_metrics(fault="misfire", stray_refused=False))  # handled late
    assert is_success(_metrics(stray_refused=None))  # any other kind: not asked


def test_the_row_keeps_each_scene_so_runs_split_by_seed_add_up():
    runs = [_metrics(seed=seed, success=True, notes=[], final_errors=[], actions_executed=11,
                     replans=0, unintended_contacts=seed, sim_time_s=60.0 + seed,
                     wall_time_s=50.0, looks={},
                     sim_time_by_activity_s={"look": 2.0 + seed % 2, "pick_place": 40.0})
            for seed in (30, 31)]
    runs[1]["sim_time_by_activity_s"]["look_wait"] = 4.0  # the other run never waited
    row = summarise(9, "none", runs)
    assert row["sim_time_by_activity_median_s"] == {"look": 2.5, "look_wait": 2.0,
                                                    "pick_place": 40.0}
    assert [(s["seed"], s["unintended_contacts"], s["sim_time_s"]) for s in row["per_scene"]] \
        == [(30, 30, 90.0), (31, 31, 91.0)]
    assert row["unintended_contacts"] == 61
