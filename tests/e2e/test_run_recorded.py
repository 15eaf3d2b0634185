"""densepack-run as a user runs it (its own process, the cell's nodes in theirs) records the
run into its report folder and draws the timeline: the bag is read back with the mcap reader
(not rosbags, which wrote it) and agrees with the report."""

from __future__ import annotations

import json
import subprocess
from collections import Counter

import cv2
import pytest
from densepack_interfaces.msg import ExecutorStatus

from tests.helpers import REPO, read_mcap, tool

from .scenes import two_block_scene

pytestmark = [pytest.mark.slow, pytest.mark.ros]


def test_a_run_is_recorded_and_its_timeline_drawn(tmp_path):
    scene = two_block_scene(tmp_path)
    report = tmp_path / "report"
    done = subprocess.run([*tool("run"), "--scene", str(scene), "--report", str(report),
                           "--quiet", "--timeout", "400"], cwd=REPO, capture_output=True,
                          text=True, timeout=600)
    log = (report / "cell.log").read_text() if (report / "cell.log").exists() else ""
    assert done.returncode == 0, done.stdout + done.stderr + log[-3000:]
    assert "replay: densepack-play" in done.stdout

    metrics = json.loads((report / "metrics.json").read_text())
    rows = json.loads((report / "timeline.json").read_text())
    assert len(rows) == metrics["actions_executed"] >= 2
    assert {r["block"] for r in rows} >= {0, 1}
    for row in rows:  # a pick-and-place is a 4-6 s job on the real robot
        assert row["kind"] in ("pick_place", "push") and 1.0 < row["duration_s"] < 20.0
    assert cv2.imread(str(report / "timeline.png")) is not None

    messages = read_mcap(report / "bag")
    assert metrics["bag"]["messages"] == len(messages)
    seen = Counter(topic for topic, *_ in messages)
    for topic in ("/camera/image_raw/compressed", "/blocks/detected", "/plan",
                  "/executor/status", "/sim/ground_truth"):
        assert seen[topic] > 0, f"nothing recorded on {topic}: {dict(seen)}"
    # the executor streams on the arm's lease while it holds it (the token is the run's)
    streamed = [t for t in seen
                if t.startswith("/arm/lease/") and t.endswith("/cartesian_setpoint")]
    assert streamed and sum(seen[t] for t in streamed) > 100, dict(seen)
    assert "/camera/image_raw" not in seen
    states = [m.state for topic, _, _, m in messages if topic == "/executor/status"]
    assert states[-1] == ExecutorStatus.STATE_DONE
    times = [log_time for _, _, log_time, _ in messages]
    assert max(times) * 1e-9 < metrics["sim_time_s"] + 5  # stamped with simulated time
