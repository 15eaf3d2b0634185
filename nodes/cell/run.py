"""One run of the whole cell, driven from outside: start the nodes, send the goal, watch,
inject faults.

``CellRun`` starts every node of the cell file as its own process (so a fault can kill and
restart one) but the goal node: the goal goes to the executor's ``/rearrange`` action
(``GoalSender``). ``RunMonitor`` collects what a report needs from the cell's topics and the
goal's feedback and result, and ``run()`` loops until the goal ends, a node crashes or time
runs out, calling ``on_progress`` hooks (the run command prints progress, the cell benchmark
injects faults).
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from std_srvs.srv import Trigger

from msgs_py import BlockSet, Scene
from nodes.cell.discovery import DiscoveryWatch, discovery_hint, graph_view
from nodes.cell.goal_sender import GoalSender
from nodes.cell.launch import load_cell
from nodes.cell.monitor import RunMonitor
from nodes.cell.processes import ACTION_CELL_PARAMS, CellRun
from nodes.common.executors import single_threaded
from nodes.common.params import configs_from_parameters, read_params_file
from nodes.common.paths import config_path
from nodes.executor.config import ExecutorConfig
from nodes.executor.goals import check_layout
from nodes.executor.verify import goal_errors
from nodes.goal.node import goal_layout

#: Result outcome -> the run's outcome (the names of the exit codes and reports).
OUTCOMES = {"succeeded": "done", "failed": "failed", "canceled": "canceled",
            "preempted": "failed"}
#: How often the graph is looked at for the nodes expected on other computers (s).
GRAPH_PERIOD_S = 0.5
#: A goal already running when a node is lost is canceled; its result is waited for this long
#: (the executor may be the computer that is cut off) (s).
UNREACHABLE_CANCEL_S = 10.0
#: After the result, the last ground truth and events are waited for: one stamped this long
#: (s of simulated time) after it, at most SETTLE_WALL_S of wall time.
SETTLE_SIM_S = 0.3
SETTLE_WALL_S = 2.0


@dataclass
class RunResult:
    outcome: str  # done | failed | canceled | rejected | timeout | crashed | unreachable
    wall_time_s: float
    notes: list[str] = field(default_factory=list)


def check_goal(scene: Scene, cell_file: str = "cell.yaml") -> Scene:
    """The goal layout of ``scene``, checked the way the executor checks a Rearrange goal (its
    blocks standing in for the first detection; its parameters from the cell file), so a goal
    the cell would reject is refused here with the reason.

    Raises:
        MessageError: the scene has no goal, or the cell cannot carry it out (field named).
    """
    (executor,), _ = load_cell(config_path(cell_file), ("executor",), {},
                               node_params=ACTION_CELL_PARAMS)
    values: dict[str, Any] = {}
    for path in executor.params_files:
        values.update(read_params_file(path, "executor"))
    values.update(executor.parameters)
    (config,) = configs_from_parameters((("", ExecutorConfig),), values, cell_file)
    layout = goal_layout(scene)
    check_layout(layout, BlockSet(scene.blocks, block_size=scene.block_size), config.safe_box)
    return layout


class SimStarter:
    """Starts the sim's clock (``/sim/start``) once every node of the run is on the graph: a
    sim started paused (``start_paused``) then charges the run no simulated time for the
    seconds its processes take to start. (Their statuses cannot say so: the nodes on the
    sim's clock publish on its ticks.) A sim that runs already answers so; none at all (a
    real cell) is never called."""

    def __init__(self, monitor: RunMonitor, nodes: set[str]) -> None:
        self.monitor = monitor
        self.nodes = nodes  #: the run's own nodes, but the sim
        self.client = monitor.sim_start
        self.asked = False

    def step(self) -> None:
        if self.asked or not self.client.service_is_ready():
            return
        if {name for name, _ in self.monitor.node.get_node_names_and_namespaces()
                } >= self.nodes:
            self.client.call_async(Trigger.Request())
            self.asked = True


def run(
    cell: CellRun,
    monitor: RunMonitor,
    layout: Scene,
    timeout_s: float,
    on_progress: Callable[[RunMonitor, float], None] = lambda m, t: None,
    watch: DiscoveryWatch | None = None,
) -> RunResult:
    """Send ``layout`` as a Rearrange goal and spin the monitor until the goal ends, a node
    crashes, ``watch`` cannot see a node expected on another computer (``unreachable``) or
    time runs out (the goal is then canceled: a safe stop)."""
    executor = single_threaded(context=monitor.node.context)
    executor.add_node(monitor.node)
    sender = GoalSender(monitor, layout)
    starter = SimStarter(monitor, set(cell.launches) - {"sim"})
    wall0 = time.monotonic()
    looked = -math.inf
    outcome = "timeout"
    notes: list[str] = []
    try:
        while time.monotonic() - wall0 < timeout_s:
            executor.spin_once(timeout_sec=0.1)
            crashed = cell.supervise()
            if crashed:
                notes.append(crashed)
                outcome = "crashed"
                break
            if watch is not None and time.monotonic() - looked >= GRAPH_PERIOD_S:
                looked = time.monotonic()
                with monitor.lock:
                    heard = dict(monitor.heard)
                report = watch.update(looked, graph_view(monitor.node, watch.topics), heard)
                if report:
                    notes += [report, discovery_hint(os.environ)]
                    outcome = "unreachable"
                    sender.cancel(lambda: executor.spin_once(timeout_sec=0.1), UNREACHABLE_CANCEL_S)
                    break
            starter.step()
            sender.step(time.monotonic())
            on_progress(monitor, time.monotonic() - wall0)
            if sender.outcome:
                outcome = OUTCOMES.get(sender.outcome, sender.outcome)
                monitor.goal_ended()
                settle = time.monotonic() + SETTLE_WALL_S
                while time.monotonic() < settle and not monitor.settled(SETTLE_SIM_S):
                    executor.spin_once(timeout_sec=0.1)
                break
        else:
            notes.append(f"no result within {timeout_s:.0f} s; goal canceled")
            sender.cancel(lambda: executor.spin_once(timeout_sec=0.1))
        if sender.outcome == "rejected":
            notes.append("the executor rejected the goal (its reason is in the log)")
        if sender.resent:
            notes.append(f"goal sent again {sender.resent} time(s) after its feedback went "
                         "silent")
    finally:
        executor.remove_node(monitor.node)
        executor.shutdown()
    return RunResult(outcome, time.monotonic() - wall0, notes)


def final_errors(truth: BlockSet | None, scene: Scene) -> list[dict[str, Any]]:
    """Each goal slot's error against the simulator's ground truth."""
    if truth is None:
        return []
    poses = {b.id: b.pose for b in truth.blocks}
    return [
        {"block": d.block, "pos_err_m": d.position_error,
         "yaw_err_deg": math.degrees(d.yaw_error)}
        for d in goal_errors(poses, scene)
    ]


def run_metrics(monitor: RunMonitor, scene: Scene, result: RunResult) -> dict[str, Any]:
    """The run report's figures: the goal's result (or, without one, the executor's last
    status), the ground truth's final errors and the sim's events."""
    with monitor.lock:
        status, feedback, final = monitor.executor_status, monitor.feedback, monitor.result
        plans, truth, events = list(monitor.plans), monitor.ground_truth, monitor.events
    errors = final_errors(truth, scene)
    pos = [e["pos_err_m"] for e in errors]
    yaw = [e["yaw_err_deg"] for e in errors]
    figures = final.metrics if final is not None else (status.metrics if status else {})
    last = feedback or status
    return {
        "outcome": result.outcome,
        "notes": result.notes,
        "executor_state": last.state if last else None,
        "result": final.detail if final is not None else None,
        "last_error": status.last_error if status else None,
        "blocks": len(scene.blocks),
        "actions_planned": len(plans[0].actions) if plans else None,
        "actions_executed": figures.get("actions_executed"),
        "plans": len(plans),
        "replans": figures.get("replans"),
        # what went wrong on the way, as the executor counted it (faults_<kind>, ...)
        "executor_faults": {k: v for k, v in figures.items()
                            if k.startswith("faults") or k in ("protective_stops",
                                                               "blocked_descents")},
        "planning_time_s": [p.planning_time_s for p in plans],
        "execution_time_s": figures.get("execution_time_s"),
        # to the goal's result (not the settling after it)
        "sim_time_s": monitor.run_time,
        "wall_time_s": result.wall_time_s,
        "unintended_contacts": events.unintended_contacts if events else None,
        "blocks_lost": events.blocks_lost if events else None,
        # blocks still off the table when the run ended: left in the fingers
        "blocks_raised_at_end": list(events.raised) if events else None,
        "events": events.to_dict()["events"] if events else [],
        "sim_time_by_activity_s": {k[len("time_"):-2]: v for k, v in figures.items()
                                   if k.startswith("time_") and k.endswith("_s")},
        # how the actions were looked at: on the way, through a waypoint, from the look pose
        "looks": {k[len("looks_"):]: v for k, v in figures.items() if k.startswith("looks_")},
        "final_pos_err_max_m": max(pos) if pos else None,
        "final_pos_err_median_m": sorted(pos)[len(pos) // 2] if pos else None,
        "final_yaw_err_max_deg": max(yaw) if yaw else None,
        "final_yaw_err_median_deg": sorted(yaw)[len(yaw) // 2] if yaw else None,
        "final_errors": errors,
        "perceived_errors": ([{"block": e.block_id, "found": e.found,
                               "pos_err_m": e.position_error_m,
                               "yaw_err_deg": math.degrees(e.yaw_error_rad)}
                              for e in final.block_errors] if final is not None else []),
    }
