"""A process's memory and CPU time, read from Linux's /proc (the soak's per-goal figures).

Parsing is pure (the text of ``/proc/<pid>/status`` and ``/proc/<pid>/stat`` in, numbers out)
so it is tested on captured text; ``sample`` is the thin part that reads the files.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

#: Clock ticks per second of the stat file's CPU times (getconf CLK_TCK; 100 on Linux).
TICKS_PER_S = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
#: Fields of /proc/<pid>/stat after the command name: state is field 3 of the file, so utime
#: (field 14) and stime (field 15) are at 11 and 12 of what follows the name.
_UTIME, _STIME = 11, 12


@dataclass(frozen=True, slots=True)
class ProcSample:
    """One process at one moment: resident memory (MB) and CPU time used so far (s)."""

    pid: int
    rss_mb: float
    cpu_s: float


def rss_mb_from_status(text: str) -> float:
    """``VmRSS`` of a ``/proc/<pid>/status`` text, in MB (10^6 bytes).

    Raises:
        ValueError: no VmRSS line (a zombie, or not a status file).
    """
    for line in text.splitlines():
        if line.startswith("VmRSS:"):
            value, unit = line.split()[1:3]
            if unit != "kB":
                raise ValueError(f"VmRSS in {unit!r}, expected kB")
            return int(value) * 1024 / 1e6
    raise ValueError("no VmRSS line")


def cpu_s_from_stat(text: str, ticks_per_s: float = TICKS_PER_S) -> float:
    """User + system CPU time (s) of a ``/proc/<pid>/stat`` text. The command name (field 2)
    is in parentheses and may itself hold spaces and parentheses: fields are counted from the
    last ')'."""
    fields = text[text.rindex(")") + 2:].split()
    return (int(fields[_UTIME]) + int(fields[_STIME])) / ticks_per_s


def sample(pid: int, proc: Path = Path("/proc")) -> ProcSample | None:
    """The process's figures now, or None when it is gone (or a zombie)."""
    try:
        status = (proc / str(pid) / "status").read_text()
        stat = (proc / str(pid) / "stat").read_text()
        return ProcSample(pid, rss_mb_from_status(status), cpu_s_from_stat(stat))
    except (OSError, ValueError, IndexError):
        return None


def cpu_used(before: ProcSample | None, after: ProcSample | None) -> float | None:
    """CPU time (s) a process used between two samples; a process started again since (a
    respawn: another pid) counts from its start. None when it is gone."""
    if after is None:
        return None
    if before is None or before.pid != after.pid:
        return after.cpu_s
    return after.cpu_s - before.cpu_s
