"""The reference-plan file (``docs/bench/reference_plans.json``): reading it and its keys.

Written by ``densepack-bench reference`` (``nodes.bench.reference``), read by every planner
benchmark row for its reference columns, and checked whole by a unit test (every plan in it
replays valid on its own scene).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from msgs_py import Plan

REFERENCE_FILE = Path(__file__).resolve().parents[2] / "docs" / "bench" / "reference_plans.json"


def scene_key(kind: str, n: int, density: float, seed: int) -> str:
    return f"{kind}/{n}/{density:g}/{seed}"


def load_reference(path: Path = REFERENCE_FILE) -> dict[str, dict[str, Any]]:
    """The file's entries by scene key ({} when there is no file)."""
    if not path.exists():
        return {}
    return {e["key"]: e for e in json.loads(path.read_text())["scenes"]}


def entry_plan(entry: dict[str, Any]) -> Plan:
    """The entry's best plan (with its scene and parameters, replayable on its own)."""
    return Plan.from_dict(entry["plan"], f"scenes[{entry['key']}].plan")


def proven_optimum(entry: dict[str, Any] | None) -> int | None:
    """The entry's optimum when proven (certified, or over the pose set), else None."""
    if entry is None or entry.get("status") not in ("optimal", "optimal_over_pose_set"):
        return None
    return entry["best_actions"]


