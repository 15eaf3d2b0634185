"""A scene of the cell benchmark runs in a process of its own: one whose teardown hangs
(Fast DDS deadlocked once in 18 chaos scenes, the benchmark with it) is killed once its
metrics are written, and the benchmark goes on with them."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from nodes.bench.isolation import metrics_file, run_scene_isolated


def writes_then_hangs(blocks, density, seed, fault, timeout, workdir: Path) -> None:
    metrics_file(workdir, blocks, seed, fault).write_text(json.dumps({"outcome": "done"}))
    time.sleep(3600)  # a teardown that never ends


def dies_without_metrics(blocks, density, seed, fault, timeout, workdir: Path) -> None:
    raise SystemExit(3)


def test_a_scene_whose_teardown_hangs_is_killed_and_its_metrics_kept(tmp_path, capsys):
    m = run_scene_isolated(9, 0.1, 4, "chaos", 10.0, tmp_path, writes_then_hangs, grace_s=0.5)
    assert m == {"outcome": "done"}
    assert "did not end" in capsys.readouterr().out


def test_a_scene_that_ends_without_metrics_is_an_error_naming_it(tmp_path):
    with pytest.raises(RuntimeError, match=r"seed 4.*exit code 3"):
        run_scene_isolated(9, 0.1, 4, "none", 10.0, tmp_path, dies_without_metrics, grace_s=0.5)
