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
#: Fields of /proc/<pid>/stat after the command name: state is field 3 of the file, so the
#: parent pid (field 4), utime (14), stime (15), cutime (16) and cstime (17) are at 1, 11, 12,
#: 13 and 14 of what follows the name. cutime/cstime: the CPU of children it has reaped.
_PPID, _UTIME, _STIME, _CUTIME, _CSTIME = 1, 11, 12, 13, 14


@dataclass(frozen=True, slots=True)
class ProcSample:
    """One process (with its descendants, if asked: the planner's plans run in processes of
    their own) at one moment: resident memory (MB, summed) and CPU time used so far (s,
    reaped children's included)."""

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


def _fields_after_name(text: str) -> list[str]:
    """The stat fields after the command name (field 2), which is in parentheses and may
    itself hold spaces and parentheses: fields are counted from the last ')'."""
    return text[text.rindex(")") + 2:].split()


def cpu_s_from_stat(text: str, ticks_per_s: float = TICKS_PER_S) -> float:
    """User + system CPU time (s) of a ``/proc/<pid>/stat`` text, with that of the children
    the process has reaped."""
    fields = _fields_after_name(text)
    return sum(int(fields[i]) for i in (_UTIME, _STIME, _CUTIME, _CSTIME)) / ticks_per_s


def parent_pid_from_stat(text: str) -> int:
    """The parent pid of a ``/proc/<pid>/stat`` text."""
    return int(_fields_after_name(text)[_PPID])


def descendants(pid: int, parents: dict[int, int]) -> list[int]:
    """Every live descendant of ``pid``, given each process's parent (pid -> ppid)."""
    children: dict[int, list[int]] = {}
    for child, parent in parents.items():
        children.setdefault(parent, []).append(child)
    found, todo = [], list(children.get(pid, []))
    while todo:
        child = todo.pop()
        found.append(child)
        todo.extend(children.get(child, []))
    return found


def process_parents(proc: Path = Path("/proc")) -> dict[int, int]:
    """Every live process's parent (pid -> ppid): read once for all the processes sampled
    at one moment."""
    parents = {}
    for entry in proc.iterdir():
        if entry.name.isdigit():
            try:
                parents[int(entry.name)] = parent_pid_from_stat((entry / "stat").read_text())
            except (OSError, ValueError, IndexError):
                continue
    return parents


def _one(pid: int, proc: Path) -> tuple[float, float] | None:
    try:
        status = (proc / str(pid) / "status").read_text()
        stat = (proc / str(pid) / "stat").read_text()
        return rss_mb_from_status(status), cpu_s_from_stat(stat)
    except (OSError, ValueError, IndexError):
        return None


def sample(pid: int, proc: Path = Path("/proc"), parents: dict[int, int] | None = None
           ) -> ProcSample | None:
    """The figures of ``pid`` now, with those of its live descendants when ``parents``
    (``process_parents``) is given; None when it is gone (or a zombie)."""
    own = _one(pid, proc)
    if own is None:
        return None
    rss, cpu = own
    for child in descendants(pid, parents) if parents is not None else []:
        figures = _one(child, proc)
        if figures is not None:
            rss, cpu = rss + figures[0], cpu + figures[1]
    return ProcSample(pid, rss, cpu)


def cpu_used(before: ProcSample | None, after: ProcSample | None) -> float | None:
    """CPU time (s) a process used between two samples; a process started again since (a
    respawn: another pid) counts from its start. None when it is gone."""
    if after is None:
        return None
    if before is None or before.pid != after.pid:
        return after.cpu_s
    return after.cpu_s - before.cpu_s
