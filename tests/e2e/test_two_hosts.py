"""The cell split over two computers (issue 29, item 3), made as two network namespaces on
this machine (tests/e2e/hosts.py), configured as a user configures two hosts
(docs/real_cell.md, "Several computers"): the same ROS_DOMAIN_ID, discovery kept on each
host (LOCALHOST) and ROS_STATIC_PEERS naming the other, so nothing rides on multicast.

Host a, the cell computer: the sim (standing in for ur_robot_driver, the Robotiq driver and
the camera), the detector beside the camera, and the arm and gripper nodes beside their
drivers, started with ``densepack-cell --nodes``. Host b, the planning computer:
``densepack-run --remote sim,detector,arm,gripper`` starts the planner and the executor and
drives the goal. First with host a's cable pulled: the run must stop by itself, naming the
nodes it cannot see. Then plugged in: a two-block scene done (the default scene's 9 blocks
were run this way too, docs/real_cell.md; they triple the test's time), every block within
3 mm of its goal by the sim's ground truth (on one host: 0.04-0.44 mm). Last, the
cable pulled while a run's goal is under way: the sim's data stops, and the run stops within
seconds naming it (the graph would list the cut-off nodes for DDS's 20 s lease).
"""

from __future__ import annotations

import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time

import pytest

from tests.helpers import REPO, tool

from .hosts import Hosts, HostsUnavailable
from .scenes import two_block_scene

pytestmark = [pytest.mark.slow, pytest.mark.ros]

CELL_PC = ("sim", "detector", "arm", "gripper")
#: Wall-time bounds of this test's waits (s): the cell computer's nodes up, each run.
START_S, UNREACHABLE_RUN_S, RUN_S = 180.0, 120.0, 900.0


def host_env(peer: str) -> dict[str, str]:
    keep = ("PATH", "HOME", "PYTHONPATH", "LANG", "VIRTUAL_ENV", "ROS_HOME")
    env = {k: os.environ[k] for k in keep if k in os.environ}
    return {**env, "ROS_DOMAIN_ID": os.environ["ROS_DOMAIN_ID"],
            "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST", "ROS_STATIC_PEERS": peer,
            "PYTHONUNBUFFERED": "1", "RCUTILS_COLORIZED_OUTPUT": "0"}


def read_lines(proc: subprocess.Popen) -> queue.Queue:
    lines: queue.Queue = queue.Queue()

    def pump() -> None:
        for line in iter(proc.stdout.readline, ""):
            lines.put(line)

    threading.Thread(target=pump, daemon=True).start()
    return lines


def wait_for_line(lines: queue.Queue, text: str, seen: list[str], timeout: float) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            line = lines.get(timeout=1.0)
        except queue.Empty:
            continue
        seen.append(line)
        if text in line:
            return
    raise AssertionError(f"no '{text}' in {timeout:.0f} s:\n" + "".join(seen[-40:]))


def run_argv(scene, report, *args: str) -> list[str]:
    return [*tool("run"), "--scene", str(scene), "--report", str(report), "--quiet",
            "--no-record", "--remote", ",".join(CELL_PC), *args]


def run_on(host, peer: str, scene, report, *args: str, timeout: float
           ) -> subprocess.CompletedProcess:
    return subprocess.run(host.command(run_argv(scene, report, *args), host_env(peer)), cwd=REPO,
                          capture_output=True, text=True, timeout=timeout)


def cut_during_a_run(hosts, scene, report) -> tuple[int, str]:
    """A run whose goal has its plan when host a's cable is pulled: its exit code and output.
    (The blocks already stand at their goals: the executor must look to finish, and cannot.)"""
    proc = subprocess.Popen(hosts.b.command(run_argv(scene, report), host_env(hosts.a.address)),
                            cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    lines, seen = read_lines(proc), []
    try:
        wait_for_line(lines, "plan ", seen, UNREACHABLE_RUN_S)
        hosts.a.link_up(False)
        proc.wait(timeout=UNREACHABLE_RUN_S)
    finally:
        stop(proc)
        hosts.a.link_up(True)
    time.sleep(1.0)  # the pump thread's last lines
    while not lines.empty():
        seen.append(lines.get())
    return proc.returncode, "".join(seen)


def stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture
def hosts():
    try:
        made = Hosts().__enter__()
    except HostsUnavailable as why:
        pytest.skip(str(why))
    try:
        yield made
    finally:
        made.__exit__()


def test_the_cell_split_over_two_hosts_reports_a_cut_link_and_does_a_scene(hosts, tmp_path):
    scene = two_block_scene(tmp_path)
    cell_pc = None
    try:
        argv = [sys.executable, "-m", "nodes.tools.cell", "--nodes", ",".join(CELL_PC),
                "--scene", str(scene)]
        cell_pc = subprocess.Popen(hosts.a.command(argv, host_env(hosts.b.address)), cwd=REPO,
                                   stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines, seen = read_lines(cell_pc), []
        wait_for_line(lines, "sim running", seen, START_S)

        hosts.a.link_up(False)  # the cable pulled: discovery cannot cross
        cut = run_on(hosts.b, hosts.a.address, scene, tmp_path / "cut", "--discovery-timeout", "10",
                     timeout=UNREACHABLE_RUN_S)
        assert cut.returncode == 5, cut.stdout + cut.stderr
        assert "cannot see nodes sim, detector, arm, gripper (expected on another computer) " \
               "10 s after the start" in cut.stderr, cut.stderr
        assert "ROS_STATIC_PEERS=10.29.0.1" in cut.stderr

        hosts.a.link_up(True)
        done = run_on(hosts.b, hosts.a.address, scene, tmp_path / "run", timeout=RUN_S)
        log = (tmp_path / "run" / "cell.log").read_text()
        assert done.returncode == 0, done.stdout + done.stderr + log[-3000:]
        metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
        assert metrics["outcome"] == "done" and metrics["blocks_lost"] == 0
        assert metrics["final_pos_err_max_m"] <= 0.003, metrics["final_errors"]
        assert metrics["final_yaw_err_max_deg"] <= 2.0, metrics["final_errors"]
        print(f"two hosts: worst block {metrics['final_pos_err_max_m'] * 1e3:.2f} mm, "
              f"{metrics['actions_executed']:.0f} actions, sim {metrics['sim_time_s']:.0f} s, "
              f"wall {metrics['wall_time_s']:.0f} s")
        assert cell_pc.poll() is None, "".join(seen[-40:])  # the cell computer's nodes lived

        code, said = cut_during_a_run(hosts, scene, tmp_path / "cut_later")
        assert code == 5, said
        assert "no data from node sim (expected on another computer) for 5 s" in said, said
    finally:
        if cell_pc is not None:
            stop(cell_pc)
