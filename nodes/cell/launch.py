"""The cell file, read, and its node set started: each node as its own process
(``python -m <module> --ros-args --params-file ... -r from:=to``, extra ROS arguments passed
through), or all in this process on one MultiThreadedExecutor. Every log line is prefixed with
its node's name; a node that dies stops the rest. Nodes whose code is not in this installation
are reported as missing and the rest start anyway.

Profiles: ``sim`` (``config/cell.yaml``) is the simulated cell; ``real``
(``config/real/cell.yaml``) starts densepack's nodes and not the sim, against ur_robot_driver,
the Robotiq driver and a camera driver, with the remappings and parameters of that file.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import rclpy
import yaml
from rclpy.executors import ExternalShutdownException
from rclpy.signals import SignalHandlerOptions

from nodes.cell.respawn import Respawn, RespawnBook, respawn_env
from nodes.cell.shared_memory import clean_dead_shared_memory
from nodes.common.executors import PatientExecutor
from nodes.common.paths import config_path
from nodes.common.runner import LAUNCHER_PID_ENV

#: Node name -> module that defines ``SPEC`` (a NodeSpec) and ``main``.
NODE_MODULES = {
    "sim": "nodes.sim.node",
    "detector": "nodes.detector.node",
    "planner": "nodes.planner.node",
    "executor": "nodes.executor.node",
    "arm": "nodes.arm.node",
    "gripper": "nodes.gripper.node",
    "goal": "nodes.goal.node",
}

SHUTDOWN_GRACE_S = 10.0
#: Profile name -> its cell file (under config/).
PROFILES = {"sim": "cell.yaml", "real": "real/cell.yaml"}


@dataclass(frozen=True)
class NodeLaunch:
    name: str
    module: str
    params_files: tuple[Path, ...] = ()
    parameters: dict[str, Any] = field(default_factory=dict)
    remaps: dict[str, str] = field(default_factory=dict)
    respawn: Respawn = field(default_factory=Respawn)

    def command(self, extra: Sequence[str] = ()) -> list[str]:
        """The node's process: ``python -m <module> --ros-args ...``."""
        return [sys.executable, "-m", self.module, *self.ros_args(extra)]

    def ros_args(self, extra: Sequence[str] = ()) -> list[str]:
        args = ["--ros-args"]
        for path in self.params_files:
            args += ["--params-file", str(path)]
        for key, value in self.parameters.items():
            args += ["-p", f"{key}:={_ros_value(value)}"]
        for source, target in self.remaps.items():
            args += ["-r", f"{source}:={target}"]
        extra = list(extra)
        if extra and extra[0] == "--ros-args":
            extra = extra[1:]
        return args + extra


def _ros_value(value: Any) -> str:
    return yaml.safe_dump(value, default_flow_style=True).strip().removesuffix("...").strip()


def load_cell(path: Path, only: Sequence[str] = (), extra_params: dict[str, Any] | None = None,
              without: Sequence[str] = (), node_params: dict[str, dict[str, Any]] | None = None):
    """Read a cell file; returns (launches to start, names that are not implemented).

    ``only``: start just these nodes; ``without``: leave these out. Parameter precedence,
    lowest first: the file's shared ``parameters``, a node's own ``parameters``, then
    ``extra_params`` (the command line's, e.g. ``--scene``), then ``node_params[name]``.
    """
    data = yaml.safe_load(path.read_text()) or {}
    nodes = data.get("nodes") or {}
    shared = dict(data.get("parameters") or {})
    unknown = [n for n in (*nodes, *only, *without) if n not in NODE_MODULES]
    if unknown:
        raise SystemExit(f"densepack-cell: unknown node(s) {unknown}; known: {list(NODE_MODULES)}")
    launches, missing = [], []
    for name, spec in nodes.items():
        if (only and name not in only) or name in without:
            continue
        module = NODE_MODULES[name]
        if importlib.util.find_spec(module.rsplit(".", 1)[0]) is None or (
            importlib.util.find_spec(module) is None
        ):
            missing.append(name)
            continue
        spec = spec or {}
        files = tuple(config_path(p) for p in spec.get("params", []))
        params = dict(shared)
        params.update(spec.get("parameters") or {})
        params.update(extra_params or {})
        params.update((node_params or {}).get(name, {}))
        remaps = {str(k): str(v) for k, v in (spec.get("remap") or {}).items()}
        try:
            respawn = Respawn.from_spec(name, spec)
        except ValueError as err:
            raise SystemExit(f"densepack-cell: {path}: {err}") from None
        launches.append(NodeLaunch(name, module, files, params, remaps, respawn))
    return launches, missing


# --- one process per node ---------------------------------------------------------------------
def _pump(prefix: str, stream: Any, lock: threading.Lock) -> None:
    for line in iter(stream.readline, ""):
        with lock:
            sys.stdout.write(f"[{prefix}] {line}")
            sys.stdout.flush()
    stream.close()


def run_processes(launches: Sequence[NodeLaunch], extra_ros: Sequence[str]) -> int:
    """Each node its own process until Ctrl-C or SIGTERM; a node that ends is started again
    if its cell file says ``respawn``, else (or once its respawns are used up) a node that
    died stops the cell (exit code 1)."""
    env = dict(os.environ, PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0",
               **{LAUNCHER_PID_ENV: str(os.getpid())})
    lock = threading.Lock()
    by_name = {launch.name: launch for launch in launches}
    procs: dict[str, subprocess.Popen] = {}
    pumps: list[threading.Thread] = []
    book = RespawnBook({launch.name: launch.respawn for launch in launches})
    stop = threading.Event()

    def request_stop(*_: Any) -> None:
        stop.set()

    def start(launch: NodeLaunch, again: bool = False) -> None:
        proc = subprocess.Popen(
            launch.command(extra_ros), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
            text=True, env=respawn_env(env) if again else env, start_new_session=True,
        )
        procs[launch.name] = proc
        pump = threading.Thread(target=_pump, args=(launch.name, proc.stdout, lock), daemon=True)
        pump.start()
        pumps.append(pump)
        print(f"[cell] started {launch.name} (pid {proc.pid})", flush=True)

    signal.signal(signal.SIGINT, request_stop)
    signal.signal(signal.SIGTERM, request_stop)
    for launch in launches:
        start(launch)
    while not stop.is_set():
        now = time.monotonic()
        for name, proc in list(procs.items()):
            if proc.poll() is not None:
                del procs[name]
                print(f"[cell] {book.on_exit(name, proc.returncode, now)}", flush=True)
                print(f"[cell] {clean_dead_shared_memory()}", flush=True)
        for name in book.due(now):
            start(by_name[name], again=True)
        if book.fatal is not None or not (procs or book.due_at):
            break
        stop.wait(0.2)
    _terminate(procs)
    for pump in pumps:  # forward every line the nodes wrote before they exited
        pump.join(timeout=5.0)
    print(f"[cell] {clean_dead_shared_memory()}", flush=True)  # of any node that died
    print("[cell] all nodes stopped", flush=True)
    return 1 if book.fatal is not None else 0


def _terminate(procs: dict[str, subprocess.Popen]) -> None:
    for proc in procs.values():
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
    deadline = time.monotonic() + SHUTDOWN_GRACE_S
    for name, proc in procs.items():
        try:
            proc.wait(timeout=max(0.1, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            print(f"[cell] {name} did not stop in {SHUTDOWN_GRACE_S} s; killing it", flush=True)
            proc.kill()
            proc.wait()


# --- all nodes in this process ----------------------------------------------------------------
def run_in_process(launches: Sequence[NodeLaunch], extra_ros: Sequence[str]) -> int:
    os.environ.setdefault("RCUTILS_CONSOLE_OUTPUT_FORMAT", "[{name}] [{severity}] {message}")
    # Our own handlers and a polled spin: rclpy's handler, on a signal that lands just as the
    # executor starts waiting, sometimes did not wake it (a hang until SIGKILL).
    rclpy.init(args=["densepack-cell"], signal_handler_options=SignalHandlerOptions.NO)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    executor = PatientExecutor(num_threads=max(4, 2 * len(launches)))
    built = []
    code = 0
    try:
        for launch in launches:
            spec = importlib.import_module(launch.module).SPEC
            node = spec.factory(cli_args=launch.ros_args(extra_ros))
            built.append(node)
            executor.add_node(node)
            print(f"[cell] started {launch.name} in-process", flush=True)
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.2)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception as err:
        print(f"[cell] a node died: {type(err).__name__}: {err}", flush=True)
        code = 1
    finally:
        executor.shutdown(timeout_sec=SHUTDOWN_GRACE_S)  # no callback runs on a node destroyed
        for node in built:
            node.destroy_node()
        rclpy.try_shutdown()
        print("[cell] all nodes stopped", flush=True)
    return code
