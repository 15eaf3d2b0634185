"""The ``main()`` of every densepack node: ros2-run-style arguments, clean shutdown, --help.

Each node module ends with::

    SPEC = NodeSpec("planner", PlannerNode, "Plans ...", configs=(("", PlannerConfig),))

    def main(args=None):
        return run_node(SPEC, args)

``run_node`` strips ``--ros-args ...`` (handed to rclpy untouched), answers ``--help`` with
the node's parameter table, spins the node on a multi-threaded executor and shuts down with
the Jazzy idiom. It returns (and the console script exits with) 0 on Ctrl-C / SIGTERM and
1 when the node failed to start or died, so ``densepack-cell`` can tell a crash from a stop.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import signal
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.utilities import remove_ros_args

from nodes.common.executors import PatientExecutor, single_threaded, spin
from nodes.common.params import describe_config
from nodes.common.transports import size_for_frames, use_profile


@dataclass(frozen=True)
class NodeSpec:
    """What a node is: its default name, how to build it, and its parameter groups."""

    name: str
    factory: Callable[..., Any]
    description: str
    configs: tuple[tuple[str, type], ...] = ()
    topics: str = ""
    threads: int = 4
    #: publishes camera frames: its transports are sized for them (``nodes.common.transports``)
    publishes_frames: bool = False

    def help_text(self) -> str:
        lines = [self.description.strip(), ""]
        if self.topics:
            lines += [self.topics.strip(), ""]
        rows = [row for prefix, cls in self.configs for row in describe_config(cls, prefix)]
        if rows:
            lines.append("parameters (set with --ros-args -p NAME:=VALUE or --params-file FILE):")
            width = max(len(r["name"]) for r in rows)
            for r in rows:
                unit = f" [{r['unit']}]" if r["unit"] else ""
                lines.append(f"  {r['name']:<{width}}  {r['default']}{unit}  {r['description']}")
        return "\n".join(lines)


def split_ros_args(argv: Sequence[str]) -> tuple[list[str], list[str]]:
    """Separate a command line into (user args, full argv for rclpy)."""

    return list(remove_ros_args(list(argv)))[1:], list(argv)


#: Set by the launchers (densepack-cell, densepack-run, the cell benchmark) on the nodes they
#: start: the launcher's pid.
LAUNCHER_PID_ENV = "DENSEPACK_LAUNCHER_PID"


def die_with_launcher() -> None:
    """Stop (SIGTERM, a clean shutdown) when the launcher dies, even by SIGKILL: launched nodes
    run in their own session, so nothing else would stop them and they would live on as
    orphans, still talking on the domain."""
    launcher = os.environ.get(LAUNCHER_PID_ENV)
    if not launcher or not sys.platform.startswith("linux"):
        return

    pr_set_pdeathsig = 1
    ctypes.CDLL(None, use_errno=True).prctl(pr_set_pdeathsig, signal.SIGTERM)
    if os.getppid() != int(launcher):  # it died before the request took effect
        raise SystemExit(0)


def run_node(spec: NodeSpec, args: Sequence[str] | None = None) -> int:
    """Run ``spec``'s node until shutdown; returns the process exit code."""

    argv = list(sys.argv if args is None else [f"densepack-{spec.name}", *args])
    user_args, ros_argv = split_ros_args(argv)
    parser = argparse.ArgumentParser(
        prog=f"densepack-{spec.name}",
        description=spec.help_text(),
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="ROS arguments go after --ros-args, e.g. --ros-args --params-file "
        f"config/{spec.name}.yaml -p use_sim_time:=true -r __node:=my_{spec.name}",
    )
    parser.parse_args(user_args)

    die_with_launcher()
    if spec.publishes_frames:
        size_for_frames(os.environ)
    use_profile(os.environ)
    rclpy.init(args=ros_argv)  # installs SIGINT/SIGTERM handlers that shut the context down
    node = executor = None
    code = 0
    try:
        node = spec.factory()
        # rclpy's MultiThreadedExecutor polls its futures in Python on every wake-up: for a
        # node whose callbacks are all short, one thread costs a fraction of the CPU.
        executor = (single_threaded() if spec.threads == 1
                    else PatientExecutor(num_threads=spec.threads))
        executor.add_node(node)
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as err:  # a node that dies reports why and exits non-zero
        code = _failed(spec.name, err)
    finally:
        if executor is not None:
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code


def _failed(name: str, err: Exception) -> int:
    """The exit code for ``err`` escaping the spin: 0 when the context was shut down under a
    callback (a signal arrived while it ran, and its next call into rcl met the shut context:
    the stop asked for, not a crash), else 1, reported as fatal."""
    if not rclpy.ok():
        print(f"[{name}] stopped: a callback was cut short by the shutdown "
              f"({type(err).__name__}: {err})", file=sys.stderr, flush=True)
        return 0
    print(f"[{name}] fatal: {type(err).__name__}: {err}", file=sys.stderr, flush=True)
    return 1
