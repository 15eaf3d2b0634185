"""The reference-plan file: every plan in it replays valid on its own scene, the scene is the
benchmark's for its key, and each entry's figures agree with its plan."""

from __future__ import annotations

from nodes.bench.instances import instance
from nodes.bench.reference_file import REFERENCE_FILE, entry_plan, load_reference
from nodes.planner.geometry.validator import validate_plan


def test_every_reference_plan_validates_and_matches_its_entry():
    entries = load_reference()
    assert REFERENCE_FILE.exists() and entries
    for key, entry in entries.items():
        if entry["plan"] is None:  # no plan known (only bounds): nothing to replay
            assert entry["best_actions"] is None and entry["status"] == "bounded", key
            continue
        kind, n, density, seed = key.split("/")
        scene = instance(kind, int(n), float(density), int(seed))
        plan = entry_plan(entry)
        assert plan.scene.blocks == scene.blocks and plan.scene.goal == scene.goal, key
        report = validate_plan(plan, scene)
        assert report.ok, (key, report.errors)
        assert entry["best_actions"] == len(plan.actions) >= entry["lower_bound"], key
        if entry["status"] == "optimal":
            assert len(plan.actions) == entry["lower_bound"], key
        elif entry["status"] == "optimal_over_pose_set":
            assert len(plan.actions) == entry["pose_set_optimum"], key
        if entry["pose_set_optimum"] is not None:
            assert entry["pose_set_bound"] == entry["pose_set_optimum"], key
