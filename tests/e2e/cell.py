"""The whole cell in one process, configured exactly as `densepack-cell` configures it
(config/cell.yaml: each node from its `config/` parameter files, the executor on simulated
time, the sim in lockstep with it); `action=True` configures it as `densepack-run` does (no
goal node: goals come on /rearrange)."""

from __future__ import annotations

import importlib
from pathlib import Path

from nodes.common.paths import config_path
from nodes.tools.cell import load_cell
from nodes.tools.cell_run import ACTION_CELL_PARAMS, ACTION_CELL_WITHOUT


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
