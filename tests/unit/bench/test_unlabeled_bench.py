"""The unlabeled benchmark suite: its scenes and one tiny run."""

from __future__ import annotations

import argparse

from nodes.bench import unlabeled as unlabeled_bench
from nodes.common.scenes import random_scene


def test_grid_shapes_are_the_most_nearly_square():
    shapes = {k: unlabeled_bench.grid_shape(k) for k in (2, 3, 4, 6, 8, 9, 16)}
    assert shapes == {2: (1, 2), 3: (1, 3), 4: (2, 2), 6: (2, 3), 8: (2, 4), 9: (3, 3),
                      16: (4, 4)}


def test_scenes_are_the_random_scenes_of_the_other_benchmarks():
    ours = unlabeled_bench.bench_scene(9, 0.2, seed=5, labeled=False)
    theirs = random_scene(9, 0.2, seed=5, labeled=False)
    assert ours.blocks == theirs.blocks and ours.workspace == theirs.workspace
    assert ours.goal.grid == theirs.goal.grid and not ours.goal.labeled
    assert unlabeled_bench.bench_scene(9, 0.2, seed=5, labeled=True).goal.labeled


def test_a_tiny_run_reports_every_planner():
    parser = argparse.ArgumentParser()
    unlabeled_bench.add_arguments(parser)
    opts = parser.parse_args(["--set", "random", "--k", "2", "--b", "1", "--density", "high",
                              "--goal", "grid", "poses"])
    opts.quick, opts.seeds = False, 2
    rows = unlabeled_bench.run(opts)
    planners = ["default (portfolio)", "labeled_pirs", "assignment_pirs", "pebble_graphs"]
    assert [r["planner"] for r in rows] == planners * 2
    assert [r["goal"] for r in rows] == ["grid"] * 4 + ["poses"] * 4
    assert all(r["success_rate"] == 1.0 for r in rows)
    assert set(unlabeled_bench.COLUMNS) <= set(rows[-1])


def test_an_explicit_pose_goal_lists_the_grids_slots():
    grid = unlabeled_bench.bench_scene(9, 0.3, seed=2, labeled=False)
    poses = unlabeled_bench.bench_scene(9, 0.3, seed=2, labeled=False, goal_form="poses")
    assert poses.goal.grid is None and not poses.goal.labeled
    assert poses.goal.slot_poses(poses.block_size) == grid.goal.slot_poses(grid.block_size)
    assert poses.blocks == grid.blocks
