"""A short shift on one cell (densepack-bench soak, as a user runs it): two goals from two
seeded scenes, the second laid out by /sim/reset under the running cell. Each goal must end
done with every block at its goal, start afresh (the new scene seen, its first plan made
from it, the sim's events back at zero), on a clock that ran on, with every process's
memory and CPU time recorded."""

from __future__ import annotations

import json
import subprocess

import pytest

from nodes.bench.soak import PROCESSES
from tests.helpers import REPO, tool

pytestmark = [pytest.mark.slow, pytest.mark.ros]


def test_two_goals_on_one_cell_each_start_afresh_and_are_done(tmp_path):
    out = tmp_path / "soak.json"
    done = subprocess.run([*tool("bench"), "soak", "--goals", "2", "--blocks", "2",
                           "--density", "0.08", "--first-seed", "3", "--keep", str(tmp_path),
                           "--json", str(out)], cwd=REPO, capture_output=True, text=True,
                          timeout=1200)
    log = (tmp_path / "cell.log").read_text() if (tmp_path / "cell.log").exists() else ""
    assert done.returncode == 0, done.stdout + done.stderr + log[-3000:]
    rows = json.loads(out.read_text())["rows"]
    goals, summary = rows[:-1], rows[-1]
    assert [r["goal"] for r in goals] == [1, 2] and summary["goal"] == "all"
    for row in goals:
        assert row["outcome"] == "done" and row["success"], row
        assert row["inherited"] == "" and row["lost"] == 0, row
        assert row["actions"] >= 1 and row["sim_s"] > 0
        for name in PROCESSES:
            assert row[f"rss_{name}_mb"] > 10.0, (name, row)
    per_goal = [json.loads((tmp_path / f"goal_00{k}.json").read_text()) for k in (1, 2)]
    assert per_goal[1]["sim_start_s"] >= per_goal[0]["sim_start_s"] + per_goal[0]["sim_s"]
    for row in per_goal:
        assert all(row["cpu_s"][name] is not None for name in PROCESSES), row["cpu_s"]
    assert summary["done"] == 2 and summary["targets"]["fresh"]
