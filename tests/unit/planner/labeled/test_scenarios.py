"""Scenarios from the paper, planned end to end and checked by the replay validator."""

from __future__ import annotations

import dataclasses
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from msgs_py import BlockPose, Goal, GoalSlot, PickPlace, Plan, Push, Scene, Workspace
from nodes.common.scenes import random_scene
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.labeled.plan_labeled import plan_scene

S = 0.0508
PITCH = S + 0.003
CONFIG = PlannerConfig(budget_s=20.0)
WS = Workspace(0.40, 1.00, -0.30, 0.30)


def scene_of(blocks, goals, ws=WS, yaw_exact=False):
    slots = tuple(GoalSlot(x, y, th, i) for i, (x, y, th) in goals.items())
    return Scene(ws, S, tuple(BlockPose(i, *p) for i, p in blocks.items()),
                 Goal(slots=slots, yaw_exact=yaw_exact))


def plan_ok(scene, config=CONFIG) -> Plan:
    out = plan_scene(scene, config)
    assert out.ok, out.error
    report = validate_plan(Plan.from_dict(out.plan.to_dict()))  # replay the JSON form
    assert report.ok, report.errors
    return out.plan


def test_enclosed_goal_is_only_reached_by_a_push():
    # neighbours left, right and below already stand on their goals; only +y is open
    c = (0.70, 0.0)
    walls = {1: (c[0] - PITCH, c[1], 0.0), 2: (c[0] + PITCH, c[1], 0.0),
             3: (c[0], c[1] - PITCH, 0.0)}
    scene = scene_of({0: (0.50, 0.20, 0.4), **walls}, {0: (*c, 0.0), **walls})
    plan = plan_ok(scene)
    assert {a.block for a in plan.actions} == {0}  # the neighbours are never disturbed
    assert isinstance(plan.actions[-1], Push)
    assert plan.actions[-1].direction[1] < -0.99  # pushed in from +y, the only free side
    assert len(plan.actions) == 2


def test_grasp_blocked_at_start_and_other_grasp_blocked_at_goal_needs_a_regrasp():
    # yaw_exact: block 0 must keep yaw 0. At the start a neighbour sits on its +x side
    # (grasp 0 blocked), at the goal a neighbour sits on its +y side (grasp 1 blocked).
    start, goal = (0.55, -0.15), (0.80, 0.15)
    fixed = {1: (start[0] + PITCH, start[1], 0.0), 2: (goal[0], goal[1] + PITCH, 0.0)}
    scene = scene_of({0: (*start, 0.0), **fixed}, {0: (*goal, 0.0), **fixed}, yaw_exact=True)
    plan = plan_ok(scene)
    moves = [a for a in plan.actions if a.block == 0]
    assert len(plan.actions) >= 2
    if {a.block for a in plan.actions} == {0}:  # regrasped rather than clearing a neighbour
        assert all(isinstance(a, PickPlace) for a in moves)
        assert moves[0].grasp == 1 and moves[-1].grasp == 0
    assert math.remainder(moves[-1].to.theta, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)


def test_without_yaw_exact_the_cube_symmetry_saves_the_regrasp():
    start, goal = (0.55, -0.15), (0.80, 0.15)
    fixed = {1: (start[0] + PITCH, start[1], 0.0), 2: (goal[0], goal[1] + PITCH, 0.0)}
    scene = scene_of({0: (*start, 0.0), **fixed}, {0: (*goal, 0.0), **fixed})
    plan = plan_ok(scene)
    assert len(plan.actions) == 1 and plan.actions[0].grasp == 1


def test_two_blocks_standing_on_each_others_goal():
    a, b = (0.65, 0.0, 0.0), (0.65 + PITCH, 0.0, 0.0)
    scene = scene_of({0: a, 1: b}, {0: b, 1: a})
    plan = plan_ok(scene)
    assert 3 <= len(plan.actions) <= 4


def test_goal_already_reached_gives_an_empty_plan():
    poses = {0: (0.6, 0.0, 0.1), 1: (0.8, 0.1, -0.3)}
    rotated = {0: (0.6, 0.0, 0.1 + math.pi / 2), 1: (0.8, 0.1, -0.3)}  # yaw modulo 90 deg
    plan = plan_ok(scene_of(poses, rotated))
    assert plan.actions == ()


def test_unsolvable_layout_fails_naming_a_block_and_a_reason():
    # a corridor exactly two blocks long: the blocks cannot pass each other
    ws = Workspace(0.5, 0.5 + 2 * S + 0.002, 0.0, S + 0.002)
    left, right = (0.5 + S / 2, S / 2 + 0.001, 0.0), (0.5 + 1.5 * S + 0.002, S / 2 + 0.001, 0.0)
    scene = scene_of({0: left, 1: right}, {0: right, 1: left}, ws=ws)
    out = plan_scene(scene, dataclasses.replace(CONFIG, budget_s=5.0))
    assert not out.ok and out.plan is None
    assert out.failed_block in (0, 1)
    assert f"block {out.failed_block}" in out.error and len(out.error) > 20


def test_same_seed_same_plan():
    scene = random_scene(6, 0.15, seed=4)
    first, second = plan_scene(scene, CONFIG), plan_scene(scene, CONFIG)
    assert first.ok and second.ok
    assert first.plan.actions == second.plan.actions


def test_plan_carries_everything_needed_to_replay_it():
    plan = plan_ok(random_scene(4, 0.1, seed=1))
    for key in ("block_size", "finger_thickness", "finger_width", "approach_clearance",
                "push_opening", "push_contact_depth", "a1", "a2", "a3", "eps", "n_samples",
                "clear_goal_first", "distance_cost", "table_margin"):
        assert key in plan.params
    assert plan.scene is not None and plan.plan_id
    assert plan.params["block_size"] + 2 * plan.params["approach_clearance"] <= 0.085


def test_unlabeled_goals_are_refused_clearly():
    from msgs_py import MessageError

    scene = random_scene(4, 0.1, seed=0, labeled=False)
    with pytest.raises(MessageError, match="unlabeled"):
        plan_scene(scene, CONFIG)


@settings(max_examples=15)
@given(n=st.sampled_from([2, 4, 6, 9]), density=st.sampled_from([0.05, 0.12, 0.2]),
       seed=st.integers(0, 10_000))
def test_every_returned_plan_passes_the_validator(n, density, seed):
    scene = random_scene(n, density, seed)
    out = plan_scene(scene, dataclasses.replace(CONFIG, seed=seed))
    if out.ok:
        assert validate_plan(Plan.from_dict(out.plan.to_dict())).ok
    else:
        assert out.error


def test_more_blocks_than_a_64_bit_mask_holds_are_planned():
    from nodes.bench.instances import instance

    scene = instance("random", 70, 0.2, seed=0)  # a 7 x 10 grid
    out = plan_scene(scene, dataclasses.replace(CONFIG, budget_s=60.0))
    assert out.ok, out.error
    assert out.lower_bound <= len(out.plan.actions)
    assert validate_plan(Plan.from_dict(out.plan.to_dict())).ok
