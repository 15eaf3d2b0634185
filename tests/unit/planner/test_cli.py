"""densepack-plan writes a validated plan and a drawing, and names bad input."""

from __future__ import annotations

from msgs_py import load_plan, save_scene
from nodes.common.paths import config_path
from nodes.common.scenes import random_scene
from nodes.planner.cli import main
from nodes.planner.geometry.validator import validate_plan


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
