"""Placement benchmark: where the arm sets blocks down, before any correction.

``densepack-bench placement --scenes 10`` plans seeded random scenes (the cell benchmark's)
and plays every action of each plan on the simulated arm with the executor's own step
scripts, without ROS, camera or replanning: each action starts from the block's true pose,
so what is measured is the grip, the carry and the release alone. For every pick-and-place
it takes the block's true pose after the fingers let go and rose, against the action's goal
(yaw modulo the half turn the executor may add: ``primitives.GRASP_SYMMETRY``), and counts
release stalls (fingers that stop opening; the executor's "not released" fault). The sim is
as shipped (``config/sim.yaml``: block-to-block friction and mass spread, gripper latency),
seeded per scene.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
from dataclasses import dataclass
from typing import Any

from msgs_py import PickPlace, Pose2D
from msgs_py.cell import GripperGeometry
from nodes.bench.sim_arm import SimArm
from nodes.bench.sim_play import play
from nodes.executor.config import ExecutorConfig
from nodes.executor.primitives import GRASP_SYMMETRY, action_steps
from nodes.executor.steps import Grip
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import plan_goal
from nodes.sim.config import load_sim_configs
from nodes.sim.layout import random_sim_scene
from nodes.sim.world import SimWorld

COLUMNS = ("blocks", "scenes", "placements", "stalls", "yaw_err_median_deg", "yaw_err_p90_deg",
           "yaw_err_max_deg", "pos_err_median_mm", "pos_err_max_mm", "scenes_failed")
#: Sim seconds an action may take before the benchmark calls it stuck.
ACTION_LIMIT_S = 30.0


def add_arguments(parser) -> None:
    parser.add_argument("--scenes", type=int, default=10, help="seeded scenes")
    parser.add_argument("--blocks", type=int, default=9, help="blocks per scene")
    parser.add_argument("--density", type=float, default=0.2,
                        help="block area / workspace area (the cell benchmark's)")


@dataclass
class Placed:
    """One pick-and-place: the block's error after it (m, rad) and the stalls on the way."""

    position_error: float
    yaw_error: float
    stalls: int


def play_action(world, steps, cfg: ExecutorConfig) -> tuple[int, str]:
    """Stream ``steps`` as the executor does; a stalled opening is counted and let go of as
    the executor does (grip again, open again). Returns (stalls, error)."""
    stalls = 0

    def grip_again(world, runner) -> None:
        nonlocal stalls
        stalls += 1
        runner.retry_current([Grip(cfg.grip_command, cfg.gripper_settle_s, "grip again")])

    _, error = play(world, steps, cfg, on_stall=grip_again, limit_s=ACTION_LIMIT_S)
    return stalls, error


def run_scene(blocks: int, density: float, seed: int) -> tuple[list[Placed], str]:
    """Plan scene ``seed`` and play it; (the placements, why it stopped early or "")."""
    scene = random_sim_scene(blocks, density, seed)
    outcome = plan_goal(scene, PlannerConfig())
    if outcome.plan is None:
        return [], f"no plan: {outcome.error}"
    sim, camera, _ = load_sim_configs()
    world = SimArm(SimWorld(dataclasses.replace(sim, seed=seed), camera.model(), scene))
    cfg, geo = ExecutorConfig(), GripperGeometry.from_params(outcome.plan.params)
    placed: list[Placed] = []
    try:
        world.step(24)
        for action in outcome.plan.actions:
            start = next(b.pose for b in world.block_poses() if b.id == action.block)
            stalls, error = play_action(world, action_steps(action, start, geo, cfg), cfg)
            if error:
                return placed, f"action on block {action.block}: {error}"
            if isinstance(action, PickPlace):
                end = next(b.pose for b in world.block_poses() if b.id == action.block)
                placed.append(Placed(end.distance_to(action.to), yaw_error(end, action.to),
                                     stalls))
    finally:
        world.close()
    return placed, ""


def yaw_error(end: Pose2D, goal: Pose2D) -> float:
    return abs(math.remainder(end.theta - goal.theta, GRASP_SYMMETRY))


def run(opts) -> list[dict[str, Any]]:
    scenes = 2 if opts.quick else opts.scenes
    placed: list[Placed] = []
    failed: list[str] = []
    for seed in range(scenes):
        got, why = run_scene(opts.blocks, opts.density, seed)
        placed += got
        print(f"  seed {seed}: {len(got)} placements, "
              f"worst yaw {max((math.degrees(p.yaw_error) for p in got), default=0):.2f} deg"
              + (f"; stopped: {why}" if why else ""), flush=True)
        if why:
            failed.append(f"seed {seed}: {why}")
    yaws = sorted(math.degrees(p.yaw_error) for p in placed) or [math.nan]
    mm = [p.position_error * 1e3 for p in placed] or [math.nan]
    return [{
        "blocks": opts.blocks, "scenes": scenes, "placements": len(placed),
        "stalls": sum(p.stalls for p in placed),
        "yaw_err_median_deg": statistics.median(yaws),
        "yaw_err_p90_deg": yaws[min(len(yaws) - 1, int(0.9 * len(yaws)))],
        "yaw_err_max_deg": max(yaws), "pos_err_median_mm": statistics.median(mm),
        "pos_err_max_mm": max(mm), "scenes_failed": "; ".join(failed) or "none",
        "yaw_errors_deg": yaws,
    }]
