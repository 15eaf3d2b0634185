"""Cell benchmark: seeded scenes through the whole loop in simulation, optionally with faults.

``densepack-bench cell --scenes 10 [--blocks 9] [--fault NAME ...]`` runs sim, detector,
planner and executor as separate processes on each scene (the sim's seeded random scenes
scattered in a workspace sized for ``--density``, goal: a dense grid with 3 mm gaps, sent as
a ``/rearrange`` goal as ``densepack-run`` sends it) and reports, per (blocks, fault):
success (every block within 3 mm / 2 deg of its goal by ground truth, none lost, goal
succeeded), final errors, actions executed vs planned, corrections (replans), unintended
contacts, lost blocks, simulated and wall time.

Faults, injected once per scene: ``executor_restart`` / ``planner_restart`` (SIGKILL the
process when action 2 is running, start it again 2 s later; a restarted executor has lost
the goal, which the client sends again once its feedback has gone silent), ``nudge`` (a
hand pushes an already placed block about 1 cm between two actions), ``camera_drop``
(camera frames dropped for 8 simulated seconds while the executor is observing).
"""

from __future__ import annotations

import json
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from msgs_py import save_plan, save_scene
from nodes.tools.cell_run import (
    CellRun,
    RunMonitor,
    check_goal,
    private_domain,
    run_metrics,
    stop_cells_on_sigterm,
)
from nodes.tools.cell_run import run as run_cell

FAULTS = ("none", "executor_restart", "planner_restart", "nudge", "camera_drop")
SUCCESS_POS_M = 0.003
SUCCESS_YAW_DEG = 2.0

COLUMNS = [
    "blocks", "fault", "scenes", "success_rate", "pos_err_median_m", "pos_err_max_m",
    "yaw_err_median_deg", "yaw_err_max_deg", "actions_executed_median", "actions_planned_median",
    "corrections", "unintended_contacts", "blocks_lost", "sim_time_median_s",
    "wall_time_median_s", "wall_time_max_s",
]


def add_arguments(parser) -> None:
    parser.add_argument("--scenes", type=int, default=10, help="seeded scenes per fault")
    parser.add_argument("--blocks", type=int, nargs="+", default=[9], help="blocks per scene")
    parser.add_argument("--density", type=float, default=0.10,
                        help="block area / workspace area of the random scenes")
    parser.add_argument("--fault", nargs="+", default=["none"], choices=[*FAULTS, "all"])
    parser.add_argument("--timeout", type=float, default=600.0, help="wall limit per scene (s)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep each scene's log, scene file and metrics under this folder")


class FaultInjector:
    """Injects one fault into a running cell when the executor's progress calls for it."""

    def __init__(self, name: str, cell: CellRun, monitor: RunMonitor) -> None:
        from densepack_interfaces.msg import Disturbance
        from std_msgs.msg import Float64

        from nodes.common.qos import RELIABLE

        self.name = name
        self.cell = cell
        self.monitor = monitor
        self.done = name == "none"
        self.note = ""
        self._restart_at: float | None = None
        self._disturb = monitor.node.create_publisher(Disturbance, "/sim/disturb", RELIABLE)
        self._blackout = monitor.node.create_publisher(Float64, "/sim/camera_blackout", RELIABLE)
        self._float = Float64

    def __call__(self, monitor: RunMonitor, wall: float) -> None:
        if self._restart_at is not None and wall >= self._restart_at:
            node = self.name.split("_")[0]
            self.cell.start(node)
            self._restart_at = None
            self.note += f"; {node} restarted at {wall:.0f} s"
        if self.done:
            return
        status = monitor.feedback  # the goal's progress
        if status is None:
            return
        if self.name in ("executor_restart", "planner_restart") and (
                status.state == "running" and status.action_index >= 2):
            node = self.name.split("_")[0]
            self.cell.kill(node)
            self._restart_at = wall + 2.0
            self.done = True
            self.note = f"{node} killed during action {status.action_index}"
        elif self.name == "nudge" and (
                status.state == "observing" and status.action_index >= 2 and monitor.plans):
            from msgs_py.interface_codecs import disturbance_to_msg
            from msgs_py.sim import Disturbance

            block = monitor.plans[0].actions[0].block
            self._disturb.publish(disturbance_to_msg(Disturbance(block, 0.008, 0.006)))
            self.done = True
            self.note = f"block {block} nudged by (8, 6) mm after action {status.action_index}"
        elif self.name == "camera_drop" and (
                status.state == "observing" and status.action_index >= 1):
            self._blackout.publish(self._float(data=8.0))
            self.done = True
            self.note = f"camera frames dropped for 8 s after action {status.action_index}"


def run_scene(blocks: int, density: float, seed: int, fault: str, timeout: float,
              workdir: Path) -> dict[str, Any]:
    import rclpy
    from rclpy.context import Context

    from nodes.sim.layout import random_sim_scene

    scene = random_sim_scene(blocks, density, seed)
    layout = check_goal(scene)
    scene_file = save_scene(scene, workdir / f"scene_{blocks}_{seed}.yaml")
    private_domain()
    context = Context()
    rclpy.init(context=context)
    stop_cells_on_sigterm()
    try:
        with open(workdir / f"cell_{blocks}_{seed}_{fault}.log", "w") as log:
            cell = CellRun(scene_file, log)
            monitor = RunMonitor(context)
            injector = FaultInjector(fault, cell, monitor)
            cell.start()
            try:
                result = run_cell(cell, monitor, layout, timeout, injector)
            finally:
                cell.stop()
        if injector.note:
            result.notes.append(injector.note.lstrip("; "))
        if not injector.done:
            result.notes.append(f"fault {fault} was never injected")
        metrics = run_metrics(monitor, scene, result)
        monitor.node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    for k, plan in enumerate(monitor.plans):
        save_plan(plan, workdir / f"plan_{blocks}_{seed}_{fault}_{k}.json")
    metrics.update(seed=seed, fault=fault, success=is_success(metrics))
    (workdir / f"metrics_{blocks}_{seed}_{fault}.json").write_text(
        json.dumps(metrics, indent=2, default=str))
    return metrics


def is_success(m: dict[str, Any]) -> bool:
    return (m["outcome"] == "done" and m["final_pos_err_max_m"] is not None
            and m["final_pos_err_max_m"] <= SUCCESS_POS_M
            and m["final_yaw_err_max_deg"] <= SUCCESS_YAW_DEG
            and not m["blocks_lost"])


def summarise(blocks: int, fault: str, runs: list[dict[str, Any]]) -> dict[str, Any]:
    errors = [e for m in runs for e in m["final_errors"]]
    pos = [e["pos_err_m"] for e in errors]
    yaw = [e["yaw_err_deg"] for e in errors]

    def median(key: str, items=runs) -> float:
        values = [m[key] for m in items if m.get(key) is not None]
        return statistics.median(values) if values else float("nan")

    def total(key: str) -> float:
        return float(sum(m[key] or 0 for m in runs))

    return {
        "blocks": blocks,
        "fault": fault,
        "scenes": len(runs),
        "success_rate": sum(m["success"] for m in runs) / len(runs),
        "pos_err_median_m": statistics.median(pos) if pos else float("nan"),
        "pos_err_max_m": max(pos) if pos else float("nan"),
        "yaw_err_median_deg": statistics.median(yaw) if yaw else float("nan"),
        "yaw_err_max_deg": max(yaw) if yaw else float("nan"),
        "actions_executed_median": median("actions_executed"),
        "actions_planned_median": median("actions_planned"),
        "corrections": total("replans"),
        "unintended_contacts": total("unintended_contacts"),
        "blocks_lost": total("blocks_lost"),
        "sim_time_median_s": median("sim_time_s"),
        "wall_time_median_s": median("wall_time_s"),
        "wall_time_max_s": max(m["wall_time_s"] for m in runs),
        "outcomes": [f"seed {m['seed']}: {m['outcome']}"
                     + (f" ({'; '.join(m['notes'])})" if m["notes"] else "")
                     + (f" [{m['last_error']}]" if m.get("last_error") else "")
                     for m in runs],
    }


def run(opts, scene_runner: Callable[..., dict[str, Any]] = run_scene) -> list[dict[str, Any]]:
    faults = list(FAULTS) if "all" in opts.fault else opts.fault
    scenes = 2 if opts.quick else (opts.seeds or opts.scenes)
    workdir = opts.keep or Path(tempfile.mkdtemp(prefix="densepack-cell-bench-"))
    workdir.mkdir(parents=True, exist_ok=True)
    rows = []
    for blocks in opts.blocks:
        for fault in faults:
            runs = []
            for seed in range(opts.first_seed, opts.first_seed + scenes):
                t0 = time.monotonic()
                m = scene_runner(blocks, opts.density, seed, fault, opts.timeout, workdir)
                runs.append(m)
                print(f"  {blocks} blocks, {fault}, seed {seed}: {m['outcome']}, success "
                      f"{m['success']}, worst {m['final_pos_err_max_m']}, "
                      f"{time.monotonic() - t0:.0f} s", flush=True)
            rows.append(summarise(blocks, fault, runs))
    print(f"logs and per-scene metrics in {workdir}")
    return rows
