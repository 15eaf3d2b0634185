"""densepack-plan writes a validated plan and a drawing; the bench suite yields DESIGN rows."""

from __future__ import annotations

import argparse

import pytest

from msgs_py import load_plan, save_scene
from nodes.common.paths import config_path
from nodes.common.scenes import random_scene
from nodes.planner import bench
from nodes.planner.cli import main
from nodes.planner.validator import validate_plan


def test_plan_command_writes_a_valid_plan_and_a_png(tmp_path, capsys):
    out, png = tmp_path / "plan.json", tmp_path / "plan.png"
    assert main([str(config_path("scenes/default.yaml")), "-o", str(out), "--png", str(png),
                 "--seed", "3"]) == 0
    plan = load_plan(out)
    assert validate_plan(plan).ok and plan.seed == 3 and len(plan.actions) >= 9
    assert png.stat().st_size > 10_000 and png.read_bytes()[:4] == b"\x89PNG"
    assert "validated" in capsys.readouterr().out


def test_plan_command_reports_bad_input_and_no_plan(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nworkspace: {x_min: 0, x_max: 1, y_min: 0, y_max: 1}\n"
                   "blocks: [{id: 0, x: 0.5, y: 0.5}]\ngoal: {poses: [{id: 3, x: 0.2, y: 0.2}]}\n")
    assert main([str(bad)]) == 2
    assert "goal.poses[0].id" in capsys.readouterr().err
    scene = random_scene(4, 0.1, seed=0)
    path = tmp_path / "s.yaml"
    save_scene(scene, path)
    assert main([str(path), "--set", "n_samples=0", "--set", "eps=0.0",
                 "--budget", "2"]) in (0, 1)


def test_set_reaches_every_parameter_group_and_refuses_unknown_names(tmp_path, capsys):
    scene = str(config_path("scenes/unlabeled.yaml"))
    out = tmp_path / "plan.json"
    assert main([scene, "-o", str(out), "--set", "unlabeled.method=assignment"]) == 0
    assert load_plan(out).planner == "assignment_pirs"
    assert main([scene, "-o", str(out), "--method", "pebble_graphs",
                 "--set", "unlabeled.method=assignment"]) == 0
    assert load_plan(out).planner == "pebble_graphs"  # the flag wins over --set
    assert main([scene, "--set", "n_sample=3"]) == 2
    assert "unknown parameter(s) ['n_sample']" in capsys.readouterr().err


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
