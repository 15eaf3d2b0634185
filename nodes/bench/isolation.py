"""A scene of the cell benchmark in a process of its own.

The benchmark's client node lives in the scene's process; when its DDS teardown hangs (Fast
DDS 2.14 was seen to deadlock once in 18 chaos scenes, in ``PDP::removeWriterProxyData`` while
the client node's publishers were destroyed), that process is killed once its metrics are
written, and the benchmark goes on with them.
"""

from __future__ import annotations

import json
import multiprocessing
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any


def metrics_file(workdir: Path, blocks: int, seed: int, fault: str) -> Path:
    return workdir / f"metrics_{blocks}_{seed}_{fault}.json"


#: A scene's client process still there this long after it wrote its metrics is killed (s):
#: its DDS teardown hung (see the module's docstring).
TEARDOWN_GRACE_S = 30.0
#: Beyond the scene's own timeout, the wall time a scene's process may take to start and end
#: the cell (s).
SCENE_SLACK_S = 180.0


def run_scene_isolated(blocks: int, density: float, seed: int, fault: str, timeout: float,
                       workdir: Path, target: Callable[..., Any],
                       grace_s: float = TEARDOWN_GRACE_S) -> dict[str, Any]:
    """``run_scene`` (``target``) in a process of its own: a DDS teardown that hangs costs
    that process, killed ``grace_s`` after its metrics are written, not the benchmark."""
    out = metrics_file(workdir, blocks, seed, fault)
    out.unlink(missing_ok=True)
    proc = multiprocessing.get_context("spawn").Process(
        target=target, args=(blocks, density, seed, fault, timeout, workdir),
        name=f"scene-{blocks}-{seed}-{fault}")
    proc.start()
    deadline = time.monotonic() + timeout + SCENE_SLACK_S
    try:
        while proc.is_alive() and not out.exists() and time.monotonic() < deadline:
            proc.join(1.0)
        proc.join(grace_s)
    finally:
        if proc.is_alive() and not out.exists():  # interrupted: it stops its cell on SIGTERM
            proc.terminate()
            proc.join(grace_s)
    if proc.is_alive():
        print(f"  {blocks} blocks, {fault}, seed {seed}: the scene's process did not end "
              f"{grace_s:.0f} s after its run (a hung DDS teardown): killed",
              flush=True)
        proc.kill()
        proc.join()
    if not out.exists():
        raise RuntimeError(f"scene {blocks} blocks, {fault}, seed {seed}: its process ended "
                           f"(exit code {proc.exitcode}) without metrics; see {workdir}")
    return json.loads(out.read_text())
