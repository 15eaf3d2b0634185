"""Progress reports of the planner and the executor (JSON payloads of std_msgs/String).

Both are flat records: a ``state`` from a fixed vocabulary, counters, the last error in
words and a ``metrics`` dict of figures (seconds, counts) for dashboards and reports.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from msgs_py.checks import (
    check_keys,
    finite_float,
    integer,
    require_mapping,
    text,
)
from msgs_py.errors import MessageError
from msgs_py.scene import SCHEMA_VERSION

EXECUTOR_STATES = (
    "idle",  # no plan yet
    "running",  # streaming an action
    "observing",  # arm out of the camera's view, waiting for a fresh detection
    "recovering",  # handling a fault: setting a block down, bringing one back
    "replanning",  # asked the planner for a new plan from the perceived state
    "stopping",  # lifting and parking after a stop request or an error
    "stopped",  # parked after /executor/stop; /executor/start resumes
    "done",  # plan finished and every block verified at its goal
    "failed",  # gave up; last_error says why
)

PLANNER_STATES = (
    "waiting",  # missing a goal or a detection
    "planning",
    "planned",  # a validated plan was published
    "failed",  # no plan: last_error names the block and the reason
)


def _metrics_from(field: str, raw: Any) -> dict[str, float]:
    raw = require_mapping(field, raw)
    return {str(k): finite_float(f"{field}.{k}", v) for k, v in raw.items()}


@dataclass(frozen=True, slots=True)
class ExecutorStatus:
    """What the executor is doing: action ``action_index`` (1-based) of ``action_total``."""

    state: str
    plan_id: str = ""
    action_index: int = 0
    action_total: int = 0
    block: int | None = None
    last_error: str = ""
    detail: str = ""
    metrics: dict[str, float] = field(default_factory=dict)
    version: int = SCHEMA_VERSION

    def __post_init__(self) -> None:
        if self.state not in EXECUTOR_STATES:
            raise MessageError("state", self.state, f"expected one of {list(EXECUTOR_STATES)}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "version": self.version,
            "state": self.state,
            "plan_id": self.plan_id,
            "action_index": self.action_index,
            "action_total": self.action_total,
            "block": self.block,
            "last_error": self.last_error,
            "detail": self.detail,
            "metrics": dict(self.metrics),
        }

    @classmethod
    def from_dict(cls, data: Any) -> ExecutorStatus:
        data = require_mapping("status", data)
        optional = ("plan_id", "action_index", "action_total", "block", "last_error", "detail",
                    "metrics")
        check_keys("", data, ("version", "state"), optional)
        _check_version(data["version"])
        block = data.get("block")
        return cls(
            state=text("state", data["state"]),
            plan_id=text("plan_id", data.get("plan_id", "")),
            action_index=integer("action_index", data.get("action_index", 0), minimum=0),
            action_total=integer("action_total", data.get("action_total", 0), minimum=0),
            block=None if block is None else integer("block", block, minimum=0),
            last_error=text("last_error", data.get("last_error", "")),
            detail=text("detail", data.get("detail", "")),
            metrics=_metrics_from("metrics", data.get("metrics", {})),
        )


@dataclass(frozen=True, slots=True)
class PlannerStatus:
    """What the planner did last: ``failed`` carries the block and reason in ``last_error``."""

    state: str
    plan_id: str = ""
    n_actions: int = 0
    planning_time_s: float = 0.0
    last_error: str = ""
    failed_block: int | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    version: int = SCHEMA_VERSION

    def __post_init__(self) -> None:
        if self.state not in PLANNER_STATES:
            raise MessageError("state", self.state, f"expected one of {list(PLANNER_STATES)}")

    def to_dict(self) -> dict[str, Any]:
        return {
            "version": self.version,
            "state": self.state,
            "plan_id": self.plan_id,
            "n_actions": self.n_actions,
            "planning_time_s": self.planning_time_s,
            "last_error": self.last_error,
            "failed_block": self.failed_block,
            "metrics": dict(self.metrics),
        }

    @classmethod
    def from_dict(cls, data: Any) -> PlannerStatus:
        data = require_mapping("status", data)
        optional = ("plan_id", "n_actions", "planning_time_s", "last_error", "failed_block",
                    "metrics")
        check_keys("", data, ("version", "state"), optional)
        _check_version(data["version"])
        failed = data.get("failed_block")
        return cls(
            state=text("state", data["state"]),
            plan_id=text("plan_id", data.get("plan_id", "")),
            n_actions=integer("n_actions", data.get("n_actions", 0), minimum=0),
            planning_time_s=finite_float("planning_time_s", data.get("planning_time_s", 0.0)),
            last_error=text("last_error", data.get("last_error", "")),
            failed_block=None if failed is None else integer("failed_block", failed, minimum=0),
            metrics=_metrics_from("metrics", data.get("metrics", {})),
        )


def _check_version(value: Any) -> None:
    version = integer("version", value)
    if version != SCHEMA_VERSION:
        raise MessageError("version", version, f"unsupported; expected {SCHEMA_VERSION}")
