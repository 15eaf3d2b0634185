"""The whole cell in one process, configured as `densepack-cell` configures it: each node
from its `config/` parameter files, the timed nodes on simulated time."""

from __future__ import annotations

from pathlib import Path

from nodes.common.paths import config_path
from nodes.detector.node import DetectorNode
from nodes.executor.node import ExecutorNode
from nodes.planner.node import PlannerNode
from nodes.sim.node import SimNode
from nodes.tools.goal import GoalPublisher


def ros_args(*files: str, **params: object) -> list[str]:
    args = ["--ros-args"]
    for name in files:
        args += ["--params-file", str(config_path(name))]
    for key, value in params.items():
        args += ["-p", f"{key}:={value}"]
    return args


def start_cell(ros, scene_file: Path | str, real_time_factor: float = 4.0) -> None:
    """Sim (frames on demand), detector, planner, executor and goal publisher on `ros`."""
    ctx = ros.context
    ros.add(SimNode(context=ctx, cli_args=ros_args(
        "sim.yaml", scene_file=scene_file, real_time_factor=real_time_factor,
        **{"camera.rate_hz": 0.0})))
    ros.add(DetectorNode(context=ctx, cli_args=ros_args(
        "detector.yaml", "camera_calibration.yaml", use_sim_time="true")))
    ros.add(PlannerNode(context=ctx, cli_args=ros_args("planner.yaml")))
    ros.add(ExecutorNode(context=ctx, cli_args=ros_args("executor.yaml", use_sim_time="true")))
    ros.add(GoalPublisher(context=ctx, cli_args=ros_args(scene_file=scene_file)))
