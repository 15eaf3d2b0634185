"""One run of the whole cell, driven from outside: start the nodes, watch, inject faults.

``CellRun`` starts every node of the cell file as its own process (so a fault can kill and
restart one), collects what a report needs from the cell's topics in ``RunMonitor``, and
``run()`` loops until the executor reports ``done`` or ``failed`` or time runs out, calling
``on_progress`` hooks (the run command prints progress, the cell benchmark injects faults).
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from msgs_py import BlockSet, Plan, Scene
from nodes.common.paths import config_path
from nodes.common.runner import LAUNCHER_PID_ENV
from nodes.tools.cell import NodeLaunch, load_cell

FINAL_STATES = ("done", "failed")


class RunMonitor:
    """The latest of everything a run report needs, from the cell's topics."""

    def __init__(self, context: Any) -> None:
        from rclpy.node import Node
        from sensor_msgs.msg import Image
        from std_msgs.msg import String
        from visualization_msgs.msg import MarkerArray

        from msgs_py.ros_codecs import (
            block_set_from_markers,
            executor_status_from_string,
            plan_from_string,
            planner_status_from_string,
        )
        from nodes.common.qos import LATCHED, RELIABLE, SENSOR

        self.node = Node("densepack_run", context=context)
        self.lock = threading.Lock()
        self.executor_status: Any = None
        self.planner_status: Any = None
        self.plans: list[Plan] = []
        self.events: dict[str, Any] = {}
        self.ground_truth: BlockSet | None = None
        self.first_image: Any = None
        self.last_image: Any = None
        self.sim_time = 0.0
        n = self.node
        n.create_subscription(String, "/executor/status",
                              self._keep("executor_status", executor_status_from_string), LATCHED)
        n.create_subscription(String, "/planner/status",
                              self._keep("planner_status", planner_status_from_string), LATCHED)
        n.create_subscription(String, "/plan", self._keep("plans", plan_from_string), LATCHED)
        n.create_subscription(MarkerArray, "/sim/ground_truth",
                              self._keep("ground_truth", block_set_from_markers), RELIABLE)
        n.create_subscription(String, "/sim/events", self._keep("events", _json), RELIABLE)
        n.create_subscription(Image, "/camera/image_raw", self._on_image, SENSOR)
        # Simulated time comes from the ground truth's stamps (10 Hz), not /clock: a /clock
        # subscription costs a Python callback per message.

    def _keep(self, attr: str, decode: Callable[[Any], Any]) -> Callable[[Any], None]:
        from msgs_py import MessageError

        def callback(msg: Any) -> None:
            try:
                value = decode(msg)
            except (MessageError, ValueError):
                return  # a malformed message is not the monitor's business
            with self.lock:
                if attr == "ground_truth":
                    self.sim_time = value.stamp_ns * 1e-9
                if attr == "plans":
                    if not self.plans or self.plans[-1].plan_id != value.plan_id:
                        self.plans.append(value)
                else:
                    setattr(self, attr, value)

        return callback

    def _on_image(self, msg: Any) -> None:
        with self.lock:
            if self.first_image is None:
                self.first_image = msg
            self.last_image = msg



def _json(msg: Any) -> dict[str, Any]:
    try:
        data = json.loads(msg.data)
    except json.JSONDecodeError as err:
        raise ValueError(str(err)) from None
    if not isinstance(data, dict):
        raise ValueError("not an object")
    return data


@dataclass
class RunResult:
    outcome: str  # done | failed | timeout | crashed
    wall_time_s: float
    notes: list[str] = field(default_factory=list)


class CellRun:
    """The cell's nodes as separate processes, logging to one file."""

    def __init__(self, scene_file: Path, log: IO[str], cell_file: str = "cell.yaml",
                 extra_ros_args: tuple[str, ...] = ()) -> None:
        launches, missing = load_cell(config_path(cell_file), (),
                                      {"scene_file": str(scene_file)})
        if missing:
            raise RuntimeError(f"the cell is incomplete: {', '.join(missing)} not implemented")
        self.launches: dict[str, NodeLaunch] = {launch.name: launch for launch in launches}
        self.extra = list(extra_ros_args)
        self.log = log
        self.procs: dict[str, subprocess.Popen] = {}
        self.killed: set[str] = set()  # killed on purpose (fault injection), not crashed
        self.pumps: list[threading.Thread] = []
        self.log_lock = threading.Lock()
        self.env = dict(os.environ, PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0",
                        **{LAUNCHER_PID_ENV: str(os.getpid())})

    def start(self, name: str | None = None) -> None:
        for launch in [self.launches[name]] if name else self.launches.values():
            cmd = [sys.executable, "-m", launch.module, *launch.ros_args(self.extra)]
            proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                    text=True, env=self.env, start_new_session=True)
            self.procs[launch.name] = proc
            self.killed.discard(launch.name)
            pump = threading.Thread(target=self._pump, args=(launch.name, proc), daemon=True)
            pump.start()
            self.pumps.append(pump)

    def _pump(self, name: str, proc: subprocess.Popen) -> None:
        assert proc.stdout is not None
        for line in iter(proc.stdout.readline, ""):
            with self.log_lock:
                self.log.write(f"[{name}] {line}")
                self.log.flush()

    def kill(self, name: str) -> None:
        """SIGKILL one node, as a crash would."""
        proc = self.procs[name]
        self.killed.add(name)
        proc.kill()
        proc.wait()

    def died(self) -> list[tuple[str, int]]:
        return [(n, p.returncode) for n, p in self.procs.items()
                if n not in self.killed and p.poll() is not None and p.returncode != 0]

    def stop(self, grace_s: float = 15.0) -> None:
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        deadline = time.monotonic() + grace_s
        for proc in self.procs.values():
            try:
                proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for pump in self.pumps:
            pump.join(timeout=2.0)


#: Topics only a running cell publishes: seen on the domain, another cell is there.
CELL_TOPICS = ("/sim/ground_truth", "/executor/status", "/plan")


def another_cell(node: Any, wait_s: float = 2.0) -> str | None:
    """The topic through which another cell shows itself on this node's domain, or None.
    Two cells on one domain hear each other's goals, detections and plans."""
    deadline = time.monotonic() + wait_s
    while True:
        for topic in CELL_TOPICS:
            if node.count_publishers(topic) > 0:
                return topic
        if time.monotonic() >= deadline:
            return None
        time.sleep(0.1)


def private_domain() -> int:
    """Put this process and the nodes it starts on a DDS domain of their own (kept on this
    host), so a benchmark never hears a cell someone runs by hand, nor another benchmark."""
    from nodes.common.harness import allocate_domain_id

    if "DENSEPACK_PRIVATE_DOMAIN" not in os.environ:
        os.environ["DENSEPACK_PRIVATE_DOMAIN"] = str(allocate_domain_id(120, 200))
    os.environ["ROS_DOMAIN_ID"] = os.environ["DENSEPACK_PRIVATE_DOMAIN"]
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return int(os.environ["ROS_DOMAIN_ID"])


def stop_cells_on_sigterm() -> None:
    """SIGTERM unwinds the main thread like Ctrl-C, so every ``finally: cell.stop()`` runs."""
    def _exit(signum: int, frame: Any) -> None:
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, _exit)


def run(
    cell: CellRun,
    monitor: RunMonitor,
    timeout_s: float,
    on_progress: Callable[[RunMonitor, float], None] = lambda m, t: None,
) -> RunResult:
    """Spin the monitor until the executor finishes, a node crashes or time runs out."""
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=monitor.node.context)
    executor.add_node(monitor.node)
    wall0 = time.monotonic()
    outcome = "timeout"
    notes: list[str] = []
    try:
        while time.monotonic() - wall0 < timeout_s:
            executor.spin_once(timeout_sec=0.1)
            crashed = cell.died()
            if crashed:
                notes.append(f"node(s) crashed: {crashed}")
                outcome = "crashed"
                break
            on_progress(monitor, time.monotonic() - wall0)
            status = monitor.executor_status
            if status is not None and status.state in FINAL_STATES:
                outcome = status.state
                settle = time.monotonic() + 2.0
                while time.monotonic() < settle:  # last ground truth and events
                    executor.spin_once(timeout_sec=0.1)
                break
    finally:
        executor.remove_node(monitor.node)
        executor.shutdown()
    return RunResult(outcome, time.monotonic() - wall0, notes)


def final_errors(truth: BlockSet | None, scene: Scene) -> list[dict[str, Any]]:
    """Each goal slot's error against the simulator's ground truth."""
    from nodes.executor.verify import goal_errors

    if truth is None:
        return []
    poses = {b.id: b.pose for b in truth.blocks}
    return [
        {"block": d.block, "pos_err_m": d.position_error,
         "yaw_err_deg": math.degrees(d.yaw_error)}
        for d in goal_errors(poses, scene)
    ]


def run_metrics(monitor: RunMonitor, scene: Scene, result: RunResult) -> dict[str, Any]:
    with monitor.lock:
        status, plans = monitor.executor_status, list(monitor.plans)
        truth, events = monitor.ground_truth, dict(monitor.events)
    errors = final_errors(truth, scene)
    pos = [e["pos_err_m"] for e in errors]
    yaw = [e["yaw_err_deg"] for e in errors]
    metric = (lambda k: status.metrics.get(k)) if status else (lambda k: None)
    return {
        "outcome": result.outcome,
        "notes": result.notes,
        "executor_state": status.state if status else None,
        "last_error": status.last_error if status else None,
        "blocks": len(scene.blocks),
        "actions_planned": len(plans[0].actions) if plans else None,
        "actions_executed": metric("actions_executed"),
        "plans": len(plans),
        "replans": metric("replans"),
        "planning_time_s": [p.planning_time_s for p in plans],
        "execution_time_s": metric("execution_time_s"),
        "sim_time_s": monitor.sim_time,
        "wall_time_s": result.wall_time_s,
        "unintended_contacts": events.get("unintended_contacts"),
        "blocks_lost": events.get("blocks_lost"),
        "events": events.get("events", []),
        "sim_time_by_activity_s": ({k[len("time_"):-2]: v for k, v in status.metrics.items()
                                    if k.startswith("time_") and k.endswith("_s")}
                                   if status else {}),
        "final_pos_err_max_m": max(pos) if pos else None,
        "final_pos_err_median_m": sorted(pos)[len(pos) // 2] if pos else None,
        "final_yaw_err_max_deg": max(yaw) if yaw else None,
        "final_yaw_err_median_deg": sorted(yaw)[len(yaw) // 2] if yaw else None,
        "final_errors": errors,
    }
