"""``densepack-run``: the main job. Runs the whole cell on a scene and writes a run report.

Checks the scene's goal the way the executor will, starts the cell (sim, detector, planner,
executor; one process each), sends the goal layout as a ``/rearrange`` goal (the client of
the executor's action), prints one line per plan and per feedback step with a progress bar,
and when the goal ends (or the time limit passes: the goal is canceled, a safe stop) stops
the cell and writes a report folder: ``before.png`` / ``after.png`` (overhead camera),
``plan.png`` (the first plan drawn), ``plan.json``, ``metrics.json`` (the goal's outcome and
figures, per-block final error against the goal from ``/sim/ground_truth``, unintended
contacts and lost blocks from ``/sim/events``), ``timeline.png`` / ``timeline.json`` (per
action: kind, simulated duration, corrections, the block's final error), ``cell.log``, and
``bag/``: the whole run recorded as a rosbag2 bag (MCAP; ``densepack-record --all``, images
compressed; ``--no-record`` to skip), for ``densepack-play`` and the Foxglove app.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import rclpy
import yaml
from rclpy.context import Context
from tqdm import tqdm

from msgs_py import Plan, load_scene, save_plan
from msgs_py.cell import PLACED_TOLERANCE_XY
from nodes.cell.discovery import FIRST_SEEN_S, DiscoveryWatch
from nodes.cell.monitor import RunMonitor, another_cell
from nodes.cell.processes import CellRun, stop_cells_on_sigterm
from nodes.cell.run import check_goal, run, run_metrics
from nodes.cell.timeline import write_timeline
from nodes.common.paths import config_path

EXIT_CODES = {"done": 0, "failed": 1, "canceled": 1, "crashed": 1, "timeout": 2,
              "rejected": 4, "unreachable": 5}
EXIT_ANOTHER_CELL = 3
EXIT_REFUSED = 4
#: The run's bag, inside its report folder.
BAG_DIR = "bag"
#: How long the recorder may take to close its bag after SIGINT (s).
RECORDER_CLOSE_S = 30.0
#: The recorder's niceness (``start_recorder``).
RECORDER_NICE = 10


def image_to_png(msg: Any, path: Path) -> bool:
    if msg is None or msg.encoding != "rgb8" or not msg.height:
        return False
    rows = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(msg.height, msg.step)
    rgb = rows[:, : msg.width * 3].reshape(msg.height, msg.width, 3)
    return bool(cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)))


def draw_plan(plan: Plan, path: Path) -> bool:
    try:
        from nodes.planner.draw import draw_plan as planner_draw
    except ImportError:
        return False
    if plan.scene is None:
        return False
    planner_draw(plan.scene, plan, path, title=f"plan {plan.plan_id}")
    return True


class Progress:
    """One line per plan and per feedback step of the goal, and a tqdm bar over the actions."""

    def __init__(self, quiet: bool) -> None:
        # A bar redrawn into a log file is megabytes of carriage returns: lines only there.
        live = not quiet and sys.stdout.isatty()
        self.bar = tqdm(total=1, unit="action", dynamic_ncols=True) if live else None
        self.plans_seen = 0
        self.last_line = ""

    def say(self, line: str) -> None:
        if self.bar is not None:
            self.bar.write(line)
        else:
            print(line, flush=True)

    def __call__(self, monitor: RunMonitor, wall: float) -> None:
        with monitor.lock:
            status, plans = monitor.feedback, list(monitor.plans)
        for plan in plans[self.plans_seen:]:
            self.say(f"plan {plan.plan_id}: {len(plan.actions)} actions, planned in "
                     f"{plan.planning_time_s:.2f} s (cost {plan.cost:.1f})")
        self.plans_seen = len(plans)
        if status is None:
            return
        line = f"[{status.action_index}/{status.action_total}] {status.state}: {status.detail}"
        if line != self.last_line:
            self.say(f"{line}  (sim {monitor.sim_time:.1f} s, wall {wall:.1f} s)")
            self.last_line = line
        if self.bar is not None:
            self.bar.total = max(status.action_total, 1)
            self.bar.n = status.action_index
            self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="densepack-run", description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="scenes/default.yaml", help="scene file (config/)")
    parser.add_argument("--report", type=Path, default=None, help="report folder (runs/<time>)")
    parser.add_argument("--timeout", type=float, default=900.0, help="wall-time limit (s)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress bar (there is none either when stdout is not a terminal)")
    parser.add_argument("--no-record", action="store_true",
                        help=f"do not record the run into <report>/{BAG_DIR} (rosbag2, MCAP)")
    parser.add_argument("--remote", default="", metavar="NODES",
                        help="nodes of the cell that run on other computers (comma-separated, "
                        "e.g. sim,detector,arm,gripper, started there with densepack-cell "
                        "--nodes): not started here, and the run stops (exit 5) naming any it "
                        "cannot see")
    parser.add_argument("--discovery-timeout", type=float, default=FIRST_SEEN_S, metavar="S",
                        help="how soon the --remote nodes must be seen (s)")
    return parser


def start_recorder(cell: CellRun, bag: Path) -> subprocess.Popen:
    """``densepack-record --all`` into ``bag`` (simulated time, images compressed), as its
    own process beside the cell: the run's own loop stays as light as without it. It runs
    at a lower CPU priority (RECORDER_NICE): it takes a message in 0.3 ms, 6 s of CPU over
    the default run, and at the cell's priority it slowed the cell's round trips on two
    cores (the default run's wall time 26-29 s with it, 23.5-23.9 s niced, 22.6-22.9 s
    without it); its queues (``bags.RECORD_DEPTH``) hold what comes meanwhile."""
    return cell.attach("record", [sys.executable, "-m", "nodes.tools.record", "--all",
                                  "--use-sim-time", "--quiet", "--nice", str(RECORDER_NICE),
                                  "-o", str(bag)])


def stop_recorder(proc: subprocess.Popen) -> bool:
    """Ctrl-C the recorder and wait for it to close the bag; True when it did."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=RECORDER_CLOSE_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        return False
    return proc.returncode == 0


def main(args: Sequence[str] | None = None) -> int:
    opts = build_parser().parse_args(args)
    scene_file = config_path(opts.scene).resolve()
    try:
        scene = load_scene(scene_file)
        layout = check_goal(scene)
    except (OSError, ValueError) as err:  # MessageError: a bad scene or goal, field named
        print(f"densepack-run: {scene_file.name} refused: {err}", file=sys.stderr, flush=True)
        return EXIT_REFUSED
    report = opts.report or Path("runs") / dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    report.mkdir(parents=True, exist_ok=True)
    print(f"densepack-run: {len(scene.blocks)} blocks -> {scene.goal.n_slots} goal slots "
          f"({scene_file.name}); node logs in {report / 'cell.log'}", flush=True)
    context = Context()
    rclpy.init(context=context)
    stop_cells_on_sigterm()
    progress = Progress(opts.quiet)
    remote = tuple(n for n in opts.remote.split(",") if n)
    with open(report / "cell.log", "w") as log:
        cell = CellRun(scene_file, log, remote=remote)
        monitor = RunMonitor(context)
        topic = another_cell(monitor.node, remote=remote)
        if topic is not None:
            domain = os.environ.get("ROS_DOMAIN_ID", "0")
            print(f"densepack-run: another cell is running on ROS_DOMAIN_ID={domain} (it "
                  f"publishes {topic}); stop it, or run this one with another ROS_DOMAIN_ID",
                  file=sys.stderr, flush=True)
            progress.close()
            monitor.node.destroy_node()
            rclpy.try_shutdown(context=context)
            return EXIT_ANOTHER_CELL
        recorder = None if opts.no_record else start_recorder(cell, report / BAG_DIR)
        cell.start()
        try:
            watch = DiscoveryWatch(remote, opts.discovery_timeout) if remote else None
            result = run(cell, monitor, layout, opts.timeout, progress, watch)
        finally:
            progress.close()
            recorded = recorder is not None and stop_recorder(recorder)
            cell.stop()
    if result.outcome == "unreachable":
        print(f"densepack-run: {'; '.join(result.notes)}", file=sys.stderr, flush=True)
    metrics = run_metrics(monitor, scene, result)
    if recorder is not None:
        metrics["bag"] = bag_figures(report / BAG_DIR) if recorded else None
    write_report(report, monitor, metrics)
    monitor.node.destroy_node()
    rclpy.try_shutdown(context=context)
    return EXIT_CODES[result.outcome]


def write_report(report: Path, monitor: RunMonitor, metrics: dict[str, Any]) -> None:
    with monitor.lock:
        first, last, plans = monitor.first_image, monitor.last_image, list(monitor.plans)
    image_to_png(first, report / "before.png")
    image_to_png(last, report / "after.png")
    if plans:
        save_plan(plans[0], report / "plan.json")
        draw_plan(plans[0], report / "plan.png")
    end = monitor.run_time
    with monitor.lock:
        spans = monitor.timeline.finish(
            end, {e["block"]: e["pos_err_m"] for e in metrics["final_errors"]})
    write_timeline(spans, report / "timeline.png", report / "timeline.json",
                   title=f"{report.name}: {metrics['outcome']}, {len(spans)} actions",
                   tolerance_m=PLACED_TOLERANCE_XY)
    (report / "metrics.json").write_text(json.dumps(metrics, indent=2, default=str) + "\n")
    worst, done = metrics["final_pos_err_max_m"], metrics["actions_executed"]
    print(f"densepack-run: {metrics['outcome']}; worst block "
          f"{'n/a' if worst is None else f'{worst * 1e3:.2f} mm'}, "
          f"{'n/a' if done is None else f'{done:.0f}'} actions, lost {metrics['blocks_lost']}, "
          f"wall {metrics['wall_time_s']:.0f} s; report in {report}", flush=True)
    bag = metrics.get("bag")
    if bag:
        print(f"densepack-run: recorded {bag['messages']} messages on {bag['topics']} topics "
              f"into {report / BAG_DIR} ({bag['size_mb']:.1f} MB); replay: densepack-play "
              f"{report / BAG_DIR}", flush=True)
    elif "bag" in metrics:
        print("densepack-run: the recorder did not close its bag (see cell.log)", flush=True)


def bag_figures(bag: Path) -> dict[str, Any] | None:
    """Messages, topics and size of a closed bag, from its ``metadata.yaml``."""

    try:
        info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    except (OSError, KeyError, TypeError, yaml.YAMLError):
        return None
    return {"messages": info["message_count"],
            "topics": sum(1 for t in info["topics_with_message_count"] if t["message_count"]),
            "size_mb": sum(f.stat().st_size for f in bag.iterdir()) / 1e6}



if __name__ == "__main__":
    sys.exit(main())
