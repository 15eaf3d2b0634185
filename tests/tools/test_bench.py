"""The benchmark front end: table formatting and suite dispatch."""

from __future__ import annotations

import math

from nodes.tools.bench import SUITES, _json_safe, format_table, main


def test_table_aligns_columns_and_marks_missing_figures():
    rows = [{"n": 4, "time_median_s": 0.123456}, {"n": 16, "time_median_s": math.nan}]
    table = format_table(rows, ["n", "time_median_s"])
    lines = table.splitlines()
    assert lines[0].split() == ["n", "time_median_s"]
    assert lines[2].split() == ["4", "0.1235"] and lines[3].split() == ["16", "-"]


def test_non_finite_figures_become_null_in_json():
    assert _json_safe({"a": [math.inf, 1.0]}) == {"a": [None, 1.0]}


def test_unknown_or_missing_suite_is_reported(capsys):
    assert main([]) == 2
    assert set(SUITES) == {"sim", "arm", "perception", "planner", "cell", "unlabeled",
                           "placement", "reference", "soak", "transport"}
