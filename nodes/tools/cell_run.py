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
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from msgs_py import BlockSet, Plan, Scene
from nodes.common.paths import config_path
from nodes.common.runner import LAUNCHER_PID_ENV
from nodes.tools.cell import NodeLaunch, load_cell
from nodes.tools.timeline import TimelineBuilder

#: How the run tools change the cell file's node set: no goal node (the goal is a
#: ``/rearrange`` goal), and an executor that starts a plan only for a goal, so one restarted
#: mid-run waits for its client to send the goal again instead of resuming on its own.
ACTION_CELL_WITHOUT = ("goal",)
ACTION_CELL_PARAMS = {"executor": {"auto_start": False}}

#: A goal whose feedback (sent at least once a second) has been silent this long has lost its
#: server (the executor died): the goal is sent again (s).
GOAL_SILENCE_S = 10.0
#: A goal request unanswered this long is sent again (s).
GOAL_ANSWER_S = 10.0
#: A goal rejected when first sent is sent again after this long, this many times in all: the
#: client checked it already, so a rejection is the cell not being ready (the executor has not
#: yet taken the detection the client saw) until it happens again and again (s).
REJECTED_RETRY_S = 2.0
SENDS_WHEN_REJECTED = 3
#: After a cancel, wait this long for the goal's result (the arm lifts and parks) (s).
CANCEL_WAIT_S = 60.0
#: Result outcome -> the run's outcome (the names of the exit codes and reports).
OUTCOMES = {"succeeded": "done", "failed": "failed", "canceled": "canceled",
            "preempted": "failed"}


class RunMonitor:
    """The latest of everything a run report needs, from the cell's topics and the goal."""

    def __init__(self, context: Any) -> None:
        from densepack_interfaces.action import Rearrange
        from densepack_interfaces.msg import BlockPoseArray, ExecutorStatus, SimEvents
        from densepack_interfaces.msg import Plan as PlanMsg
        from densepack_interfaces.msg import PlannerStatus as PlannerStatusMsg
        from rclpy.action import ActionClient
        from rclpy.node import Node
        from sensor_msgs.msg import Image

        from msgs_py import ros as msg_codecs
        from nodes.common.qos import LATCHED, RELIABLE, SENSOR

        self.node = Node("densepack_run", context=context)
        self.lock = threading.Lock()
        self.executor_status: Any = None
        self.planner_status: Any = None
        self.plans: list[Plan] = []
        self.events: Any = None  # msgs_py.sim.SimEvents
        self.ground_truth: BlockSet | None = None
        self.detection: BlockSet | None = None
        self.feedback: Any = None  # msgs_py.tasks.RearrangeFeedback of the goal
        self.result: Any = None  # msgs_py.tasks.RearrangeResult of the goal
        self.first_image: Any = None
        self.last_image: Any = None
        self.sim_time = 0.0
        # Per-action spans for the report's timeline, from the status stream as it comes.
        self.timeline = TimelineBuilder()
        n = self.node
        n.create_subscription(ExecutorStatus, "/executor/status", self._on_executor_status,
                              LATCHED)
        n.create_subscription(PlannerStatusMsg, "/planner/status",
                              self._keep("planner_status", msg_codecs.planner_status_from_msg),
                              LATCHED)
        n.create_subscription(PlanMsg, "/plan", self._keep("plans", msg_codecs.plan_from_msg),
                              LATCHED)
        n.create_subscription(BlockPoseArray, "/sim/ground_truth",
                              self._keep("ground_truth", msg_codecs.block_set_from_msg), RELIABLE)
        n.create_subscription(BlockPoseArray, "/blocks/detected",
                              self._keep("detection", msg_codecs.block_set_from_msg), RELIABLE)
        n.create_subscription(SimEvents, "/sim/events",
                              self._keep("events", msg_codecs.sim_events_from_msg), LATCHED)
        n.create_subscription(Image, "/camera/image_raw", self._on_image, SENSOR)
        # Simulated time comes from the ground truth's stamps (10 Hz), not /clock: a /clock
        # subscription costs a Python callback per message.
        self.rearrange = ActionClient(n, Rearrange, "/rearrange")

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
                        self.timeline.add_plan(value.plan_id, [a.type for a in value.actions])
                else:
                    setattr(self, attr, value)

        return callback

    def _on_executor_status(self, msg: Any) -> None:
        from msgs_py import MessageError
        from msgs_py.ros import executor_status_from_msg, stamp_to_ns

        try:
            status = executor_status_from_msg(msg)
        except (MessageError, ValueError):
            return
        with self.lock:
            self.executor_status = status
            # The executor stamps its status with its simulated clock.
            self.timeline.on_status(stamp_to_ns(msg.stamp) * 1e-9, status.state, status.plan_id,
                                    status.action_index, status.action_total, status.block)

    def _on_image(self, msg: Any) -> None:
        with self.lock:
            if self.first_image is None:
                self.first_image = msg
            self.last_image = msg


class GoalSender:
    """Sends a goal layout to ``/rearrange`` once the cell sees its blocks, follows its
    feedback into the monitor, and sends it again when its server went silent (an executor
    killed and restarted: the new one does not know the goal). ``outcome`` is set when the
    goal ends: a result outcome, or ``rejected``.

    Each goal carries an id made here, so a goal whose answer was lost on the way (DDS can
    drop a service response sent before the server has met the client's reader; the
    executor then runs a goal its client never heard accepted) is still recognised by its
    feedback and followed: sending it again would only be refused, the first one running."""

    def __init__(self, monitor: RunMonitor, layout: Scene) -> None:
        from msgs_py.ros import rearrange_goal_to_msg

        self.monitor = monitor
        self.goal = rearrange_goal_to_msg(layout)
        self.handle: Any = None  # the goal being followed
        self._sending: Any = None  # a goal request not answered yet
        self._sent_at = 0.0
        self._heard_at = 0.0
        self._result: Any = None
        self._rejected = 0
        self._sent_ids: set[bytes] = set()  # every goal id sent, answered or not
        self._running_id: Any = None  # a sent goal heard from in feedback before its answer
        self.outcome = ""
        self.resent = 0

    def step(self, now: float) -> None:
        if self.outcome:
            return
        if self.handle is None and self._running_id is not None:
            self._follow_unanswered(now)
        elif self._sending is not None:
            self._answer(now)
        elif self.handle is None:
            ready = self.monitor.rearrange.server_is_ready() and self.monitor.detection is not None
            if ready and now - self._sent_at >= REJECTED_RETRY_S * bool(self._rejected):
                self._send(now)
        elif self._result.done():
            self._finish(self._result.result())
        elif now - self._heard_at > GOAL_SILENCE_S:
            self.resent += 1
            self._send(now)

    def _send(self, now: float) -> None:
        from unique_identifier_msgs.msg import UUID

        goal_id = UUID(uuid=list(uuid.uuid4().bytes))
        self._sent_ids.add(bytes(goal_id.uuid))
        self._sending = self.monitor.rearrange.send_goal_async(
            self.goal, feedback_callback=self._on_feedback, goal_uuid=goal_id)
        self._sent_at = now

    def _follow_unanswered(self, now: float) -> None:
        """Our goal runs (its feedback says so) though its answer never came: follow it."""
        from densepack_interfaces.action import Rearrange
        from rclpy.action.client import ClientGoalHandle

        accepted = Rearrange.Impl.SendGoalService.Response(accepted=True)
        handle = ClientGoalHandle(self.monitor.rearrange, self._running_id, accepted)
        self.handle, self._result = handle, handle.get_result_async()
        self._sending, self._running_id, self._heard_at = None, None, now

    def _answer(self, now: float) -> None:
        if not self._sending.done():
            if now - self._sent_at > GOAL_ANSWER_S:
                self._sending = None  # lost on the way (no server yet): try again later
                self._heard_at = now
            return
        handle, self._sending = self._sending.result(), None
        self._heard_at = now
        if handle.accepted:
            self.handle, self._result = handle, handle.get_result_async()
        elif self.handle is None:
            self._rejected += 1
            self._sent_at = now
            if self._rejected >= SENDS_WHEN_REJECTED:
                self.outcome = "rejected"
        # else: a resend refused while the old goal still runs: keep following that one

    def _on_feedback(self, message: Any) -> None:
        from msgs_py.ros import rearrange_feedback_from_msg

        self._heard_at = time.monotonic()
        if self.handle is None and bytes(message.goal_id.uuid) in self._sent_ids:
            self._running_id = message.goal_id
        feedback = rearrange_feedback_from_msg(message.feedback)
        with self.monitor.lock:
            self.monitor.feedback = feedback
            self.monitor.timeline.on_corrections(feedback.corrections)

    def _finish(self, answer: Any) -> None:
        from msgs_py.ros import rearrange_result_from_msg

        result = rearrange_result_from_msg(answer.result)
        with self.monitor.lock:
            self.monitor.result = result
        self.outcome = result.outcome

    def cancel(self, spin: Callable[[], None], wait_s: float = CANCEL_WAIT_S) -> None:
        """Cancel the goal (a safe stop) and wait for its result, spinning with ``spin``."""
        if self.handle is None or self.outcome:
            return
        self.handle.cancel_goal_async()
        deadline = time.monotonic() + wait_s
        while not self._result.done() and time.monotonic() < deadline:
            spin()
        if self._result.done():
            self._finish(self._result.result())


@dataclass
class RunResult:
    outcome: str  # done | failed | canceled | rejected | timeout | crashed
    wall_time_s: float
    notes: list[str] = field(default_factory=list)


class CellRun:
    """The cell's nodes as separate processes, logging to one file (the goal node left out:
    the run sends its goal on the action)."""

    def __init__(self, scene_file: Path, log: IO[str], cell_file: str = "cell.yaml",
                 extra_ros_args: tuple[str, ...] = ()) -> None:
        launches, missing = load_cell(config_path(cell_file), (),
                                      {"scene_file": str(scene_file)},
                                      ACTION_CELL_WITHOUT, ACTION_CELL_PARAMS)
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
            self.procs[launch.name] = self._spawn(launch.name, cmd)
            self.killed.discard(launch.name)

    def attach(self, name: str, cmd: list[str]) -> subprocess.Popen:
        """Start a helper process beside the cell (a recorder): same environment and log,
        but not one of the cell's nodes, so its end is no crash and ``stop`` leaves it be."""
        return self._spawn(name, cmd)

    def _spawn(self, name: str, cmd: list[str]) -> subprocess.Popen:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, env=self.env, start_new_session=True)
        pump = threading.Thread(target=self._pump, args=(name, proc), daemon=True)
        pump.start()
        self.pumps.append(pump)
        return proc

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


def check_goal(scene: Scene, cell_file: str = "cell.yaml") -> Scene:
    """The goal layout of ``scene``, checked the way the executor checks a Rearrange goal (its
    blocks standing in for the first detection; its parameters from the cell file), so a goal
    the cell would reject is refused here with the reason.

    Raises:
        MessageError: the scene has no goal, or the cell cannot carry it out (field named).
    """
    from nodes.common.params import configs_from_parameters, read_params_file
    from nodes.executor.config import ExecutorConfig
    from nodes.executor.goals import check_layout
    from nodes.tools.goal import goal_layout

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
    layout: Scene,
    timeout_s: float,
    on_progress: Callable[[RunMonitor, float], None] = lambda m, t: None,
) -> RunResult:
    """Send ``layout`` as a Rearrange goal and spin the monitor until the goal ends, a node
    crashes or time runs out (the goal is then canceled: a safe stop)."""
    from rclpy.executors import SingleThreadedExecutor

    executor = SingleThreadedExecutor(context=monitor.node.context)
    executor.add_node(monitor.node)
    sender = GoalSender(monitor, layout)
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
            sender.step(time.monotonic())
            on_progress(monitor, time.monotonic() - wall0)
            if sender.outcome:
                outcome = OUTCOMES.get(sender.outcome, sender.outcome)
                settle = time.monotonic() + 2.0
                while time.monotonic() < settle:  # last ground truth and events
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
        "sim_time_s": monitor.sim_time,
        "wall_time_s": result.wall_time_s,
        "unintended_contacts": events.unintended_contacts if events else None,
        "blocks_lost": events.blocks_lost if events else None,
        "events": events.to_dict()["events"] if events else [],
        "sim_time_by_activity_s": {k[len("time_"):-2]: v for k, v in figures.items()
                                   if k.startswith("time_") and k.endswith("_s")},
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
