"""What the executor tells: its detail, log lines and figures."""

from __future__ import annotations

import math

import pytest

from nodes.executor.report import Report
from nodes.executor.supervision import FaultKind
from nodes.executor.verify import Deviation


def test_a_fault_counts_in_the_total_and_in_its_kind():
    report = Report()
    report.count_fault(FaultKind.MISSED)
    report.count_fault(FaultKind.NOT_RELEASED)
    report.count_fault(FaultKind.MISSED)
    assert report.metrics["faults"] == 3
    assert (report.metrics["faults_missed"], report.metrics["faults_not_released"]) == (2, 1)


def test_what_the_executor_says_is_its_detail_and_a_log_line_handed_on_once():
    report = Report()
    report.say("action 1/3: push block 2")
    report.log("replanning")
    assert report.detail == "action 1/3: push block 2"
    assert report.take_log() == ["action 1/3: push block 2", "replanning"]
    assert report.take_log() == []


def test_the_worst_goal_errors_are_kept_in_millimetres_and_degrees_of_the_figures():
    report = Report()
    report.goal_errors([Deviation(1, 0.0004, math.radians(0.2)),
                        Deviation(2, 0.0001, math.radians(1.1))])
    assert report.metrics["final_pos_err_max_m"] == pytest.approx(0.0004)
    assert report.metrics["final_yaw_err_max_deg"] == pytest.approx(1.1)
    report.goal_errors([])
    assert report.metrics["final_pos_err_max_m"] == pytest.approx(0.0004)  # kept
