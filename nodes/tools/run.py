"""``densepack-run``: the main job. Runs the whole cell on a scene and writes a run report.

Starts ``densepack-cell`` (sim, detector, planner, executor, goal) on the scene, watches
the planner and the executor, shows one line per action and a progress bar, and when the
executor reports ``done`` or ``failed`` (or the time limit passes) stops the cell and
writes a report folder: ``before.png`` / ``after.png`` (overhead camera), ``plan.png``
(the first plan drawn), ``plan.json``, ``metrics.json`` (per-block final error against the
goal from ``/sim/ground_truth``, actions, planning and execution time, unintended contacts
and lost blocks from ``/sim/events``) and ``cell.log`` (every node's log).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from msgs_py import BlockSet, Plan, Scene, load_scene, save_plan
from nodes.common.paths import config_path

EXIT_DONE, EXIT_FAILED, EXIT_TIMEOUT = 0, 1, 2


class RunMonitor:
    """Collects what the run report needs from the cell's topics (rclpy in this process)."""

    def __init__(self, context: Any) -> None:
        from rclpy.node import Node
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import Image
        from std_msgs.msg import String
        from visualization_msgs.msg import MarkerArray

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
        self.status_history: list[Any] = []
        n = self.node
        n.create_subscription(String, "/executor/status", self._on_executor, LATCHED)
        n.create_subscription(String, "/planner/status", self._on_planner, LATCHED)
        n.create_subscription(String, "/plan", self._on_plan, LATCHED)
        n.create_subscription(String, "/sim/events", self._on_events, RELIABLE)
        n.create_subscription(MarkerArray, "/sim/ground_truth", self._on_truth, RELIABLE)
        n.create_subscription(Image, "/camera/image_raw", self._on_image, SENSOR)
        n.create_subscription(Clock, "/clock", self._on_clock, SENSOR)

    def _decode(self, fn, msg):
        from msgs_py import MessageError

        try:
            return fn(msg)
        except (MessageError, ValueError):
            return None

    def _on_executor(self, msg) -> None:
        from msgs_py.ros_codecs import executor_status_from_string

        status = self._decode(executor_status_from_string, msg)
        if status is not None:
            with self.lock:
                self.executor_status = status
                self.status_history.append(status)

    def _on_planner(self, msg) -> None:
        from msgs_py.ros_codecs import planner_status_from_string

        status = self._decode(planner_status_from_string, msg)
        if status is not None:
            with self.lock:
                self.planner_status = status

    def _on_plan(self, msg) -> None:
        from msgs_py.ros_codecs import plan_from_string

        plan = self._decode(plan_from_string, msg)
        if plan is not None:
            with self.lock:
                if not self.plans or self.plans[-1].plan_id != plan.plan_id:
                    self.plans.append(plan)

    def _on_events(self, msg) -> None:
        try:
            data = json.loads(msg.data)
        except json.JSONDecodeError:
            return
        with self.lock:
            self.events = data

    def _on_truth(self, msg) -> None:
        from msgs_py.ros_codecs import block_set_from_markers

        truth = self._decode(block_set_from_markers, msg)
        if truth is not None:
            with self.lock:
                self.ground_truth = truth

    def _on_image(self, msg) -> None:
        with self.lock:
            if self.first_image is None:
                self.first_image = msg
            self.last_image = msg

    def _on_clock(self, msg) -> None:
        self.sim_time = msg.clock.sec + msg.clock.nanosec * 1e-9


def image_to_png(msg: Any, path: Path) -> bool:
    import cv2
    import numpy as np

    if msg is None or msg.encoding != "rgb8" or not msg.height:
        return False
    rgb = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.height, msg.step)
    rgb = rgb[:, : msg.width * 3].reshape(msg.height, msg.width, 3)
    return bool(cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)))


def final_errors(truth: BlockSet | None, scene: Scene) -> list[dict[str, Any]]:
    from nodes.executor.verify import goal_errors

    if truth is None:
        return []
    poses = {b.id: b.pose for b in truth.blocks}
    return [
        {"block": d.block, "pos_err_m": d.position_error, "yaw_err_deg": math.degrees(d.yaw_error)}
        for d in goal_errors(poses, scene)
    ]


def draw_plan(plan: Plan, path: Path) -> bool:
    try:
        from nodes.planner.draw import draw_plan as planner_draw
    except ImportError:
        return False
    planner_draw(plan, path)
    return True


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="densepack-run", description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="scenes/default.yaml", help="scene file (config/)")
    parser.add_argument("--report", type=Path, default=None, help="report folder (runs/<time>)")
    parser.add_argument("--timeout", type=float, default=900.0, help="wall-time limit (s)")
    parser.add_argument("--in-process", action="store_true", help="all nodes in one process")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


def main(args: Sequence[str] | None = None) -> int:
    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from tqdm import tqdm

    opts = build_parser().parse_args(args)
    scene_file = config_path(opts.scene).resolve()
    scene = load_scene(scene_file)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    report = opts.report or Path("runs") / stamp
    report.mkdir(parents=True, exist_ok=True)
    print(f"densepack-run: {len(scene.blocks)} blocks -> {scene.goal.n_slots} goal slots "
          f"({scene_file.name}); report in {report}", flush=True)

    log = open(report / "cell.log", "w")  # noqa: SIM115 - closed after the cell stops
    cmd = [sys.executable, "-m", "nodes.tools.cell", "--scene", str(scene_file)]
    if opts.in_process:
        cmd.append("--in-process")
    cell = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    context = Context()
    rclpy.init(context=context)
    monitor = RunMonitor(context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(monitor.node)
    wall0 = time.monotonic()
    bar = None if opts.quiet else tqdm(total=1, unit="action", dynamic_ncols=True, leave=True)
    code, last_line, plans_seen = EXIT_TIMEOUT, "", 0
    try:
        while time.monotonic() - wall0 < opts.timeout:
            executor.spin_once(timeout_sec=0.1)
            if cell.poll() is not None:
                print(f"densepack-run: the cell exited early (code {cell.returncode}); "
                      f"see {report / 'cell.log'}", flush=True)
                code = EXIT_FAILED
                break
            with monitor.lock:
                status, plans = monitor.executor_status, list(monitor.plans)
            for plan in plans[plans_seen:]:
                _say(bar, f"plan {plan.plan_id}: {len(plan.actions)} actions, planned in "
                          f"{plan.planning_time_s:.2f} s (cost {plan.cost:.1f})")
            plans_seen = len(plans)
            if status is None:
                continue
            line = f"[{status.action_index}/{status.action_total}] {status.state}: {status.detail}"
            if line != last_line:
                _say(bar, f"{line}  (sim {monitor.sim_time:.1f} s, "
                          f"wall {time.monotonic() - wall0:.1f} s)")
                last_line = line
            if bar is not None:
                bar.total = max(status.action_total, 1)
                bar.n = status.action_index
                bar.refresh()
            if status.state in ("done", "failed"):
                code = EXIT_DONE if status.state == "done" else EXIT_FAILED
                for _ in range(20):  # let the last ground truth and events arrive
                    executor.spin_once(timeout_sec=0.1)
                break
    except KeyboardInterrupt:
        code = EXIT_FAILED
    finally:
        if bar is not None:
            bar.close()
        wall = time.monotonic() - wall0
        write_report(report, monitor, scene, wall, code)
        cell.send_signal(signal.SIGINT)
        try:
            cell.wait(timeout=30)
        except subprocess.TimeoutExpired:
            cell.kill()
        log.close()
        executor.shutdown()
        monitor.node.destroy_node()
        rclpy.try_shutdown(context=context)
    return code


def _say(bar: Any, line: str) -> None:
    if bar is not None:
        bar.write(line)
    else:
        print(line, flush=True)


def write_report(report: Path, monitor: RunMonitor, scene: Scene, wall: float, code: int) -> None:
    with monitor.lock:
        status, plans = monitor.executor_status, list(monitor.plans)
        truth, events = monitor.ground_truth, dict(monitor.events)
        first, last = monitor.first_image, monitor.last_image
    image_to_png(first, report / "before.png")
    image_to_png(last, report / "after.png")
    if plans:
        save_plan(plans[0], report / "plan.json")
        draw_plan(plans[0], report / "plan.png")
    errors = final_errors(truth, scene)
    pos = [e["pos_err_m"] for e in errors]
    yaw = [e["yaw_err_deg"] for e in errors]
    metrics = {
        "outcome": {EXIT_DONE: "done", EXIT_FAILED: "failed"}.get(code, "timeout"),
        "executor_state": status.state if status else None,
        "last_error": status.last_error if status else None,
        "blocks": len(scene.blocks),
        "actions_planned_first_plan": len(plans[0].actions) if plans else None,
        "actions_executed": status.metrics.get("actions_executed") if status else None,
        "plans": len(plans),
        "replans": status.metrics.get("replans") if status else None,
        "planning_time_s": [p.planning_time_s for p in plans],
        "execution_time_s": status.metrics.get("execution_time_s") if status else None,
        "sim_time_s": monitor.sim_time,
        "wall_time_s": wall,
        "unintended_contacts": events.get("unintended_contacts"),
        "blocks_lost": events.get("blocks_lost"),
        "final_pos_err_max_m": max(pos) if pos else None,
        "final_yaw_err_max_deg": max(yaw) if yaw else None,
        "final_errors": errors,
    }
    (report / "metrics.json").write_text(json.dumps(metrics, indent=2, default=str) + "\n")
    print(f"densepack-run: {metrics['outcome']}; "
          f"max error {_mm(metrics['final_pos_err_max_m'])}, "
          f"{metrics['actions_executed']} actions, wall {wall:.0f} s; report in {report}",
          flush=True)


def _mm(value: float | None) -> str:
    return "n/a" if value is None else f"{value * 1e3:.2f} mm"


if __name__ == "__main__":
    sys.exit(main())
