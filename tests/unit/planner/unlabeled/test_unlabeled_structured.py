"""Structured unlabeled scenes: a slot walled in by filled slots, a grid with one hole."""

from __future__ import annotations

from nodes.bench.instances import instance
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.unlabeled.config import UnlabeledConfig
from nodes.planner.unlabeled.plan_unlabeled import plan_unlabeled

CONFIG = PlannerConfig(budget_s=20.0)


def test_a_walled_in_centre_is_filled_by_sliding_a_neighbour_in():
    # a 3x3 grid built but for its centre, whose block stands outside: a neighbour is pushed
    # into the centre and the outside block takes the neighbour's slot on the edge
    scene = instance("enclosed", 9, 0.2, seed=0, labeled=False)
    out = plan_unlabeled(scene, CONFIG, UnlabeledConfig())
    assert out.ok, out.error
    assert len(out.plan.actions) == out.lower_bound == 3
    assert validate_plan(out.plan).ok


def test_a_full_grid_but_one_hole_needs_only_the_hole_filled():
    scene = instance("permuted", 9, 0.2, seed=0, labeled=False)
    out = plan_unlabeled(scene, CONFIG, UnlabeledConfig())
    assert out.ok, out.error
    assert len(out.plan.actions) == out.lower_bound
    assert validate_plan(out.plan).ok
