"""The whole cell in one process, configured exactly as `densepack-cell` configures it
(config/cell.yaml: each node from its `config/` parameter files, the executor on simulated
time, the sim in lockstep with it); `action=True` configures it as `densepack-run` does (no
goal node: goals come on /rearrange)."""

from __future__ import annotations

import importlib
import math
from pathlib import Path

from densepack_interfaces.msg import BlockPoseArray

from msgs_py import Scene
from msgs_py import ros as msg_codecs
from nodes.cell.launch import load_cell
from nodes.cell.processes import ACTION_CELL_PARAMS, ACTION_CELL_WITHOUT
from nodes.common.paths import config_path
from nodes.common.qos import RELIABLE
from nodes.executor.verify import goal_errors


def start_cell(ros, scene_file: Path | str, action: bool = False) -> None:
    """Sim (frames on demand), detector, planner, executor and (unless ``action``) the goal
    publisher on ``ros``."""
    launches, missing = load_cell(config_path("cell.yaml"), (),
                                  {"scene_file": str(scene_file)},
                                  ACTION_CELL_WITHOUT if action else (),
                                  ACTION_CELL_PARAMS if action else None)
    assert not missing, missing
    for launch in launches:
        spec = importlib.import_module(launch.module).SPEC
        ros.add(spec.factory(context=ros.context, cli_args=launch.ros_args()))


def assert_every_block_at_its_goal(ros, scene: Scene, slots: int) -> None:
    """By the sim's ground truth, each of the ``slots`` goal slots holds its block within
    3 mm and 2 degrees."""
    truth = msg_codecs.block_set_from_msg(ros.wait_for_message("/sim/ground_truth", BlockPoseArray,
                                                       timeout=30, qos=RELIABLE))
    errors = goal_errors({b.id: b.pose for b in truth.blocks}, scene)
    assert len(errors) == slots
    for e in errors:
        assert e.position_error <= 0.003, e.describe()
        assert math.degrees(e.yaw_error) <= 2.0, e.describe()
