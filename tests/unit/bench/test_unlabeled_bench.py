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
    opts = parser.parse_args(["--set", "random", "--k", "2", "--b", "1", "--density", "high"])
    opts.quick, opts.seeds = False, 2
    rows = unlabeled_bench.run(opts)
    assert [r["planner"] for r in rows] == ["labeled_pirs", "assignment_pirs", "pebble_graphs"]
    assert all(r["success_rate"] == 1.0 for r in rows)
    assert set(unlabeled_bench.COLUMNS) <= set(rows[-1])
