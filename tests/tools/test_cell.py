"""densepack-cell starts the node set, prefixes logs, stops cleanly, fails when a node dies."""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time

import pytest
from densepack_interfaces.msg import GoalLayout

from msgs_py.ros import goal_layout_from_msg
from nodes.common.qos import LATCHED
from tests.helpers import REPO, script, tool

pytestmark = pytest.mark.ros


class Cell:
    """A densepack-cell process whose output is collected line by line as it comes."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [*tool("cell"), *args], cwd=REPO,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            env=dict(os.environ, PYTHONUNBUFFERED="1"),
        )
        self.lines: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in iter(self.proc.stdout.readline, ""):
            self.lines.append(line)

    @property
    def output(self) -> str:
        return "".join(self.lines)

    def wait_for_output(self, text: str, timeout: float = 60.0) -> None:
        deadline = time.monotonic() + timeout
        while text not in self.output:
            assert time.monotonic() < deadline, f"no '{text}' in: {self.output}"
            assert self.proc.poll() is None, f"the cell exited: {self.output}"
            time.sleep(0.05)

    def stop(self, sig=signal.SIGINT, timeout: float = 30.0) -> tuple[int, str]:
        self.proc.send_signal(sig)
        code = self.proc.wait(timeout=timeout)
        self.reader.join(timeout=10)
        return code, self.output

    def finish(self, timeout: float = 60.0) -> tuple[int, str]:
        code = self.proc.wait(timeout=timeout)
        self.reader.join(timeout=10)
        return code, self.output


def test_list_names_the_node_set():
    out = subprocess.run([script("densepack-cell"), "--list"], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode == 0
    assert "goal: nodes.goal.node --ros-args" in out.stdout


@pytest.mark.parametrize("mode", [[], ["--in-process"]], ids=["processes", "in-process"])
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_cell_runs_the_goal_node_and_stops_cleanly(ros, mode, sig):
    cell = Cell("--nodes", "goal", *mode)
    try:
        cell.wait_for_output("published the goal")
        msg = ros.wait_for_message("/goal_layout", GoalLayout, timeout=60, qos=LATCHED)
        assert goal_layout_from_msg(msg).goal.n_slots == 9
    finally:
        code, out = cell.stop(sig)
    assert code == 0, out
    assert "[goal]" in out and "published the goal" in out
    assert "[cell] all nodes stopped" in out


@pytest.mark.parametrize("mode", [[], ["--in-process"]], ids=["processes", "in-process"])
def test_cell_exits_non_zero_when_a_node_dies(mode):
    cell = Cell("--nodes", "goal", *mode, "--ros-args", "-p",
                "scene_file:=/nonexistent/scene.yaml")
    try:
        code, out = cell.finish(timeout=60)
    except subprocess.TimeoutExpired:
        cell.proc.kill()
        raise
    assert code != 0
    assert "cannot read file" in out


def test_cell_reports_missing_nodes_and_starts_the_rest():
    cell = Cell()
    cell.wait_for_output("[cell] started goal")
    code, out = cell.stop()
    assert code == 0, out
    import importlib.util

    from nodes.cell.launch import NODE_MODULES

    missing = [n for n, m in NODE_MODULES.items()
               if importlib.util.find_spec(m.rsplit(".", 1)[0]) is None]
    if missing:
        assert "not implemented yet, not started: " + ", ".join(missing) in out
    assert "[cell] started goal" in out


def test_command_line_parameters_override_the_cell_file(tmp_path):
    from nodes.cell.launch import load_cell

    cell = tmp_path / "cell.yaml"
    cell.write_text("parameters: {use_sim_time: true, scene_file: a.yaml}\n"
                    "nodes:\n  goal:\n    parameters: {scene_file: b.yaml}\n")
    (launch,), _ = load_cell(cell)
    assert launch.parameters == {"use_sim_time": True, "scene_file": "b.yaml"}
    (launch,), _ = load_cell(cell, extra_params={"scene_file": "/x/c.yaml"})
    assert launch.parameters["scene_file"] == "/x/c.yaml"
    assert launch.ros_args()[-2:] == ["-p", "scene_file:=/x/c.yaml"]
    (launch,), _ = load_cell(cell, node_params={"goal": {"scene_file": "d.yaml"}})
    assert launch.parameters["scene_file"] == "d.yaml"


def test_without_leaves_nodes_out():
    out = subprocess.run([script("densepack-cell"), "--list", "--without", "goal,planner"],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    names = [line.split(":")[0] for line in out.stdout.splitlines()]
    assert "goal" not in names and "planner" not in names and "executor" in names


def test_nodes_do_not_outlive_a_killed_launcher():
    """SIGKILL leaves the launcher no chance to stop its nodes: they notice and stop."""
    cell = Cell("--nodes", "goal")
    cell.wait_for_output("[cell] started goal")
    node_pid = int(cell.output.split("[cell] started goal (pid ")[1].split(")")[0])
    cell.wait_for_output("published the goal")
    cell.proc.kill()
    cell.proc.wait(timeout=10)
    deadline = time.monotonic() + 20
    while _alive(node_pid):
        assert time.monotonic() < deadline, f"node {node_pid} outlived its launcher"
        time.sleep(0.1)


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(")")[1].split()[0] != "Z"  # a zombie has exited
    except FileNotFoundError:
        return False


def test_a_node_killed_comes_back_until_its_respawns_are_used_up(tmp_path):
    """SIGKILL, as a crash: the launcher starts the node again after its delay, logs it, and
    stops the cell (exit code 1) once the cell file's limit is reached."""
    cell_file = tmp_path / "cell.yaml"
    cell_file.write_text("nodes:\n  goal:\n    respawn: true\n    respawn_delay: 0.2\n"
                         "    respawn_max: 2\n    parameters: {scene_file: scenes/default.yaml}\n")
    cell = Cell(str(cell_file))
    try:
        for k in (1, 2, 3):
            deadline = time.monotonic() + 60
            while cell.output.count("published the goal") < k:  # the k-th start's node is up
                assert time.monotonic() < deadline and cell.proc.poll() is None, cell.output
                time.sleep(0.05)
            starts = cell.output.split("[cell] started goal (pid ")
            assert len(starts) == k + 1, cell.output
            os.kill(int(starts[-1].split(")")[0]), signal.SIGKILL)
            if k < 3:
                cell.wait_for_output(f"respawning in 0.2 s ({k} of 2)")
        code, out = cell.finish(timeout=60)
    finally:
        if cell.proc.poll() is None:
            cell.proc.kill()
    assert code == 1, out
    assert "[cell] node goal exited (code -9); no respawn left (2 used); stopping the cell" in out
