"""``densepack-cell``: our launch file.

Starts the node set of a cell file (``nodes.cell.launch``): each node as its own process by
default, or all in this process on one executor with ``--in-process``. Ctrl-C or SIGTERM shuts
everything down cleanly; the launcher exits non-zero when a node dies. ``--profile real``
starts densepack's nodes against the real drivers; ``--list --json`` prints the commands (what
the ROS launch file in ``ros_ws`` starts for users of an apt ROS install).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from nodes.cell.launch import PROFILES, load_cell, run_in_process, run_processes
from nodes.common.paths import config_path
from nodes.common.runner import split_ros_args


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="densepack-cell",
        description="Start the densepack node set (our launch file). ROS arguments after "
        "--ros-args are passed to every node.",
    )
    parser.add_argument("cell", nargs="?", default=None,
                        help="cell file under config/ (default: the profile's)")
    parser.add_argument("--profile", choices=sorted(PROFILES), default="sim",
                        help="sim: the simulated cell (config/cell.yaml); real: densepack's "
                        "nodes against the real drivers (config/real/cell.yaml)")
    parser.add_argument("--in-process", action="store_true", help="one process, one executor")
    parser.add_argument("--nodes", default="", help="comma-separated subset to start")
    parser.add_argument("--without", default="",
                        help="comma-separated nodes to leave out (e.g. goal, to send goals "
                        "on the /rearrange action instead)")
    parser.add_argument("--scene", help="scene file for the sim and the goal publisher")
    parser.add_argument("--list", action="store_true", help="print the node set and exit")
    parser.add_argument("--json", action="store_true",
                        help="with --list: the commands as JSON ({name: argv}), for a launch file")
    return parser


def main(args: Sequence[str] | None = None) -> int:
    argv = list(sys.argv if args is None else ["densepack-cell", *args])
    user_args, _ = split_ros_args(argv)
    extra_ros = argv[argv.index("--ros-args"):] if "--ros-args" in argv else []
    opts = build_parser().parse_args(user_args)
    extra_params = {"scene_file": str(Path(opts.scene).resolve())} if opts.scene else {}
    only = [n for n in opts.nodes.split(",") if n]
    without = [n for n in opts.without.split(",") if n]
    cell_file = opts.cell or PROFILES[opts.profile]
    launches, missing = load_cell(config_path(cell_file), only, extra_params, without)
    if missing:
        print(f"[cell] not implemented yet, not started: {', '.join(missing)}", flush=True)
    if opts.list and opts.json:
        print(json.dumps({launch.name: launch.command(extra_ros) for launch in launches},
                         indent=2))
        return 0
    if opts.list or not launches:
        for launch in launches:
            print(f"{launch.name}: {launch.module} {' '.join(launch.ros_args(extra_ros))}")
        return 0 if launches or opts.list else 1
    if opts.in_process:
        return run_in_process(launches, extra_ros)
    return run_processes(launches, extra_ros)


if __name__ == "__main__":
    sys.exit(main())
