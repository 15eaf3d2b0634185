"""The soak's pure figures: a goal's own counts out of the executor's lifetime ones, what a
goal inherited, the shift's windows and verdicts."""

from __future__ import annotations

import math

import pytest

from msgs_py import BlockPose, BlockSet, Plan, Scene
from nodes.bench.soak_figures import (
    flat_row,
    fresh_start_problems,
    goal_counts,
    memory_growth,
    reset_time_s,
    summarise,
    windows,
)
from nodes.sim.layout import random_sim_scene

SCENE = random_sim_scene(4, 0.1, 3)


def test_a_goals_counts_are_the_difference_over_it_and_a_respawn_starts_again():
    before = {"actions_executed": 11.0, "faults": 1.0, "time_look_s": 20.0, "replans": 2.0}
    after = {"actions_executed": 20.0, "faults": 1.0, "time_look_s": 31.5, "faults_dropped": 1.0,
             "replans": 0.0, "corrections": 0.0}
    assert goal_counts(before, after) == {"actions_executed": 9.0, "faults": 0.0,
                                          "time_look_s": 11.5, "faults_dropped": 1.0}
    restarted = goal_counts(before, {"actions_executed": 4.0})
    assert restarted == {"actions_executed": 4.0}


def _plan(blocks) -> Plan:
    return Plan(actions=(), scene=Scene(SCENE.workspace, SCENE.block_size, tuple(blocks),
                                        SCENE.goal))


def test_a_fresh_goal_has_nothing_inherited():
    seen = BlockSet(SCENE.blocks, block_size=SCENE.block_size)
    assert fresh_start_problems(SCENE, seen, _plan(SCENE.blocks), 0, 0) == []


def test_what_a_goal_inherited_is_named():
    last_end = [BlockPose(b.id, b.x + 0.03, b.y, b.theta) for b in SCENE.blocks]
    seen = BlockSet(SCENE.blocks[:3], block_size=SCENE.block_size)
    problems = fresh_start_problems(SCENE, seen, _plan(last_end), 2, 0)
    assert len(problems) == 3
    assert "shows blocks [0, 1, 2]" in problems[0]
    assert "30 mm from where the scene put it" in problems[1]
    assert "2 contacts" in problems[2]
    assert fresh_start_problems(SCENE, None, None, None, None) == [
        "no detection of the new scene before the goal"]


def test_the_reset_time_is_read_from_the_sims_answer():
    assert reset_time_s("reset: 9 blocks at t = 83.250 s") == pytest.approx(83.25)
    assert reset_time_s("something else") is None


@pytest.mark.parametrize(("goals", "reference", "early", "late"), [
    (200, 10, (10, 59), (151, 200)),
    (5, 2, (2, 3), (4, 5)),
    (2, 1, (1, 1), (2, 2)),
])
def test_windows_are_issue_29s_for_a_long_shift_and_shrink_for_a_short_one(
        goals, reference, early, late):
    w = windows(goals)
    assert (w.reference, w.early, w.late) == (reference, early, late)


def _rows(rss, walls, outcomes=None, inherited=None):
    n = len(walls)
    return [{"goal": k + 1, "outcome": (outcomes or ["done"] * n)[k], "lost": 0,
             "wall_s": walls[k], "inherited": (inherited or [""] * n)[k],
             "rss_mb": {"sim": rss[k], "executor": 100.0}, "cpu_s": {"sim": 1.0, "executor": None}}
            for k in range(n)]


def test_memory_growth_is_measured_from_the_reference_goal():
    rows = _rows([300.0, 350.0, 360.0, 400.0], [100.0] * 4)
    assert memory_growth(rows, 2) == pytest.approx({"sim": 400 / 350 - 1, "executor": 0.0})


def test_a_flat_shift_meets_the_targets_and_a_growing_one_does_not():
    flat = summarise(_rows([300.0] * 6, [100.0, 101.0, 99.0, 100.0, 102.0, 100.0]))
    assert all(flat["targets"].values()), flat
    leaking = summarise(_rows([300.0, 300.0, 300.0, 320.0, 340.0, 360.0],
                              [100.0, 100.0, 100.0, 120.0, 125.0, 130.0],
                              outcomes=["done"] * 4 + ["failed", "failed"],
                              inherited=[""] * 5 + ["the sim's events began at 1 contacts"]))
    assert leaking["memory_growth_worst"] == "sim"
    assert not any(leaking["targets"][k] for k in ("done", "fresh", "memory", "wall_flat"))
    assert leaking["wall_ratio"] == pytest.approx(127.5 / 110.0)  # goals 5-6 vs 3-4


def test_a_row_for_the_table_spreads_the_processes_into_columns():
    row = flat_row(_rows([300.0], [100.0])[0], ["sim", "executor", "arm"])
    assert row["rss_sim_mb"] == 300.0 and row["rss_arm_mb"] is None
    assert row["cpu_total_s"] == 1.0 and "rss_mb" not in row
    assert not math.isnan(row["wall_s"])


def test_the_memory_target_is_the_cells_processes_and_the_client_is_reported_beside():
    rows = _rows([300.0] * 6, [100.0] * 6)
    for k, row in enumerate(rows):
        row["rss_mb"]["client"] = 100.0 + 5.0 * k  # the benchmark's own process grows
    summary = summarise(rows)
    assert summary["targets"]["memory"] and "client" not in summary["memory_growth"]
    assert summary["client_memory_growth"] == pytest.approx(125.0 / 110.0 - 1)  # from goal 3
