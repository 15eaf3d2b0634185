"""Anytime improvement: never longer than the first plan, always validated, within its budget."""

from __future__ import annotations

import dataclasses
import time

import pytest

from msgs_py import Plan
from nodes.bench.instances import instance
from nodes.planner.budget import Budget, OutOfTime
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.labeled.plan_labeled import plan_scene
from nodes.planner.passes.improve import ImproveSettings, improve


def test_the_improvement_budget_is_k_times_the_first_solve_between_its_floor_and_cap():
    s = ImproveSettings(factor=4.0, min_s=1.0, max_s=2.5)
    assert s.seconds(0.1) == 1.0
    assert s.seconds(0.5) == 2.0
    assert s.seconds(3.0) == 2.5
    assert ImproveSettings(4.0, 1.0, 0.0).seconds(0.5) == 0.0


def fake_solver(lengths):
    """Restart k returns a plan of lengths[k - 1] actions (None: no plan)."""
    calls = []

    def solve(k, jitter, budget):
        calls.append((k, jitter))
        n = lengths[k - 1] if k <= len(lengths) else 99
        return None if n is None else [f"r{k}a{i}" for i in range(n)]
    return solve, calls


def test_only_a_shorter_plan_the_validator_accepts_replaces_the_first():
    solve, calls = fake_solver([12, None, 9, 8, 11, 10, 10])
    rejected = {8}  # the validator refuses the 8-action plan
    out = improve(["a"] * 10, solve, lambda acts: len(acts) not in rejected,
                  Budget.of(0.05), lower_bound=5, first_s=0.0)
    assert len(out.best) == 9 and out.best[0].startswith("r3")
    assert out.better == 1 and out.rejected == 1 and out.tries == len(calls) >= 7
    assert out.metrics(10)["improve_saved"] == 1.0


def test_never_longer_than_the_first_whatever_the_restarts_give():
    solve, _ = fake_solver([15, 20, None, 11])
    out = improve(["a"] * 10, solve, lambda acts: True, Budget.of(0.02), 5, 0.0)
    assert len(out.best) == 10 and out.better == 0


def test_stops_at_the_lower_bound_and_restarts_differ():
    solve, calls = fake_solver([9, 7, 3])
    out = improve(["a"] * 10, solve, lambda acts: True, Budget.of(5.0), lower_bound=7,
                  first_s=0.0)
    assert len(out.best) == 7 and out.tries == 2
    assert len({k for k, _ in calls}) == 2 and {j for _, j in calls} != {0.0}


def test_respects_its_budget_and_starts_no_restart_that_cannot_finish():
    def slow(k, jitter, budget):
        end = time.monotonic() + 0.2
        while time.monotonic() < end:
            budget.check()
            time.sleep(0.01)
        return ["a"] * 9

    out = improve(["a"] * 10, slow, lambda acts: True, Budget.of(0.5), 1, first_s=0.2)
    assert out.tries == 2  # a third would start with 0.1 s left for a 0.2 s restart
    out = improve(["a"] * 10, slow, lambda acts: True, Budget.of(0.1), 1, first_s=0.2)
    assert out.tries == 0 and len(out.best) == 10


def test_a_restart_cut_off_by_the_budget_keeps_the_best_so_far():
    def cut(k, jitter, budget):
        raise OutOfTime

    out = improve(["a"] * 10, cut, lambda acts: True, Budget.of(1.0), 1, first_s=0.0)
    assert len(out.best) == 10 and out.tries == 1


@pytest.fixture(scope="module")
def nine_blocks():
    return instance("random", 9, 0.2, 0)


def test_on_a_nine_block_scene_the_improved_plan_is_validated_and_never_longer(nine_blocks):
    # restarts get 10 s, so at least one fits after a first solve slowed by a loaded machine
    base = PlannerConfig(budget_s=30.0, seed=0, improve_min_s=10.0, improve_max_s=10.0,
                         exact_after_max_blocks=0)  # the restarts alone
    first = plan_scene(nine_blocks, dataclasses.replace(base, improve_max_s=0.0))
    assert first.ok and first.metrics["improve_tries"] == 0.0
    better = plan_scene(nine_blocks, base)
    assert better.ok and validate_plan(Plan(actions=better.plan.actions,
                                            params=better.plan.params,
                                            scene=nine_blocks)).ok
    assert len(better.plan.actions) <= len(first.plan.actions)
    assert len(better.plan.actions) >= better.lower_bound
    assert better.metrics["improve_tries"] >= 1
