"""Soak: a shift on one cell, goal after goal through ``/rearrange``.

``densepack-bench soak --goals N [--blocks 9] [--density 0.10] [--first-seed 0]`` starts the
cell once (sim, detector, planner, arm, gripper, executor: one process each, as
``densepack-run`` starts them) and sends N goals, each from a new seeded random scene (the
cell benchmark's scenes: seed = first seed + goal - 1). Before each goal after the first the
sim lays the new scene out (its ``random.*`` parameters set, then ``/sim/reset``, which in
the cell keeps the clock running and the arm where it stands), the detector forgets its
blocks (``/detector/reset``) and the goal is sent once a detection shows the new scene.

Per goal: the outcome, actions executed, corrections, the worst block error and lost blocks
(ground truth), unintended contacts, simulated and wall time, every process's resident
memory after the goal and CPU time during it (from /proc), and whether the goal started
afresh (``inherited``: it saw the new scene's blocks, its first plan started from them and
the sim's event counts were back at zero). The last row sums the shift up against issue
29's targets (nodes/bench/soak_figures.py).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import time
from pathlib import Path
from typing import Any

import rclpy
from rcl_interfaces.srv import SetParameters
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from msgs_py import Scene, save_scene
from nodes.bench import proc_stats
from nodes.bench.cell_figures import SUCCESS_POS_M, SUCCESS_YAW_DEG, held_at_end
from nodes.bench.soak_figures import (
    BENCH_CLIENT,
    flat_row,
    fresh_start_problems,
    goal_counts,
    reset_time_s,
    summarise,
)
from nodes.cell.monitor import RunMonitor
from nodes.cell.processes import (
    CellRun,
    private_domain,
    private_ros_home,
    stop_cells_on_sigterm,
)
from nodes.cell.run import check_goal, run_metrics
from nodes.cell.run import run as run_goal
from nodes.common.qos import RELIABLE
from nodes.sim.layout import random_sim_scene

#: The processes whose memory and CPU are reported: the cell's and this one (the client).
PROCESSES = ("sim", "detector", "planner", "arm", "gripper", "executor", BENCH_CLIENT)
#: Wall-time limits of the steps between goals (s).
SERVICE_S = 60.0
SCENE_SEEN_S = 90.0
FRAME_EVERY_S = 2.0

COLUMNS = ["goal", "seed", "outcome", "actions", "corrections", "worst_mm", "worst_deg",
           "lost", "contacts", "sim_s", "wall_s", "inherited",
           *(f"rss_{p}_mb" for p in PROCESSES), "cpu_total_s"]


def add_arguments(parser) -> None:
    parser.add_argument("--goals", type=int, default=200, help="goals sent to the one cell")
    parser.add_argument("--blocks", type=int, default=9, help="blocks per scene")
    parser.add_argument("--density", type=float, default=0.10,
                        help="block area / workspace area of the random scenes")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=600.0, help="wall limit per goal (s)")
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep the cell's log and each goal's metrics under this folder")


class SoakCell:
    """One cell for the whole shift, and the calls that lay out each new scene."""

    def __init__(self, context: Context, first: Scene, workdir: Path, log) -> None:
        self.cell = CellRun(save_scene(first, workdir / "scene_first.yaml"), log,
                            paused_start=False)
        self.monitor = RunMonitor(context)
        node = self.monitor.node
        self.set_params = node.create_client(SetParameters, "/sim/set_parameters")
        self.sim_reset = node.create_client(Trigger, "/sim/reset")
        self.detector_reset = node.create_client(Trigger, "/detector/reset")
        self.frames = node.create_publisher(Header, "/sim/render_request", RELIABLE)
        self.cell.start()

    def pids(self) -> dict[str, int]:
        pids = {name: proc.pid for name, proc in self.cell.procs.items()
                if proc.poll() is None}
        return {**pids, BENCH_CLIENT: os.getpid()}

    def samples(self) -> dict[str, proc_stats.ProcSample | None]:
        """Every process's figures now: a node's with its descendants (the planner plans in
        processes of its own), the client's alone (the cell's nodes are its children)."""
        parents = proc_stats.process_parents()
        return {name: proc_stats.sample(pid, parents=None if name == BENCH_CLIENT else parents)
                for name, pid in self.pids().items()}

    def lay_out(self, scene: Scene, seed: int, blocks: int, density: float) -> None:
        """The sim's next scene (its random.* parameters, then /sim/reset), the detector's
        blocks forgotten, the monitor told the goal begins; back once a detection shows the
        scene's blocks (frames asked for: the executor looks only for its own goals)."""
        values = {"random.n_blocks": blocks, "random.density": density, "random.seed": seed}
        request = SetParameters.Request(parameters=[Parameter(k, value=v).to_parameter_msg()
                                                    for k, v in values.items()])
        answer = self._call(self.set_params, request)
        if not all(r.successful for r in answer.results):
            raise RuntimeError(f"sim parameters refused: {[r.reason for r in answer.results]}")
        reset = self._call(self.sim_reset, Trigger.Request())
        if not reset.success:
            raise RuntimeError(f"/sim/reset failed: {reset.message}")
        self._call(self.detector_reset, Trigger.Request())
        at = reset_time_s(reset.message)
        self.monitor.begin_goal(round((at if at is not None else self.monitor.sim_time) * 1e9))
        self.wait_for_scene(scene)

    def wait_for_scene(self, scene: Scene) -> None:
        ids = sorted(b.id for b in scene.blocks)
        asked = -math.inf
        deadline = time.monotonic() + SCENE_SEEN_S
        with _Spinner(self.monitor.node) as spin:
            while time.monotonic() < deadline:
                with self.monitor.lock:
                    seen = self.monitor.detection
                if seen is not None and sorted(seen.ids) == ids:
                    return
                if time.monotonic() - asked > FRAME_EVERY_S:
                    self.frames.publish(Header(frame_id="soak"))
                    asked = time.monotonic()
                spin()
        raise RuntimeError(f"no detection of blocks {ids} within {SCENE_SEEN_S:.0f} s")

    def _call(self, client, request):
        with _Spinner(self.monitor.node) as spin:
            deadline = time.monotonic() + SERVICE_S
            while not client.service_is_ready() and time.monotonic() < deadline:
                spin()
            future = client.call_async(request)
            while not future.done() and time.monotonic() < deadline:
                spin()
        if not future.done():
            raise RuntimeError(f"{client.srv_name} did not answer within {SERVICE_S:.0f} s")
        return future.result()


class _Spinner:
    """The monitor's node on an executor of its own for a while (``run_goal`` adds it to
    its own for each goal)."""

    def __init__(self, node) -> None:
        self.executor = SingleThreadedExecutor(context=node.context)
        self.node = node

    def __enter__(self):
        self.executor.add_node(self.node)
        return lambda: self.executor.spin_once(timeout_sec=0.1)

    def __exit__(self, *exc) -> None:
        self.executor.remove_node(self.node)
        self.executor.shutdown()


def one_goal(soak: SoakCell, goal: int, seed: int, scene: Scene, before: dict[str, Any],
             timeout: float) -> dict[str, Any]:
    """Run goal number ``goal`` on the scene laid out; its row (``before``: the executor's
    lifetime counts and the processes' samples as the goal began)."""
    monitor = soak.monitor
    with monitor.lock:
        detection, events = monitor.detection, monitor.events
    start_sim = monitor.sim_time
    result = run_goal(soak.cell, monitor, check_goal(scene), timeout)
    m = run_metrics(monitor, scene, result)
    with monitor.lock:
        final, status = monitor.result, monitor.executor_status
        first_plan = monitor.plans[0] if monitor.plans else None
    # the executor's lifetime counts: its result's, else (no result) its last status'
    lifetime = dict(final.metrics if final is not None else
                    status.metrics if status is not None else before["lifetime"])
    counts = goal_counts(before["lifetime"], lifetime)
    samples = soak.samples()
    inherited = fresh_start_problems(
        scene, detection, first_plan, events.unintended_contacts if events else None,
        events.blocks_lost if events else None)
    row = {
        "goal": goal, "seed": seed, "outcome": m["outcome"],
        "actions": counts.get("actions_executed"), "corrections": lifetime.get("corrections"),
        "worst_mm": _scaled(m["final_pos_err_max_m"], 1e3), "worst_deg": m["final_yaw_err_max_deg"],
        # a block the goal left in the fingers counts as lost (the sim never sees it rest)
        "lost": None if m["blocks_lost"] is None else m["blocks_lost"] + held_at_end(m),
        "contacts": m["unintended_contacts"],
        "sim_start_s": start_sim, "sim_s": monitor.run_time - start_sim,
        "wall_s": result.wall_time_s,
        "inherited": "; ".join(inherited),
        "rss_mb": {n: s.rss_mb if s else None for n, s in samples.items()},
        "cpu_s": {n: proc_stats.cpu_used(before["samples"].get(n), s)
                  for n, s in samples.items()},
        "executor_counts": counts, "notes": m["notes"], "last_error": m["last_error"],
        "events": m["events"],  # the sim's unintended contacts and lost blocks, each with why
    }
    row["success"] = (row["outcome"] == "done" and row["worst_mm"] is not None
                      and row["worst_mm"] <= SUCCESS_POS_M * 1e3
                      and (row["worst_deg"] or 0.0) <= SUCCESS_YAW_DEG and not row["lost"])
    before.update(lifetime=lifetime, samples=samples)
    return row


def _scaled(value: float | None, factor: float) -> float | None:
    return None if value is None else value * factor


def run(opts) -> list[dict[str, Any]]:
    goals = 2 if opts.quick else opts.goals
    workdir = opts.keep or Path(tempfile.mkdtemp(prefix="densepack-soak-"))
    workdir.mkdir(parents=True, exist_ok=True)
    private_domain()
    private_ros_home(workdir)
    context = Context()
    rclpy.init(context=context)
    stop_cells_on_sigterm()
    rows: list[dict[str, Any]] = []
    try:
        with open(workdir / "cell.log", "w") as log:
            seeds = [opts.first_seed + k for k in range(goals)]
            scenes = [random_sim_scene(opts.blocks, opts.density, s) for s in seeds]
            soak = SoakCell(context, scenes[0], workdir, log)
            try:
                rows = _shift(soak, seeds, scenes, opts, workdir)
            finally:
                soak.cell.stop()
                soak.monitor.node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    summary = summarise(rows) if rows else {}
    (workdir / "summary.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
    print(f"soak: {summary.get('done')}/{len(rows)} done; targets {summary.get('targets')}; "
          f"logs in {workdir}", flush=True)
    return [flat_row(r, PROCESSES) for r in rows] + ([_summary_row(summary)] if rows else [])


def _shift(soak: SoakCell, seeds, scenes, opts, workdir: Path) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    soak.wait_for_scene(scenes[0])
    before = {"lifetime": {}, "samples": soak.samples()}
    for k, (seed, scene) in enumerate(zip(seeds, scenes, strict=True), start=1):
        if k > 1:
            soak.lay_out(scene, seed, opts.blocks, opts.density)
        row = one_goal(soak, k, seed, scene, before, opts.timeout)
        rows.append(row)
        (workdir / f"goal_{k:03d}.json").write_text(json.dumps(row, indent=2, default=str))
        worst = "n/a" if row["worst_mm"] is None else f"{row['worst_mm']:.2f} mm"
        print(f"  goal {k} (seed {seed}): {row['outcome']}, {row['actions']} actions, worst "
              f"{worst}, sim {row['sim_s']:.0f} s, wall {row['wall_s']:.0f} s"
              + (f"; INHERITED: {row['inherited']}" if row["inherited"] else ""), flush=True)
        if row["outcome"] == "crashed":
            break  # a node that may not respawn died: the cell is gone
    return rows


def _summary_row(summary: dict[str, Any]) -> dict[str, Any]:
    return {**summary, "goal": "all", "outcome": f"{summary['done']}/{summary['goals']} done",
            "inherited": f"{summary['fresh']} fresh"}
