"""The closed loop without ROS: a ``SimWorld``, the ``ExecutorCore`` and the planner in one loop.

For debugging and fast checks of the physical loop (grasps, pushes, corrections) on many
scenes: perception is the simulator's ground truth (the detector measures 0.02 mm median
against it, see docs/benchmarks.md), the planner is called directly, time is simulated and
runs as fast as the CPU allows. The real cell (``densepack-run``) runs the same logic
through ROS nodes; this tool never replaces it in a benchmark figure.

``python -m nodes.tools.headless SCENE.yaml [--max-sim-s S]`` prints every executor step.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from msgs_py import BlockSet, Plan, Scene, load_scene
from nodes.common.paths import config_path
from nodes.common.transforms import tool_down_quaternion
from nodes.executor.config import ExecutorConfig
from nodes.executor.core import ExecutorCore, Phase
from nodes.executor.motion import ToolPose
from nodes.executor.verify import goal_errors
from nodes.planner.config import PlannerConfig
from nodes.planner.planner import plan_scene
from nodes.sim.config import CameraConfig, SimConfig
from nodes.sim.world import SimWorld


@dataclass
class HeadlessResult:
    state: str
    last_error: str
    sim_time_s: float
    actions_executed: int
    replans: int
    unintended_contacts: int
    blocks_lost: int
    final_errors: list = field(default_factory=list)
    log: list[str] = field(default_factory=list)


def _yaw(quat) -> float:
    x, y, z, w = quat
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def run_headless(
    scene: Scene,
    planner: PlannerConfig | None = None,
    executor: ExecutorConfig | None = None,
    sim: SimConfig | None = None,
    max_sim_s: float = 1500.0,
    on_log: Callable[[float, str], None] = lambda t, line: None,
) -> HeadlessResult:
    planner = planner or PlannerConfig()
    executor = executor or ExecutorConfig()
    world = SimWorld(sim or SimConfig(), CameraConfig().model(), scene)
    core = ExecutorCore(executor)
    log: list[str] = []
    try:
        ticks = max(1, round(1.0 / (executor.rate_hz * world.config.dt)))
        plan_count = 0

        def replan() -> Plan | None:
            nonlocal plan_count
            truth = scene.with_blocks(world.block_poses())
            outcome = plan_scene(truth, planner, f"headless-{plan_count}")
            plan_count += 1
            return outcome.plan if outcome.ok else None

        def note(line: str) -> None:
            log.append(f"{world.time_s:7.1f}  {line}")
            on_log(world.time_s, line)

        plan = replan()
        if plan is None:
            return HeadlessResult("failed", "no plan", 0.0, 0, 0, 0, 0, log=log)
        core.on_plan(plan)
        while world.time_s < max_sim_s and core.phase not in (Phase.DONE, Phase.FAILED):
            world.step(ticks)
            position, quat = world.tcp_pose()
            core.on_tcp(ToolPose(*(float(v) for v in position), _yaw(quat)), world.time_s)
            core.on_finger_gap(world.gap())
            out = core.tick(world.time_s)
            for line in out.log:
                note(line)
            if out.setpoint is not None:
                s = out.setpoint
                result = world.set_setpoint(np.array([s.x, s.y, s.z]), tool_down_quaternion(s.yaw))
                if not result.accepted:
                    note(f"setpoint rejected: {result.reason}")
            if out.gripper is not None:
                world.set_gripper(out.gripper)
            world.set_manipulated(core.status().block)
            if out.trigger_camera:
                core.on_detection(BlockSet(tuple(world.block_poses()), world.time_ns))
            if out.request_replan:
                new = replan()
                if new is not None:
                    core.on_plan(new)
        status = core.status()
        truth = {b.id: b.pose for b in world.block_poses()}
        summary = world.monitor.summary()
        return HeadlessResult(
            status.state, status.last_error, world.time_s,
            int(status.metrics.get("actions_executed", 0)), int(status.metrics.get("replans", 0)),
            summary["unintended_contacts"], summary["blocks_lost"],
            goal_errors(truth, scene), log)
    finally:
        world.close()


def main(args: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m nodes.tools.headless",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("scene", help="scene file")
    parser.add_argument("--max-sim-s", type=float, default=1500.0)
    opts = parser.parse_args(args)
    scene = load_scene(config_path(opts.scene))
    result = run_headless(scene, max_sim_s=opts.max_sim_s,
                          on_log=lambda t, line: print(f"{t:7.1f}  {line}", flush=True))
    worst = max((e.position_error for e in result.final_errors), default=float("nan"))
    worst_yaw = max((e.yaw_error for e in result.final_errors), default=float("nan"))
    print(f"{result.state}: {result.actions_executed} actions, {result.replans} replans, "
          f"sim {result.sim_time_s:.0f} s, worst {worst * 1e3:.2f} mm / "
          f"{math.degrees(worst_yaw):.2f} deg, contacts {result.unintended_contacts}, "
          f"lost {result.blocks_lost} {result.last_error}")
    return 0 if result.state == "done" else 1


if __name__ == "__main__":
    sys.exit(main())
