"""densepack-cell starts the node set, prefixes logs, stops cleanly, fails when a node dies."""

from __future__ import annotations

import os
import signal
import subprocess
import time

import pytest
from std_msgs.msg import String

from msgs_py.ros_codecs import scene_from_string
from nodes.common.qos import LATCHED
from tests.helpers import script

pytestmark = pytest.mark.ros


def start_cell(*args: str) -> subprocess.Popen:
    return subprocess.Popen(
        [script("densepack-cell"), *args],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        env=dict(os.environ, PYTHONUNBUFFERED="1"),
    )


def stop(proc: subprocess.Popen, sig=signal.SIGINT, timeout: float = 30.0) -> tuple[int, str]:
    proc.send_signal(sig)
    out, _ = proc.communicate(timeout=timeout)
    return proc.returncode, out


def test_list_names_the_node_set():
    out = subprocess.run([script("densepack-cell"), "--list"], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0
    assert "goal: nodes.tools.goal --ros-args" in out.stdout


@pytest.mark.parametrize("mode", [[], ["--in-process"]], ids=["processes", "in-process"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_cell_runs_the_goal_node_and_stops_cleanly(ros, mode, sig):
    proc = start_cell("--nodes", "goal", *mode)
    try:
        msg = ros.wait_for_message("/goal_layout", String, timeout=60, qos=LATCHED)
        assert scene_from_string(msg).goal.n_slots == 9
    finally:
        code, out = stop(proc, sig)
    assert code == 0, out
    assert "[goal]" in out and "published the goal" in out
    assert "[cell] all nodes stopped" in out


@pytest.mark.parametrize("mode", [[], ["--in-process"]], ids=["processes", "in-process"])
def test_cell_exits_non_zero_when_a_node_dies(mode):
    proc = start_cell("--nodes", "goal", *mode, "--ros-args", "-p",
                      "scene_file:=/nonexistent/scene.yaml")
    try:
        out, _ = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    assert proc.returncode != 0
    assert "cannot read file" in out


def test_cell_reports_missing_nodes_and_starts_the_rest():
    proc = start_cell()
    time.sleep(3.0)
    code, out = stop(proc)
    assert code == 0, out
    import importlib.util

    from nodes.tools.cell import NODE_MODULES

    missing = [n for n, m in NODE_MODULES.items()
               if importlib.util.find_spec(m.rsplit(".", 1)[0]) is None]
    if missing:
        assert "not implemented yet, not started: " + ", ".join(missing) in out
    assert "[cell] started goal" in out


def test_command_line_parameters_override_the_cell_file(tmp_path):
    from nodes.tools.cell import load_cell

    cell = tmp_path / "cell.yaml"
    cell.write_text("parameters: {use_sim_time: true, scene_file: a.yaml}\n"
                    "nodes:\n  goal:\n    parameters: {scene_file: b.yaml}\n")
    (launch,), _ = load_cell(cell)
    assert launch.parameters == {"use_sim_time": True, "scene_file": "b.yaml"}
    (launch,), _ = load_cell(cell, extra_params={"scene_file": "/x/c.yaml"})
    assert launch.parameters["scene_file"] == "/x/c.yaml"
    assert launch.ros_args()[-2:] == ["-p", "scene_file:=/x/c.yaml"]
