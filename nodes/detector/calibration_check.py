"""The camera check's result, kept with the calibration it checked, so a run after a recent good
check starts acting at once.

The executor's camera check (a block gripped in place along both its axes, a ``squared``
placement) and every placement after it tell the detector's hand-eye check
(``nodes.detector.handeye``) whether perception and arm agree, and which table-plane
correction makes them. Once they agree, the detector writes that result here: the calibrated
camera pose it holds for (a new calibration voids it), when, and the correction. A detector
that starts with a recent record for its calibration uses the correction from its first frame
and says the calibration is checked (``/detector/calibration``): the executor then skips its
camera check, and the first placements go on checking. Placements that disagree with the
correction in use, and that the hand-eye check cannot correct, void the record: the next run
checks again.

The record lives in ``$ROS_HOME/densepack/camera_check.yaml`` (``ROS_HOME`` defaults to
``~/.ros``, where ROS keeps a machine's runtime state), one per machine. Pure logic, no ROS.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import yaml

from msgs_py.camera import CameraPose
from nodes.detector.handeye import PlaneCorrection, Verdict

#: Poses closer than this (m, and rad of each quaternion component) are the same calibration.
SAME_POSE = 1e-6


@dataclass(frozen=True, slots=True)
class CheckRecord:
    """A good check: the camera pose it held for, when (s since the epoch, wall clock), the
    correction that made placements and perception agree, and from how many placements."""

    calibration: CameraPose
    checked_at: float
    correction: PlaneCorrection
    placements: int

    def holds_for(self, pose: CameraPose) -> bool:
        """Whether this record is about ``pose`` (a new calibration voids it)."""
        return all(abs(a - b) <= SAME_POSE for a, b in zip(
            (*self.calibration.position, *self.calibration.orientation_xyzw),
            (*pose.position, *pose.orientation_xyzw), strict=True))

    def age_s(self, now: float) -> float:
        return now - self.checked_at

    def to_dict(self) -> dict:
        c = self.correction
        return {
            "calibration": {"position": [float(v) for v in self.calibration.position],
                            "orientation_xyzw": [float(v) for v in
                                                 self.calibration.orientation_xyzw]},
            "checked_at": float(self.checked_at),
            "correction": {k: float(getattr(c, k)) for k in ("dx", "dy", "w", "cx", "cy")},
            "placements": int(self.placements),
        }

    @classmethod
    def from_dict(cls, d: dict) -> CheckRecord:
        cal, c = d["calibration"], d["correction"]
        return cls(CameraPose(tuple(cal["position"]), tuple(cal["orientation_xyzw"])),
                   float(d["checked_at"]),
                   PlaneCorrection(float(c["dx"]), float(c["dy"]), float(c["w"]),
                                   float(c["cx"]), float(c["cy"])),
                   int(d["placements"]))


def default_record_path() -> Path:
    """``$ROS_HOME/densepack/camera_check.yaml`` (``~/.ros`` without ROS_HOME)."""
    home = os.environ.get("ROS_HOME") or os.path.join(os.path.expanduser("~"), ".ros")
    return Path(home) / "densepack" / "camera_check.yaml"


def load_record(path: Path) -> CheckRecord | None:
    """The record at ``path``; None when there is none or it is unreadable (a check is then
    made again, which is always safe)."""
    try:
        return CheckRecord.from_dict(yaml.safe_load(path.read_text()))
    except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError):
        return None


def save_record(path: Path, record: CheckRecord) -> None:
    """Write the record (atomically: a reader never sees half of one)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text("# densepack: the camera check's last good result (nodes/detector/"
                   "calibration_check.py)\n" + yaml.safe_dump(record.to_dict(), sort_keys=False))
    tmp.replace(path)


def void_record(path: Path) -> None:
    path.unlink(missing_ok=True)


def recent(record: CheckRecord | None, pose: CameraPose, now: float, max_age_s: float
           ) -> CheckRecord | None:
    """``record`` if it is about ``pose`` and younger than ``max_age_s``, else None."""
    if record is None or not record.holds_for(pose):
        return None
    age = record.age_s(now)
    return record if 0.0 <= age <= max_age_s and math.isfinite(age) else None


class CheckKeeper:
    """The detector's side of it: the record for its calibration, kept up to date from the
    hand-eye check's verdicts, and what to say of it."""

    def __init__(self, path: Path, pose: CameraPose, max_age_s: float, now: float) -> None:
        self.path = path
        self.pose = pose
        self.max_age_s = max_age_s
        self.record = recent(load_record(path), pose, now, max_age_s)
        self.disagrees = False
        self.error = ""  #: why the record could not be written or voided ("" = it could)

    def on_verdict(self, verdict: Verdict, correction: PlaneCorrection, placements: int,
                   now: float) -> bool:
        """The hand-eye check's verdict after a placement was seen; True when what the
        detector says of its calibration changed."""
        if verdict is Verdict.DISAGREES:
            changed = self.record is not None or not self.disagrees
            self.record, self.disagrees = None, True
            self._store(None)
            return changed
        if verdict is not Verdict.AGREES:
            return False
        was = self.record
        self.record = CheckRecord(self.pose, now, correction, placements)
        self.disagrees = False
        self._store(self.record)
        return was is None or was.correction != correction

    def _store(self, record: CheckRecord | None) -> None:
        """Write (or void) the record; a file that cannot be written costs the next run a
        check, never a frame (``error`` says why)."""
        try:
            if record is None:
                void_record(self.path)
            else:
                save_record(self.path, record)
            self.error = ""
        except (OSError, yaml.YAMLError) as err:
            self.error = f"{self.path}: {err}"

    def status(self, now: float) -> tuple[bool, str]:
        """(checked, in words)."""
        r = self.record
        if r is not None:
            return True, (f"checked against the arm's placements {r.age_s(now) / 3600:.1f} h ago "
                          f"({r.placements} placements; correction {r.correction.describe()})")
        if self.disagrees:
            return False, "the arm's placements disagree with the calibration: check it again"
        return False, "not checked against the arm yet"
