"""The planner benchmark suite yields the design's rows and takes any planner parameter."""

from __future__ import annotations

import argparse

import pytest

from nodes.bench import planner as bench


def bench_parser() -> argparse.ArgumentParser:
    """The planner suite's options as ``densepack-bench planner`` parses them."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--seeds", type=int)
    bench.add_arguments(parser)
    return parser


def test_bench_rows_carry_the_design_figures():
    opts = bench_parser().parse_args(["--set", "random", "--n", "4", "--density", "low",
                                      "--seeds", "2"])
    rows = bench.run(opts)
    assert len(rows) == 1
    row = rows[0]
    for key in ("success_rate", "time_median_s", "time_p90_s", "actions_median",
                "actions_over_lower_bound_median"):
        assert key in row
    assert row["success_rate"] == 1.0 and row["actions_over_lower_bound_median"] >= 1.0
    per_seed = row["per_seed"]
    assert sorted(per_seed) == ["0", "1"]
    assert all(s["actions"] >= s["lower_bound"] for s in per_seed.values())
    assert row["scenes_within_lower_bound_plus_1"] == sum(
        s["actions"] - s["lower_bound"] <= 1 for s in per_seed.values())


def test_bench_param_overrides_any_parameter_and_names_a_bad_one(capsys):
    parser = bench_parser()
    base = ["--set", "random", "--n", "4", "--density", "low", "--seeds", "1", "--no-exact"]
    opts = parser.parse_args([*base, "--param", "improve_max_s=0", "--param", "a3=2.5"])
    row = bench.run(opts)[0]
    assert row["overrides"] == {"improve_max_s": 0, "a3": 2.5}
    assert row["success_rate"] == 1.0
    with pytest.raises(SystemExit):
        parser.parse_args([*base, "--param", "improve_max=3"])
    assert "NAME a planner parameter, got 'improve_max=3'" in capsys.readouterr().err
    with pytest.raises(SystemExit, match="improve_max_s"):
        bench.run(parser.parse_args([*base, "--param", "improve_max_s=-1"]))
