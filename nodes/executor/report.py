"""What the executor tells about its run: the detail and last error of its status, its log
lines and its figures (counts, and the simulated time per activity)."""

from __future__ import annotations

import math

from msgs_py import ExecutorStatus
from msgs_py.status import ExecutorState as State
from nodes.executor.belief import Belief
from nodes.executor.ledger import TimeLedger
from nodes.executor.supervision import FaultKind
from nodes.executor.verify import Deviation


class Report:
    """The status's words and figures, and the log lines of the current tick."""

    def __init__(self) -> None:
        self.detail = ""
        self.last_error = ""
        self.metrics: dict[str, float] = {
            "actions_executed": 0.0, "replans": 0.0, "observations": 0.0,
            "execution_time_s": 0.0, "faults": 0.0,
        }
        self.ledger = TimeLedger()
        self._log: list[str] = []

    def log(self, line: str) -> None:
        """A line for the node's log (handed on by the next tick)."""
        self._log.append(line)

    def say(self, detail: str) -> None:
        """``detail`` is what the executor does now: in the status, and logged."""
        self.detail = detail
        self.log(detail)

    def take_log(self) -> list[str]:
        lines, self._log = self._log, []
        return lines

    def count(self, name: str, by: float = 1.0) -> None:
        self.metrics[name] = self.metrics.get(name, 0.0) + by

    def count_fault(self, kind: FaultKind) -> None:
        """One more fault, in the total and in its kind's count (``faults_<kind>``)."""
        self.count("faults")
        self.count(f"faults_{kind.name.lower()}")

    def goal_errors(self, errors: list[Deviation]) -> None:
        """Keep the worst perceived goal errors (position m, yaw deg) in the figures."""
        if errors:
            self.metrics["final_pos_err_max_m"] = max(d.position_error for d in errors)
            self.metrics["final_yaw_err_max_deg"] = math.degrees(
                max(d.yaw_error for d in errors))


def executor_status(state: State, belief: Belief, report: Report, replans: int
                    ) -> ExecutorStatus:
    """What ``/executor/status`` says: action k of n counts the plan's actions only (the
    camera check's re-grips show in the detail); the block is the one the running action
    or recovery handles, or the one the fingers hold."""
    b = belief
    total = len(b.plan.actions) if b.plan else 0
    block = None
    if b.plan and state is State.RUNNING and b.index < total:
        block = b.plan.actions[b.index].block
    if state is State.RECOVERING and b.handling is not None:
        block = b.handling
    running = state is State.RUNNING and b.index >= b.probes
    if b.held is not None and b.held.block is not None:
        block = b.held.block
    return ExecutorStatus(
        state=state,
        plan_id=b.plan.plan_id if b.plan else "",
        action_index=min(max(0, b.index - b.probes) + (1 if running else 0), total - b.probes),
        action_total=total - b.probes,
        block=block,
        last_error=report.last_error,
        detail=report.detail,
        metrics=dict(report.metrics, replans=float(replans), **report.ledger.metrics()),
    )
