"""The camera check's result kept with its calibration: a recent good one counts, a new
calibration or disagreeing placements void it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py import Pose2D
from msgs_py.camera import CameraPose
from nodes.detector.calibration_check import (
    CheckKeeper,
    CheckRecord,
    default_record_path,
    load_record,
    recent,
    save_record,
)
from nodes.detector.handeye import HandEye, PlaneCorrection, Sample, Verdict
from tests.unit.detector.test_handeye import CENTRE, CORNERS, perceive, placement

POSE = CameraPose((0.70, 0.0, 1.25), (0.7071068, -0.7071068, 0.0, 0.0))
OTHER = CameraPose((0.703, 0.0, 1.25), (0.7071068, -0.7071068, 0.0, 0.0))
FIX = PlaneCorrection(0.002, -0.001, 0.003, *CENTRE)


def test_a_record_is_read_back_and_counts_only_for_its_calibration_while_recent(tmp_path):
    path = tmp_path / "densepack" / "camera_check.yaml"
    save_record(path, CheckRecord(POSE, 1000.0, FIX, 3))
    record = load_record(path)
    assert record == CheckRecord(POSE, 1000.0, FIX, 3)
    assert recent(record, POSE, 1000.0 + 3600, max_age_s=7200) == record
    assert recent(record, POSE, 1000.0 + 9000, max_age_s=7200) is None  # too old
    assert recent(record, OTHER, 1001.0, max_age_s=7200) is None  # another calibration
    path.write_text("not: [a record")
    assert load_record(path) is None and load_record(tmp_path / "none.yaml") is None


def test_the_record_lives_under_ros_home(monkeypatch, tmp_path):
    monkeypatch.setenv("ROS_HOME", str(tmp_path))
    assert default_record_path() == tmp_path / "densepack" / "camera_check.yaml"


def squared(true: Pose2D, d, w) -> Sample:
    """The camera check's placement: gripped in place where the camera sees it, along both
    axes, so the block ends on the TCP and is seen through the error from there."""
    seen_at = perceive(true, d, w)
    return Sample(seen_at, seen_at, 0.3, perceive(seen_at, d, w), squared=True)


def test_placements_agree_once_they_pin_the_error_and_the_correction_fits_them():
    eye = HandEye(CORNERS, CENTRE)
    assert eye.verdict() is Verdict.UNKNOWN
    d, w = (0.004, -0.003), math.radians(0.3)
    eye.samples.append(squared(Pose2D(0.6, 0.1, 0.0), d, w))
    eye.samples.append(placement(Pose2D(0.8, -0.2, 0.5), Pose2D(0.7, 0.0, 0.0), 1.2, d, w))
    eye._update(0)
    assert eye.verdict() is Verdict.AGREES
    # a camera bumped 5 mm since: a placement the correction misplaces, and one alone along
    # one axis cannot be corrected from
    eye.samples.append(placement(Pose2D(0.9, 0.2, 0.0), Pose2D(0.8, 0.1, 0.0), 0.0,
                                 (d[0] + 0.005, d[1]), w))
    assert eye.verdict() is Verdict.DISAGREES


def test_the_keeper_saves_an_agreement_and_voids_a_disagreement(tmp_path):
    path = tmp_path / "check.yaml"
    keeper = CheckKeeper(path, POSE, max_age_s=3600, now=0.0)
    assert keeper.status(0.0) == (False, "not checked against the arm yet")
    assert not keeper.on_verdict(Verdict.UNKNOWN, FIX, 1, 10.0)
    numpy_fix = PlaneCorrection(*(np.float64(v) for v in (0.002, -0.001, 0.003, *CENTRE)))
    assert keeper.on_verdict(Verdict.AGREES, numpy_fix, 2, 10.0)  # as the fit returns it
    assert keeper.error == "" and load_record(path) is not None
    checked, words = keeper.status(10.0 + 1800)
    assert checked and "0.5 h ago" in words
    assert CheckKeeper(path, POSE, 3600, now=100.0).record.correction == FIX  # next start
    assert CheckKeeper(path, OTHER, 3600, now=100.0).record is None
    assert keeper.on_verdict(Verdict.DISAGREES, FIX, 3, 20.0)
    assert not path.exists() and keeper.status(20.0)[0] is False
    assert "disagree" in keeper.status(20.0)[1]


@pytest.mark.parametrize("checked, expected", [(True, True), (False, False), (None, False)])
def test_the_executor_makes_its_camera_check_unless_the_detector_says_checked(checked, expected):
    from nodes.executor.core import ExecutorCore
    from tests.unit.executor.world import CHECKING

    core = ExecutorCore(CHECKING)
    core.on_calibration(checked)
    assert core.belief.camera_checked is expected


def test_a_record_that_cannot_be_written_is_said_not_raised(tmp_path):
    blocker = tmp_path / "not_a_folder"
    blocker.write_text("")
    keeper = CheckKeeper(blocker / "check.yaml", POSE, 3600, now=0.0)
    assert keeper.on_verdict(Verdict.AGREES, FIX, 2, 1.0)
    assert keeper.error and keeper.status(1.0)[0]  # checked for this detector's life
