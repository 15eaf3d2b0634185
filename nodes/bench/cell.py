"""Cell benchmark: seeded scenes through the whole loop in simulation, optionally with faults.

``densepack-bench cell --scenes 10 [--blocks 9] [--fault NAME ...]`` runs sim, detector,
planner and executor as separate processes on each scene (the sim's seeded random scenes
scattered in a workspace sized for ``--density``, goal: a dense grid with 3 mm gaps, sent as
a ``/rearrange`` goal as ``densepack-run`` sends it) and reports, per (blocks, fault):
success (every block within 3 mm / 2 deg of its goal by ground truth, none lost, goal
succeeded), final errors, actions executed vs planned, corrections (replans), unintended
contacts, lost blocks, simulated and wall time.

Faults, injected once per scene (``--fault all`` runs every kind), the kinds a real cell
meets (what happens; when):

- ``executor_restart``, ``planner_restart``, ``detector_restart``: the process is SIGKILLed
  and started again 2 s later (a restarted executor has lost the goal: the client sends it
  again); while action 2 runs.
- ``nudge``: a hand pushes an already placed block about 1 cm; between actions 2 and 3.
- ``knock``: the first placed block is knocked 13 mm while action 3 runs.
- ``camera_drop``: camera frames dropped for 8 simulated seconds; observing after action 1.
- ``grasp_miss``: the block is knocked aside as the open fingers hover over it; ``slip``:
  the held block slides in the fingers (slippery pads for 50 ms); ``drop``: the held block
  falls out of the fingers. Armed for the next action after action 1.
- ``misfire``: another program closes the gripper to 20 mm on ``/gripper/command`` while
  action 2 runs; the executor holds the gripper's lease then, so the gripper node must refuse
  it and name the benchmark's node (``/densepack_run``) on ``/gripper/status``: a success
  needs that too (``stray_refused``).
- ``knuckle_misfire``: the same close sent straight to the Robotiq driver's position
  controller, past densepack (nothing can refuse it there); the executor must notice it and
  restore its own command (its ``faults_misfire``); while action 2 runs.
- ``remove``: a person takes away a block not yet placed; the run must stop naming it, the
  arm parked with empty fingers, the rest left as it stands (this cell does not finish a
  goal that names a block it no longer has); after action 2.
- ``add``: a person puts an unknown block (tag 40) onto a free spot, an obstacle for the
  rest of the run; after action 2.
- ``camera_noise``: the camera's read noise becomes 20 grey levels (std); from the start.
- ``calibration``: the detector's camera pose is 5 mm and 0.5 deg (a tilt) off the true one;
  from the start.
- ``chaos`` (``--chaos``): one of the densepack nodes (executor, planner, detector, arm,
  gripper; drawn from the scene's seed) is SIGKILLed at a moment drawn too (an action, while
  it runs or while the camera looks, 0-2 s into it: mid-carry, mid-motion, mid-plan), and
  the cell file's respawn brings it back, nobody else: the goal must still end done or
  cleanly failed, nothing in the fingers, no block lost.
"""

from __future__ import annotations

import functools
import json
import math
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import rclpy
from densepack_interfaces.msg import Disturbance as DisturbanceMsg
from densepack_interfaces.msg import GripperStatus as GripperStatusMsg
from densepack_interfaces.msg import SimFault as SimFaultMsg
from rclpy.context import Context
from std_msgs.msg import Float64, Float64MultiArray

from msgs_py import Scene, drivers, save_plan, save_scene
from msgs_py.ros import disturbance_to_msg, sim_fault_to_msg
from msgs_py.sim import Disturbance
from msgs_py.sim import SimFault as SimFaultRecord
from nodes.bench.cell_figures import is_success, summarise
from nodes.bench.isolation import metrics_file, run_scene_isolated
from nodes.cell.monitor import RunMonitor
from nodes.cell.processes import CellRun, private_domain, private_ros_home, stop_cells_on_sigterm
from nodes.cell.run import check_goal, run_metrics
from nodes.cell.run import run as run_cell
from nodes.common.camera_model import load_camera_pose
from nodes.common.paths import config_path
from nodes.common.qos import RELIABLE
from nodes.common.transforms import matrix_to_quaternion, quaternion_to_matrix
from nodes.robot import gripper_2f85 as g85
from nodes.sim.layout import random_sim_scene

FAULTS = ("none", "executor_restart", "planner_restart", "detector_restart", "nudge",
          "camera_drop", "grasp_miss", "slip", "drop", "misfire", "knuckle_misfire", "knock",
          "remove", "add", "camera_noise", "calibration", "chaos")
#: The nodes the chaos fault may kill (the sim does not respawn: it is the world).
CHAOS_NODES = ("executor", "planner", "detector", "arm", "gripper")
#: The calibration fault: the detector's camera 3, -4, 0 mm off and tilted 0.5 deg.
CALIBRATION_SHIFT_M = (0.003, -0.004, 0.0)
CALIBRATION_TILT_DEG = 0.5
#: The node the misfire comes from (the run monitor's): the gripper must name it.
STRAY_NAME = "/densepack_run"
#: The block a person puts into the cell (a tag id no scene of the benchmark uses).
ADDED_BLOCK = 40

COLUMNS = [
    "blocks", "fault", "scenes", "success_rate", "pos_err_median_m", "pos_err_max_m",
    "yaw_err_median_deg", "yaw_err_max_deg", "actions_executed_median", "actions_planned_median",
    "corrections", "unintended_contacts", "blocks_lost", "blocks_held_at_end", "sim_time_median_s",
    "sim_time_per_action_median_s", "wall_time_median_s", "wall_time_max_s",
]


def add_arguments(parser) -> None:
    parser.add_argument("--scenes", type=int, default=10, help="seeded scenes per fault")
    parser.add_argument("--blocks", type=int, nargs="+", default=[9], help="blocks per scene")
    parser.add_argument("--density", type=float, default=0.10,
                        help="block area / workspace area of the random scenes")
    parser.add_argument("--fault", nargs="+", default=["none"], choices=[*FAULTS, "all"])
    parser.add_argument("--chaos", action="store_true",
                        help="the chaos fault: a random node SIGKILLed at a random moment of "
                             "each run, brought back by the cell's respawn (= --fault chaos)")
    parser.add_argument("--timeout", type=float, default=600.0, help="wall limit per scene (s)")
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep each scene's log, scene file and metrics under this folder")


class FaultInjector:
    """Injects one fault into a running cell when the goal's progress calls for it."""

    def __init__(self, name: str, cell: CellRun, monitor: RunMonitor, scene: Scene,
                 seed: int = 0) -> None:
        self.name = name
        self.chaos = ChaosDraw.of(seed, len(scene.blocks)) if name == "chaos" else None
        self.cell = cell
        self.monitor = monitor
        self.scene = scene
        self.done = name in ("none", "calibration")  # the calibration is wrong from the start
        self.note = "detector camera pose 5 mm / 0.5 deg off" if name == "calibration" else ""
        self.removed: int | None = None
        self._restart_at: float | None = None
        node = monitor.node
        self._disturb = node.create_publisher(DisturbanceMsg, "/sim/disturb", RELIABLE)
        self._blackout = node.create_publisher(Float64, "/sim/camera_blackout", RELIABLE)
        self._fault = node.create_publisher(SimFaultMsg, "/sim/fault", RELIABLE)
        self._float = Float64
        self.stray_refused: bool | None = None  # misfire: did the gripper refuse and name us?
        if name == "misfire":  # only then: a publisher there is named for any refusal
            self._gripper = node.create_publisher(Float64, "/gripper/command", RELIABLE)
            node.create_subscription(GripperStatusMsg, "/gripper/status",
                                     self._on_gripper_status, RELIABLE)
        if name == "knuckle_misfire":
            self._knuckle = node.create_publisher(Float64MultiArray,
                                                  drivers.GRIPPER_COMMAND_TOPIC, RELIABLE)

    def _on_gripper_status(self, msg: GripperStatusMsg) -> None:
        if self.stray_refused is False and STRAY_NAME in msg.refused_commanders:
            self.stray_refused = True
            self.note += (f"; refused by the gripper node ({msg.lease_holder} held it), "
                          f"{STRAY_NAME} named")

    def __call__(self, monitor: RunMonitor, wall: float) -> None:
        if self._restart_at is not None and wall >= self._restart_at:
            node = self.name.split("_")[0]
            self.cell.start(node, again=True)
            self._restart_at = None
            self.note += f"; {node} restarted at {wall:.0f} s"
        if self.done:
            return
        status = monitor.feedback  # the goal's progress
        if status is None:
            return
        running, observing = status.state == "running", status.state == "observing"
        k = status.action_index
        name = self.name
        if self.chaos is not None:
            if self.chaos.due(status.state, k, wall):
                self.cell.crash(self.chaos.node)
                self._fired(f"{self.chaos.node} SIGKILLed while {status.state} (action {k}), "
                            "left to the cell's respawn")
        elif name.endswith("_restart") and running and k >= 2:
            node = name.split("_")[0]
            self.cell.kill(node)
            self._restart_at = wall + 2.0
            self._fired(f"{node} killed during action {k}")
        elif name == "nudge" and observing and k >= 2 and monitor.plans:
            self._nudge(monitor.plans[0].actions[0].block, 0.008, 0.006, f"after action {k}")
        elif name == "knock" and running and k >= 3 and monitor.plans:
            self._nudge(monitor.plans[0].actions[0].block, 0.010, -0.008, f"during action {k}")
        elif name == "camera_drop" and observing and k >= 1:
            self._blackout.publish(self._float(data=8.0))
            self._fired(f"camera frames dropped for 8 s after action {k}")
        elif name in ("grasp_miss", "slip", "drop") and observing and k >= 1:
            self._sim_fault(SimFaultRecord(name.removeprefix("grasp_")),
                            f"{name} armed after action {k}")
        elif name == "misfire" and running and k >= 2:
            self._gripper.publish(self._float(data=0.02))
            self._fired(f"a stray close to 20 mm during action {k}")
            self.stray_refused = False  # until the gripper's status names us
        elif name == "knuckle_misfire" and running and k >= 2:
            self._knuckle.publish(Float64MultiArray(data=[g85.gap_to_knuckle(0.02)]))
            self._fired(f"a stray close to 20 mm straight to {drivers.GRIPPER_COMMAND_TOPIC} "
                        f"during action {k}")
        elif name == "remove" and observing and k >= 2 and monitor.plans:
            self.removed = monitor.plans[-1].actions[-1].block
            self._sim_fault(SimFaultRecord("remove_block", self.removed),
                            f"block {self.removed} taken away after action {k}")
        elif name == "add" and observing and k >= 2:
            x, y = free_spot_in(self.scene)
            self._sim_fault(SimFaultRecord("add_block", ADDED_BLOCK, (x, y, 0.3)),
                            f"block {ADDED_BLOCK} put down at ({x:.3f}, {y:.3f}) after "
                            f"action {k}")
        elif name == "camera_noise":
            self._sim_fault(SimFaultRecord("camera_noise", value=20.0),
                            "camera read noise 20 grey levels from the start")

    def _fired(self, note: str) -> None:
        self.done = True
        self.note = note

    def _nudge(self, block: int, dx: float, dy: float, when: str) -> None:
        self._disturb.publish(disturbance_to_msg(Disturbance(block, dx, dy)))
        self._fired(f"block {block} nudged by ({dx * 1e3:.0f}, {dy * 1e3:.0f}) mm {when}")

    def _sim_fault(self, fault: SimFaultRecord, note: str) -> None:
        self._fault.publish(sim_fault_to_msg(fault))
        self._fired(note)


@dataclass
class ChaosDraw:
    """Which node the chaos fault kills, and when: once the goal's progress reaches action
    ``action`` in ``state``, ``delay_s`` of wall time later."""

    node: str
    action: int
    state: str
    delay_s: float
    _reached: float | None = None

    @classmethod
    def of(cls, seed: int, n_blocks: int) -> ChaosDraw:
        rng = np.random.default_rng(10_000 + seed)
        return cls(str(rng.choice(CHAOS_NODES)), int(rng.integers(1, max(2, n_blocks))),
                   str(rng.choice(["running", "observing"])), float(rng.uniform(0.0, 2.0)))

    def due(self, state: str, action: int, wall: float) -> bool:
        if self._reached is None and action >= self.action and state == self.state:
            self._reached = wall
        return self._reached is not None and wall - self._reached >= self.delay_s


def free_spot_in(scene: Scene) -> tuple[float, float]:
    """The workspace point farthest from every start block and goal slot (where a person
    puts a block down out of the way)."""
    ws, s = scene.workspace, scene.block_size
    xs = np.linspace(ws.x_min + s, ws.x_max - s, 21)
    ys = np.linspace(ws.y_min + s, ws.y_max - s, 21)
    gx, gy = (a.ravel() for a in np.meshgrid(xs, ys))
    taken = [(b.x, b.y) for b in scene.blocks]
    if scene.goal is not None:
        taken += [(p.x, p.y) for p in scene.goal.slot_poses(s)]
    t = np.array(taken)
    clearance = np.min(np.hypot(gx[:, None] - t[None, :, 0], gy[:, None] - t[None, :, 1]), axis=1)
    k = int(np.argmax(clearance))
    return float(gx[k]), float(gy[k])


def calibration_off_args() -> tuple[str, ...]:
    """ROS arguments that give the detector a camera pose CALIBRATION_SHIFT_M and
    CALIBRATION_TILT_DEG (about the camera's own x axis) off config/camera_calibration.yaml."""
    pose = load_camera_pose(config_path("camera_calibration.yaml"))
    a = math.radians(CALIBRATION_TILT_DEG)
    tilt = [[1.0, 0.0, 0.0], [0.0, math.cos(a), -math.sin(a)], [0.0, math.sin(a), math.cos(a)]]
    rotation = quaternion_to_matrix(pose.orientation_xyzw) @ np.array(tilt)
    quat = matrix_to_quaternion(rotation)
    position = [p + d for p, d in zip(pose.position, CALIBRATION_SHIFT_M, strict=True)]
    return ("-p", f"detector:camera_pose.position:={[round(v, 6) for v in position]}",
            "-p", f"detector:camera_pose.orientation_xyzw:={[round(float(v), 8) for v in quat]}")


def run_scene(blocks: int, density: float, seed: int, fault: str, timeout: float,
              workdir: Path) -> dict[str, Any]:
    scene = random_sim_scene(blocks, density, seed)
    layout = check_goal(scene)
    scene_file = save_scene(scene, workdir / f"scene_{blocks}_{seed}.yaml")
    private_domain()
    context = Context()
    rclpy.init(context=context)
    stop_cells_on_sigterm()
    try:
        with open(workdir / f"cell_{blocks}_{seed}_{fault}.log", "w") as log:
            extra = calibration_off_args() if fault == "calibration" else ()
            cell = CellRun(scene_file, log, extra_ros_args=extra)
            monitor = RunMonitor(context)
            injector = FaultInjector(fault, cell, monitor, scene, seed)
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
        for k, plan in enumerate(monitor.plans):
            save_plan(plan, workdir / f"plan_{blocks}_{seed}_{fault}_{k}.json")
        metrics.update(seed=seed, fault=fault, removed=injector.removed,
                       stray_refused=injector.stray_refused)
        metrics["success"] = is_success(metrics)
        # written before the client's DDS entities go (see run_scene_isolated)
        metrics_file(workdir, blocks, seed, fault).write_text(
            json.dumps(metrics, indent=2, default=str))
        monitor.node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
    return metrics


def run(opts, scene_runner: Callable[..., dict[str, Any]] | None = None
        ) -> list[dict[str, Any]]:
    scene_runner = scene_runner or functools.partial(run_scene_isolated, target=run_scene)
    faults = [f for f in FAULTS if f != "chaos"] if "all" in opts.fault else opts.fault
    if opts.chaos:
        faults = [*(f for f in faults if f != "none"), "chaos"]
    scenes = 2 if opts.quick else (opts.seeds or opts.scenes)
    workdir = opts.keep or Path(tempfile.mkdtemp(prefix="densepack-cell-bench-"))
    workdir.mkdir(parents=True, exist_ok=True)
    private_ros_home(workdir)
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
