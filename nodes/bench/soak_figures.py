"""The soak's figures, free of ROS: what one goal did (from the executor's lifetime counts),
whether it started afresh, and whether anything grew over the shift.

Issue 29's targets for a shift of N goals: at least N - 1 done, none lost, every process's
memory within 10% of its value after goal 10, and the wall time per goal flat (the last 50
goals' median within 10% of that of goals 10-60). For a short soak the windows shrink with
it (``windows``), so a 5-goal soak reports the same figures on fewer goals.
"""

from __future__ import annotations

import math
import re
import statistics
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from msgs_py import BlockSet, Plan, Scene

#: Executor status metrics counted over the executor's life, not per goal: a goal's own is
#: the difference over it.
LIFETIME_COUNTS = ("actions_executed", "observations", "late_detections", "faults",
                   "protective_stops", "blocked_descents")
#: A goal's first plan must start within this of where its scene put the blocks (the
#: detection's error is a fraction of a millimetre; the last goal's end is centimetres away).
FRESH_START_M = 0.005
#: Growth allowed over the shift (fraction), memory and wall time per goal.
GROWTH_LIMIT = 0.10
REFERENCE_GOAL = 10
#: The benchmark's own process (its monitor and goal client): its memory is measured and
#: reported, but the memory target is the cell's processes', not the instrument's.
BENCH_CLIENT = "client"
WINDOW_GOALS = 50


def lifetime_keys(metrics: Mapping[str, float]) -> list[str]:
    """The executor's lifetime counts among ``metrics``: LIFETIME_COUNTS, the per-kind fault
    counts (``faults_<kind>``) and the simulated time per activity (``time_<activity>_s``)."""
    return [k for k in metrics if k in LIFETIME_COUNTS or k.startswith("faults_")
            or (k.startswith("time_") and k.endswith("_s"))]


def goal_counts(before: Mapping[str, float], after: Mapping[str, float]) -> dict[str, float]:
    """The executor's lifetime counts over one goal. A count that went down restarted with a
    new executor process (a respawn): the goal's is then what the new one counted."""
    out = {}
    for key in lifetime_keys(after):
        now, then = float(after[key]), float(before.get(key, 0.0))
        out[key] = now - then if now >= then else now
    return out


def fresh_start_problems(scene: Scene, detection: BlockSet | None, first_plan: Plan | None,
                         contacts: float | None, lost: float | None) -> list[str]:
    """What a goal inherited from the last one, if anything: a detection of other blocks, a
    first plan that starts elsewhere than the scene laid out, or the sim's event counts not
    back at zero when the goal began."""
    problems = []
    ids = sorted(b.id for b in scene.blocks)
    if detection is None:
        problems.append("no detection of the new scene before the goal")
    elif sorted(detection.ids) != ids:
        problems.append(f"the detection before the goal shows blocks {sorted(detection.ids)}, "
                        f"the scene has {ids}")
    if first_plan is not None and first_plan.scene is not None:
        planned = {b.id: b.pose for b in first_plan.scene.blocks}
        laid = {b.id: b.pose for b in scene.blocks}
        off = {i: planned[i].distance_to(laid[i]) if i in planned else math.inf for i in laid}
        worst = max(off, key=off.__getitem__)
        if off[worst] > FRESH_START_M:
            problems.append(f"the first plan starts block {worst} "
                            f"{off[worst] * 1e3:.0f} mm from where the scene put it")
    if contacts or lost:
        problems.append(f"the sim's events began at {contacts} contacts, {lost} lost")
    return problems


_RESET_TIME = re.compile(r"at t = ([0-9.]+) s")


def reset_time_s(message: str) -> float | None:
    """The simulated time of a /sim/reset from its answer ("reset: 9 blocks at t = 83.2 s")."""
    found = _RESET_TIME.search(message)
    return float(found.group(1)) if found else None


@dataclass(frozen=True, slots=True)
class Windows:
    """Goal numbers (1-based, inclusive) the shift's figures compare."""

    reference: int  #: memory is compared with its value after this goal
    early: tuple[int, int]  #: wall time per goal at the start ...
    late: tuple[int, int]  #: ... and at the end of the shift


def windows(n_goals: int, reference: int = REFERENCE_GOAL, width: int = WINDOW_GOALS
            ) -> Windows:
    """Issue 29's windows for 200 goals (after goal 10; goals 10-59 against the last 50),
    shrunk for a shorter shift: the reference at most half-way, each window at most half of
    what follows it."""
    ref = max(1, min(reference, n_goals // 2))
    k = max(1, min(width, (n_goals - ref + 1) // 2))
    return Windows(ref, (ref, ref + k - 1), (n_goals - k + 1, n_goals))


def _median(rows: Sequence[Mapping[str, Any]], key: str, span: tuple[int, int]) -> float:
    values = [r[key] for r in rows if span[0] <= r["goal"] <= span[1] and r.get(key) is not None]
    return statistics.median(values) if values else math.nan


def memory_growth(rows: Sequence[Mapping[str, Any]], reference: int) -> dict[str, float]:
    """Per process: the largest RSS after goal ``reference`` over its RSS then, minus 1."""
    ref = next((r for r in rows if r["goal"] == reference), None)
    if ref is None:
        return {}
    growth = {}
    for name, base in ref["rss_mb"].items():
        later = [r["rss_mb"].get(name) for r in rows if r["goal"] > reference]
        later = [v for v in later if v is not None]
        if base and later:
            growth[name] = max(later) / base - 1.0
    return growth


def summarise(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The shift's figures and each target's verdict."""
    n = len(rows)
    w = windows(n)
    done = sum(r["outcome"] == "done" for r in rows)
    lost = sum(r.get("lost") or 0 for r in rows)
    every = memory_growth(rows, w.reference)
    growth = {name: g for name, g in every.items() if name != BENCH_CLIENT}
    early, late = _median(rows, "wall_s", w.early), _median(rows, "wall_s", w.late)
    wall_ratio = late / early if early and not math.isnan(early) else math.nan
    worst_name = max(growth, key=growth.__getitem__) if growth else None
    return {
        "goals": n, "done": done, "lost": lost,
        "fresh": sum(not r["inherited"] for r in rows),
        "reference_goal": w.reference, "early_goals": list(w.early), "late_goals": list(w.late),
        "memory_growth": growth, "client_memory_growth": every.get(BENCH_CLIENT),
        "memory_growth_max": growth[worst_name] if worst_name else math.nan,
        "memory_growth_worst": worst_name,
        "wall_early_median_s": early, "wall_late_median_s": late, "wall_ratio": wall_ratio,
        "targets": {
            "done": done >= n - 1,
            "lost": lost == 0,
            "fresh": all(not r["inherited"] for r in rows),
            "memory": bool(growth) and max(growth.values()) <= GROWTH_LIMIT,
            "wall_flat": not math.isnan(wall_ratio) and wall_ratio <= 1.0 + GROWTH_LIMIT,
        },
    }


def flat_row(row: Mapping[str, Any], names: Iterable[str]) -> dict[str, Any]:
    """A goal's row with its per-process figures spread into columns (``rss_<name>_mb``) and
    the goal's CPU time summed over the processes (the table's; the JSON keeps both)."""
    out = {k: v for k, v in row.items() if not isinstance(v, dict)}
    for name in names:
        out[f"rss_{name}_mb"] = row["rss_mb"].get(name)
    out["cpu_total_s"] = sum(v for v in row["cpu_s"].values() if v is not None)
    return out
