"""A run's timeline: which action ran when (simulated time), how long it took, how many
corrections followed it and how far its block ended from its goal; drawn as a PNG for the run
report. Pure logic (no rclpy): ``densepack-run`` feeds it the executor's status and the goal's
feedback as they come, then the final per-block errors.

Why from the status stream: the executor publishes ``/executor/status`` on every change of
state or action (stamped with its simulated clock), so the first status of "running action k
of plan p" and the first one after it are the action's start and end, to the status' own
stamps; nothing has to be added to the executor for a report.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

#: Executor states in which an action is still under way (streaming, or a fault being handled).
ACTIVE_STATES = ("running", "recovering")
#: Bar colours per action kind: the planner's own plan drawing uses orange for pushes too.
KIND_COLOURS = {"pick_place": "#4c72b0", "push": "#dd8452"}
UNKNOWN_COLOUR = "#8c8c8c"


@dataclass(frozen=True, slots=True)
class ActionSpan:
    """One executed action: plan ``plan_id``'s action ``index`` of ``total`` (1-based),
    ``kind`` (``pick_place``, ``push`` or ``?`` when the plan was not heard) moving
    ``block``, from ``start_s`` to ``end_s`` (simulated s); ``corrections`` replans the
    executor made from its end to the next action's start (drift it found when it looked);
    ``final_error_m`` the block's final distance from its goal slot (None: not known)."""

    plan_id: str
    index: int
    total: int
    kind: str
    block: int | None
    start_s: float
    end_s: float
    corrections: int = 0
    final_error_m: float | None = None

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


class TimelineBuilder:
    """Turns status samples into ``ActionSpan``s (feed in arrival order).

    ``on_status`` takes the executor's status; ``on_corrections`` the goal feedback's running
    count of corrections; ``add_plan`` each plan's action kinds, so a span knows what it was.
    """

    def __init__(self) -> None:
        self.kinds: dict[str, list[str]] = {}
        self.spans: list[ActionSpan] = []
        self._open: dict[str, Any] | None = None
        self._corrections = 0
        self._corrections_at_end: int | None = None

    def add_plan(self, plan_id: str, kinds: list[str]) -> None:
        self.kinds[plan_id] = list(kinds)

    def on_corrections(self, count: int) -> None:
        self._corrections = max(self._corrections, int(count))

    def on_status(self, stamp_s: float, state: str, plan_id: str, index: int, total: int,
                  block: int | None) -> None:
        key = (plan_id, index)
        current = self._open
        if current is not None and (current["key"] != key or state not in ACTIVE_STATES):
            self._close(stamp_s)
        if self._open is None and state in ACTIVE_STATES and index > 0:
            self._credit_corrections()
            self._open = {"key": key, "total": total, "block": block, "start": stamp_s}

    def _close(self, stamp_s: float) -> None:
        assert self._open is not None
        plan_id, index = self._open["key"]
        kinds = self.kinds.get(plan_id, [])
        kind = kinds[index - 1] if 0 < index <= len(kinds) else "?"
        self.spans.append(ActionSpan(plan_id, index, self._open["total"], kind,
                                     self._open["block"], self._open["start"],
                                     max(stamp_s, self._open["start"])))
        self._corrections_at_end = self._corrections
        self._open = None

    def _credit_corrections(self) -> None:
        """Corrections counted since the previous action ended belong to that action."""
        if self.spans and self._corrections_at_end is not None:
            extra = self._corrections - self._corrections_at_end
            if extra > 0:
                last = self.spans[-1]
                self.spans[-1] = _replace(last, corrections=last.corrections + extra)
            self._corrections_at_end = self._corrections

    def finish(self, stamp_s: float, final_errors: dict[int, float] | None = None
               ) -> list[ActionSpan]:
        """The spans so far (an action still open ends at ``stamp_s``), each with its block's
        final error from ``final_errors`` (block -> m)."""
        if self._open is not None:
            self._close(stamp_s)
        self._credit_corrections()
        errors = final_errors or {}
        return [_replace(s, final_error_m=errors.get(s.block) if s.block is not None else None)
                for s in self.spans]


def _replace(span: ActionSpan, **changes: Any) -> ActionSpan:
    return ActionSpan(**{**asdict(span), **changes})


def spans_to_json(spans: list[ActionSpan]) -> list[dict[str, Any]]:
    """The spans as the report's ``timeline.json`` rows (durations spelled out)."""
    return [{**asdict(s), "duration_s": s.duration_s} for s in spans]


def spans_from_json(rows: list[dict[str, Any]]) -> list[ActionSpan]:
    """``timeline.json`` rows back as spans (to redraw a report's timeline)."""
    names = set(ActionSpan.__dataclass_fields__)
    return [ActionSpan(**{k: v for k, v in row.items() if k in names}) for row in rows]


def write_timeline(spans: list[ActionSpan], png: Path, json_path: Path | None = None,
                   title: str = "", tolerance_m: float | None = None) -> None:
    """Draw ``spans`` into ``png`` (matplotlib, Agg: no display needed) and, if asked, their
    figures into ``json_path``.

    Left: one bar per action on the simulated-time axis, coloured by kind and labelled with
    its block, duration and corrections. Right: each action's block's final error (mm), with
    the placement tolerance as a line.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if json_path is not None:
        json_path.write_text(json.dumps(spans_to_json(spans), indent=2) + "\n")
    n = max(len(spans), 1)
    fig, (ax, ax_err) = plt.subplots(
        1, 2, figsize=(11, 1.2 + 0.38 * n), sharey=True,
        gridspec_kw={"width_ratios": [3, 1]})
    rows = list(range(len(spans)))
    for row, s in zip(rows, spans, strict=True):
        colour = KIND_COLOURS.get(s.kind, UNKNOWN_COLOUR)
        ax.barh(row, s.duration_s, left=s.start_s, color=colour, height=0.7)
        label = f"{s.duration_s:.1f} s"
        if s.corrections:
            label += f", {s.corrections} correction{'s' if s.corrections > 1 else ''}"
        ax.text(s.end_s + 0.3, row, label, va="center", fontsize=8)
        if s.final_error_m is not None:
            ax_err.barh(row, s.final_error_m * 1e3, color=colour, height=0.7)
            ax_err.text(s.final_error_m * 1e3, row, f" {s.final_error_m * 1e3:.2f}",
                        va="center", fontsize=8)
    ax.set_yticks(rows, [f"{s.index}/{s.total} {s.kind} b{s.block}"
                         + ("" if k == 0 or s.plan_id == spans[k - 1].plan_id else " (new plan)")
                         for k, s in enumerate(spans)], fontsize=8)
    ax.invert_yaxis()
    ax.set_xlabel("simulated time (s)")
    if spans:
        ax.set_xlim(min(s.start_s for s in spans) - 1.0, max(s.end_s for s in spans) + 6.0)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in KIND_COLOURS.values()]
    ax.legend(handles, list(KIND_COLOURS), loc="upper right", fontsize=8)
    ax.set_title(title or "actions", fontsize=10)
    ax_err.set_xlabel("block's final error (mm)")
    if tolerance_m is not None:
        ax_err.axvline(tolerance_m * 1e3, color="k", lw=0.8, ls="--", label="placed tolerance")
        ax_err.legend(loc="lower right", fontsize=7)
    ax_err.set_title("final error vs goal", fontsize=10)
    fig.tight_layout()
    fig.savefig(png, dpi=100)
    plt.close(fig)
