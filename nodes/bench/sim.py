"""Sim speed: real-time factor with the arm moving, and overhead-camera render time.

``densepack-bench sim [--quick] [--seeds K] [--blocks 9,25] [--sim-seconds S]`` builds a
``SimWorld`` per (n_blocks, seed) on a random scene (``random_sim_scene``, density
``--density``) and drives it through the arm node's logic in process (``SimArm``): TCP
setpoints at ``--setpoint-rate`` along a figure-of-eight over the workspace (gripper pointing
down, yaw turning, the gripper opening and closing once a second), timing physics + the
trajectory controller + the arm's IK and playback + the event monitor as the cell runs them
(ROS publishing excluded). Then it renders ``--renders`` camera frames. One row per n_blocks.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from typing import Any

import numpy as np

from nodes.bench.sim_arm import SimArm
from nodes.common.transforms import tool_down_quaternion
from nodes.sim import robot_model as rm
from nodes.sim.config import CameraConfig, SimConfig
from nodes.sim.layout import random_sim_scene
from nodes.sim.world import SimWorld

COLUMNS = ["n_blocks", "seeds", "physics_rate_hz", "sim_s", "wall_s", "real_time_factor",
           "real_time_factor_min", "render_ms_median", "render_ms_max", "setpoints_rejected",
           "unintended_contacts"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--blocks", default="9,25", help="comma-separated block counts")
    parser.add_argument("--density", type=float, default=0.25, help="scene density")
    parser.add_argument("--sim-seconds", type=float, default=None,
                        help="simulated seconds per run (default 30, --quick 8)")
    parser.add_argument("--setpoint-rate", type=float, default=125.0,
                        help="setpoint stream rate (Hz, like a UR RTDE stream)")
    parser.add_argument("--renders", type=int, default=None,
                        help="camera frames to time per run (default 10, --quick 3)")
    parser.add_argument("--physics-rate", type=float, default=240.0, help="physics rate (Hz)")


def tour_setpoint(t: float, scene) -> tuple[np.ndarray, np.ndarray]:
    """A figure-of-eight over the workspace at about 0.25 m/s, 0.10-0.20 m above the table."""
    cx, cy = scene.workspace.center
    ax = 0.4 * (scene.workspace.x_max - scene.workspace.x_min) / 2
    ay = 0.8 * (scene.workspace.y_max - scene.workspace.y_min) / 2
    w = 0.25 / math.hypot(ax, 2 * ay)
    position = np.array([cx + ax * math.sin(2 * w * t), cy + ay * math.sin(w * t),
                         0.15 + 0.05 * math.sin(3 * w * t)])
    return position, tool_down_quaternion(0.5 * math.sin(0.7 * t))


def run_one(n_blocks: int, seed: int, opts: argparse.Namespace) -> dict[str, Any]:
    scene = random_sim_scene(n_blocks, opts.density, seed)
    config = SimConfig(physics_rate_hz=opts.physics_rate)
    world = SimArm(SimWorld(config, CameraConfig().model(), scene))
    try:
        every = max(1, round(config.physics_rate_hz / opts.setpoint_rate))
        steps = round(opts.sim_seconds / config.dt)
        start = time.perf_counter()
        for k in range(steps):
            if k % every == 0:
                position, quat = tour_setpoint(world.time_s, scene)
                world.set_setpoint(position, quat)
            if k % round(config.physics_rate_hz) == 0:
                world.set_gripper(rm.GRIPPER_STROKE if (k // 240) % 2 else 0.06)
            world.step()
        wall = time.perf_counter() - start
        renders = []
        for _ in range(opts.renders):
            t0 = time.perf_counter()
            world.render()
            renders.append(time.perf_counter() - t0)
        return {"sim_s": world.time_s, "wall_s": wall, "rtf": world.time_s / wall,
                "render_s": renders, "rejected": world.core.controller.rejected,
                "contacts": world.monitor.unintended_contacts}
    finally:
        world.close()


def run(opts: argparse.Namespace) -> list[dict[str, Any]]:
    opts.sim_seconds = opts.sim_seconds or (8.0 if opts.quick else 30.0)
    opts.renders = opts.renders if opts.renders is not None else (3 if opts.quick else 10)
    seeds = opts.seeds or 1
    rows = []
    for n_blocks in (int(v) for v in opts.blocks.split(",")):
        runs = [run_one(n_blocks, seed, opts) for seed in range(seeds)]
        renders = [r for run_ in runs for r in run_["render_s"]]
        sim_s = sum(r["sim_s"] for r in runs)
        wall_s = sum(r["wall_s"] for r in runs)
        rows.append({
            "n_blocks": n_blocks,
            "seeds": seeds,
            "density": opts.density,
            "physics_rate_hz": opts.physics_rate,
            "setpoint_rate_hz": opts.setpoint_rate,
            "sim_s": sim_s,
            "wall_s": wall_s,
            "real_time_factor": sim_s / wall_s,
            "real_time_factor_min": min(r["rtf"] for r in runs),
            "render_ms_median": 1e3 * statistics.median(renders) if renders else float("nan"),
            "render_ms_max": 1e3 * max(renders) if renders else float("nan"),
            "setpoints_rejected": sum(r["rejected"] for r in runs),
            "unintended_contacts": sum(r["contacts"] for r in runs),
        })
    return rows
