"""The cell benchmark's figures: what counts as a success, one (blocks, fault) row, and
each scene's own figures (so runs split by ``--first-seed`` add up exactly)."""

from __future__ import annotations

import statistics
from typing import Any

#: A block counts as at its goal within these of it (ground truth).
SUCCESS_POS_M = 0.003
SUCCESS_YAW_DEG = 2.0


def is_success(m: dict[str, Any]) -> bool:
    """Done with every block at its goal (3 mm / 2 deg by ground truth), none lost; for a
    block taken away, the documented outcome: failed, naming that block, none lost; for a
    stray gripper command, also refused and named by the gripper node."""
    if m.get("stray_refused") is False:
        return False
    if m.get("removed") is not None:
        return (m["outcome"] == "failed" and f"[{m['removed']}]" in (m.get("last_error") or "")
                and not m["blocks_lost"] and not held_at_end(m))
    return (m["outcome"] == "done" and m["final_pos_err_max_m"] is not None
            and m["final_pos_err_max_m"] <= SUCCESS_POS_M
            and m["final_yaw_err_max_deg"] <= SUCCESS_YAW_DEG
            and not m["blocks_lost"] and not held_at_end(m))


def held_at_end(m: dict[str, Any]) -> int:
    """How many blocks the run left off the table (in the fingers) when it ended."""
    return len(m.get("blocks_raised_at_end") or ())


def summarise(blocks: int, fault: str, runs: list[dict[str, Any]]) -> dict[str, Any]:
    errors = [e for m in runs for e in m["final_errors"]]
    pos = [e["pos_err_m"] for e in errors]
    yaw = [e["yaw_err_deg"] for e in errors]

    def median(key: str, items=runs) -> float:
        values = [m[key] for m in items if m.get(key) is not None]
        return statistics.median(values) if values else float("nan")

    def total(key: str) -> float:
        return float(sum(m[key] or 0 for m in runs))

    return {
        "blocks": blocks,
        "fault": fault,
        "scenes": len(runs),
        "success_rate": sum(m["success"] for m in runs) / len(runs),
        "pos_err_median_m": statistics.median(pos) if pos else float("nan"),
        "pos_err_max_m": max(pos) if pos else float("nan"),
        "yaw_err_median_deg": statistics.median(yaw) if yaw else float("nan"),
        "yaw_err_max_deg": max(yaw) if yaw else float("nan"),
        "actions_executed_median": median("actions_executed"),
        "actions_planned_median": median("actions_planned"),
        "corrections": total("replans"),
        "unintended_contacts": total("unintended_contacts"),
        "blocks_lost": total("blocks_lost"),
        "blocks_held_at_end": sum(held_at_end(m) for m in runs),
        "sim_time_median_s": median("sim_time_s"),
        "sim_time_per_action_median_s": statistics.median(
            [m["sim_time_s"] / m["actions_executed"] for m in runs
             if m.get("sim_time_s") and m.get("actions_executed")] or [float("nan")]),
        # where the simulated time went, per activity, the median over the scenes
        "sim_time_by_activity_median_s": activity_medians(runs),
        # per scene: the share of the looks after actions that needed the look pose
        "look_pose_shares": [look_pose_share(m.get("looks") or {}) for m in runs],
        "wall_time_median_s": median("wall_time_s"),
        "wall_time_max_s": max(m["wall_time_s"] for m in runs),
        "per_scene": [per_scene(m) for m in runs],
        "outcomes": [f"seed {m['seed']}: {m['outcome']}"
                     + (f" ({'; '.join(m['notes'])})" if m["notes"] else "")
                     + (f" [{m['last_error']}]" if m.get("last_error") else "")
                     for m in runs],
    }


def per_scene(m: dict[str, Any]) -> dict[str, Any]:
    """One scene's figures, so runs split by ``--first-seed`` add up exactly (medians and
    maxima over all of them) and a rare failure or contact is found by its seed."""
    return {key: m.get(key) for key in (
        "seed", "success", "outcome", "actions_executed", "replans", "unintended_contacts",
        "blocks_lost", "blocks_raised_at_end", "final_pos_err_max_m", "final_yaw_err_max_deg",
        "sim_time_s", "wall_time_s", "sim_time_by_activity_s", "looks")}


def activity_medians(runs: list[dict[str, Any]]) -> dict[str, float]:
    """Per activity of the runs' ``sim_time_by_activity_s`` (a run that never did it: 0 s),
    the median simulated seconds."""
    spent = [m.get("sim_time_by_activity_s") or {} for m in runs]
    names = sorted({name for s in spent for name in s})
    return {name: round(statistics.median(s.get(name, 0.0) for s in spent), 3)
            for name in names}


def look_pose_share(looks: dict[str, float]) -> float | None:
    """Of the looks after actions, the share that needed the arm out of view: from the look
    pose, or again from the park pose for a block the frame did not show (None: no look)."""
    total = sum(looks.values())
    parked = looks.get("from_look_pose", 0.0) + looks.get("again_from_park_pose", 0.0)
    return round(parked / total, 3) if total else None
