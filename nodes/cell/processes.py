"""The cell's nodes as separate processes (so a fault can kill and restart one), and the
process-wide settings a run needs: a DDS domain of its own, SIGTERM as Ctrl-C."""

from __future__ import annotations

import os
import signal
import subprocess
import threading
import time
from pathlib import Path
from typing import IO, Any

from nodes.cell.launch import NodeLaunch, load_cell
from nodes.cell.respawn import RespawnBook, respawn_env
from nodes.cell.shared_memory import clean_dead_shared_memory
from nodes.common.harness import allocate_domain_id
from nodes.common.paths import config_path
from nodes.common.runner import LAUNCHER_PID_ENV

#: How the run tools change the cell file's node set: no goal node (the goal is a
#: ``/rearrange`` goal), and an executor that starts a plan only for a goal, so one restarted
#: mid-run waits for its client to send the goal again instead of resuming on its own.
ACTION_CELL_WITHOUT = ("goal",)
ACTION_CELL_PARAMS = {"executor": {"auto_start": False}}
#: A run's sim holds its clock until the run starts it (``nodes.cell.run.SimStarter``).
PAUSED_START = {"sim": {"start_paused": True}}


class CellRun:
    """The cell's nodes as separate processes, logging to one file (the goal node left out:
    the run sends its goal on the action); a node that ends unasked comes back as its cell
    file's ``respawn`` says (``supervise``)."""

    def __init__(self, scene_file: Path, log: IO[str], cell_file: str = "cell.yaml",
                 extra_ros_args: tuple[str, ...] = (), remote: tuple[str, ...] = (),
                 paused_start: bool = True) -> None:
        """``remote``: nodes of the cell file that run on another computer (not started);
        ``paused_start``: the sim holds its clock until ``/sim/start`` (a run calls it)."""
        launches, missing = load_cell(config_path(cell_file), (),
                                      {"scene_file": str(scene_file)},
                                      (*ACTION_CELL_WITHOUT, *remote),
                                      {**ACTION_CELL_PARAMS, **(PAUSED_START if paused_start
                                                                 else {})})
        if missing:
            raise RuntimeError(f"the cell is incomplete: {', '.join(missing)} not implemented")
        self.launches: dict[str, NodeLaunch] = {launch.name: launch for launch in launches}
        self.extra = list(extra_ros_args)
        self.log = log
        self.procs: dict[str, subprocess.Popen] = {}
        self.killed: set[str] = set()  # killed on purpose (fault injection), not crashed
        self.book = RespawnBook({name: launch.respawn for name, launch in self.launches.items()})
        self.pumps: list[threading.Thread] = []
        self.log_lock = threading.Lock()
        self.env = dict(os.environ, PYTHONUNBUFFERED="1", RCUTILS_COLORIZED_OUTPUT="0",
                        **{LAUNCHER_PID_ENV: str(os.getpid())})

    def start(self, name: str | None = None, again: bool = False) -> None:
        """Start every node, or ``name``; ``again``: after its process died (``respawn_env``).
        A node started again may follow a killed one: the dead one's shared memory goes first."""
        env = respawn_env(self.env) if again else self.env
        if name is not None:
            self._log(f"[cell] {clean_dead_shared_memory()}\n")
        for launch in [self.launches[name]] if name else self.launches.values():
            self.procs[launch.name] = self._spawn(launch.name, launch.command(self.extra), env)
            self.killed.discard(launch.name)

    def attach(self, name: str, cmd: list[str]) -> subprocess.Popen:
        """Start a helper process beside the cell (a recorder): same environment and log,
        but not one of the cell's nodes, so its end is no crash and ``stop`` leaves it be."""
        return self._spawn(name, cmd, self.env)

    def _spawn(self, name: str, cmd: list[str], env: dict[str, str]) -> subprocess.Popen:
        proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, env=env, start_new_session=True)
        pump = threading.Thread(target=self._pump, args=(name, proc), daemon=True)
        pump.start()
        self.pumps.append(pump)
        return proc

    def _pump(self, name: str, proc: subprocess.Popen) -> None:
        assert proc.stdout is not None
        for line in iter(proc.stdout.readline, ""):
            self._log(f"[{name}] {line}")

    def kill(self, name: str) -> None:
        """SIGKILL one node, as a crash would."""
        proc = self.procs[name]
        self.killed.add(name)
        proc.kill()
        proc.wait()

    def crash(self, name: str) -> None:
        """SIGKILL one node as a crash would, unasked: the cell file's respawn brings it back
        (``supervise``), as for any node that dies."""
        proc = self.procs[name]
        proc.kill()
        proc.wait()

    def supervise(self) -> str | None:
        """Start again the nodes that ended unasked and may respawn (logged); the reason the
        cell must stop (a node that died and may not, or no longer), or None."""
        now = time.monotonic()
        for name, proc in list(self.procs.items()):
            if name not in self.killed and proc.poll() is not None:
                del self.procs[name]
                self._log(f"[cell] {self.book.on_exit(name, proc.returncode, now)}\n")
        for name in self.book.due(now):
            self.start(name, again=True)
        return self.book.fatal

    def _log(self, line: str) -> None:
        with self.log_lock:
            self.log.write(line)
            self.log.flush()

    def stop(self, grace_s: float = 15.0) -> None:
        for proc in self.procs.values():
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        deadline = time.monotonic() + grace_s
        for proc in self.procs.values():
            try:
                proc.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for pump in self.pumps:
            pump.join(timeout=2.0)
        self._log(f"[cell] {clean_dead_shared_memory()}\n")  # a node killed, or that crashed


def private_domain() -> int:
    """Put this process and the nodes it starts on a DDS domain of their own (kept on this
    host), so a benchmark never hears a cell someone runs by hand, nor another benchmark."""
    if "DENSEPACK_PRIVATE_DOMAIN" not in os.environ:
        os.environ["DENSEPACK_PRIVATE_DOMAIN"] = str(allocate_domain_id(120, 200))
    os.environ["ROS_DOMAIN_ID"] = os.environ["DENSEPACK_PRIVATE_DOMAIN"]
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return int(os.environ["ROS_DOMAIN_ID"])


def private_ros_home(workdir: Path) -> Path:
    """Keep the runtime state of the nodes this process starts (ROS logs, the detector's
    camera check record) under ``workdir``: a benchmark starts from no earlier check, and
    its first scene's check serves the scenes after it, as on one cell."""
    home = workdir / "ros_home"
    home.mkdir(parents=True, exist_ok=True)
    os.environ["ROS_HOME"] = str(home)
    return home


def stop_cells_on_sigterm() -> None:
    """SIGTERM unwinds the main thread like Ctrl-C, so every ``finally: cell.stop()`` runs."""
    def _exit(signum: int, frame: Any) -> None:
        raise SystemExit(128 + signum)

    signal.signal(signal.SIGTERM, _exit)
