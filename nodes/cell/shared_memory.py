"""The shared-memory files a dead node leaves behind, removed by Fast DDS's own cleaner.

Fast DDS keeps each participant's segment (the sim's is 16 MB, ``nodes.common.transports``)
and its port as files in ``/dev/shm``, each with a lock file its process holds. A process that
ends cleanly removes them; one killed (SIGKILL, a crash, the chaos benchmark) leaves them
there until the machine restarts: 91 segments after a day of chaos runs and tests here. The
launchers therefore run ``fastdds shm clean``, the tool installed with Fast DDS, when a node
has died and when the cell stops: it removes only files whose lock no live process holds, so
other cells and ROS programs on the computer keep theirs.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

#: Fast DDS's command-line tool, installed beside the interpreter by its wheel.
FASTDDS_TOOL = Path(sys.prefix) / "tools" / "fastdds" / "fastdds.py"
CLEAN_TIMEOUT_S = 30.0


def clean_dead_shared_memory(tool: Path = FASTDDS_TOOL) -> str:
    """Run ``fastdds shm clean``; its summary on one line (what it found in use and what it
    removed), or why it did not run."""
    if not tool.exists():
        return f"shared memory not cleaned: {tool} is not installed"
    try:
        done = subprocess.run([sys.executable, str(tool), "shm", "clean"], capture_output=True,
                              text=True, timeout=CLEAN_TIMEOUT_S, check=False)
    except (OSError, subprocess.TimeoutExpired) as err:
        return f"shared memory not cleaned: {err}"
    lines = [line.strip() for line in done.stdout.splitlines() if line.strip()]
    if done.returncode != 0 or not lines:
        return f"shared memory not cleaned: fastdds shm clean said {done.stderr.strip()!r}"
    return "shared memory: " + ", ".join(lines[1:] if lines[0].endswith(":") else lines)
