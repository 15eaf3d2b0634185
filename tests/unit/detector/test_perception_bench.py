"""The perception benchmark's bookkeeping, on the detector's own synthetic frames."""

from __future__ import annotations

import argparse

from nodes.bench import perception as bench


def test_synthetic_run_reports_every_figure_and_meets_the_targets():
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--seeds", type=int)
    bench.add_arguments(parser)
    opts = parser.parse_args(["--renderer", "synthetic", "--seeds", "2"])
    rows = bench.run(opts)
    assert len(rows) == 1
    row = rows[0]
    assert set(bench.COLUMNS) <= set(row)
    assert row["scenes"] == 2 and row["detection_rate"] == 1.0
    assert row["false_detections"] == 0 and row["meets_targets"]


def test_scenes_hold_9_to_25_blocks_and_are_reproducible():
    sizes = [len(bench.scene_for(seed, 0.25).blocks) for seed in range(20)]
    assert min(sizes) >= 9 and max(sizes) <= 25 and len(set(sizes)) > 3
    assert bench.scene_for(3, 0.25) == bench.scene_for(3, 0.25)


def test_compare_rows_name_the_camera_and_the_detector_that_ignores_d():
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--seeds", type=int)
    bench.add_arguments(parser)
    opts = parser.parse_args(["--renderer", "synthetic", "--seeds", "1", "--compare",
                              "--repeats", "1"])
    rows = bench.run(opts)
    assert len(rows) == len(bench.VARIANTS)
    assert all(row["camera"].startswith("synthetic") for row in rows)
    assert sum("ignores d" in row["camera"] for row in rows) == 1
