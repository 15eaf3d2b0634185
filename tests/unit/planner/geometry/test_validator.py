"""The replay validator flags each kind of violation, and passes a clean plan."""

from __future__ import annotations

import dataclasses
import math

from msgs_py import BlockPose, Goal, GoalSlot, PickPlace, Plan, Pose2D, Push, Scene, Workspace
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.validator import validate_plan

S = 0.0508
WS = Workspace(0.40, 1.00, -0.30, 0.30)
PARAMS = PlannerConfig().to_params(S)


def scene(blocks, goals):
    return Scene(WS, S, tuple(BlockPose(i, *p) for i, p in blocks.items()),
                 Goal(slots=tuple(GoalSlot(*p, i) for i, p in goals.items())))


def check(sc, *actions, params=PARAMS):
    return validate_plan(Plan(actions=actions, params=dict(params), scene=sc))


def test_a_clean_pick_and_place_and_push_pass():
    sc = scene({0: (0.5, 0.0, 0.0)}, {0: (0.8, 0.1, 0.0)})
    a = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.7, 0.1, 0.0), 0)
    b = Push.between(0, Pose2D(0.7, 0.1, 0.0), Pose2D(0.8, 0.1, 0.0))
    assert check(sc, a, b).ok


def test_placing_onto_another_block_is_flagged():
    sc = scene({0: (0.5, 0.0, 0.0), 1: (0.8, 0.1, 0.0)}, {0: (0.8, 0.1 + S / 2, 0.0)})
    report = check(sc, PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.8, 0.1 + S / 2, 0.0), 0))
    assert any("overlaps block 1" in e for e in report.errors)


def test_fingers_landing_on_a_neighbour_are_flagged():
    # a neighbour 3 mm away on the +x side: grasp 0 (fingers along x) hits it, grasp 1 not
    sc = scene({0: (0.5, 0.0, 0.0), 1: (0.5 + S + 0.003, 0.0, 0.0)}, {0: (0.7, 0.0, 0.0)})
    bad = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.7, 0.0, 0.0), 0)
    good = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.7, 0.0, 0.0), 1)
    assert any("finger at pick overlaps block 1" in e for e in check(sc, bad).errors)
    assert check(sc, good).ok


def test_push_off_a_face_normal_or_through_a_block_is_flagged():
    sc = scene({0: (0.5, 0.0, 0.0), 1: (0.65, 0.0, 0.0)}, {0: (0.6, 0.05, 0.0)})
    diagonal = Push.between(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.6, 0.05, 0.0))
    assert any("not a face normal" in e for e in check(sc, diagonal).errors)
    sc2 = scene({0: (0.5, 0.0, 0.0), 1: (0.65, 0.0, 0.0)}, {0: (0.7, 0.0, 0.0)})
    through = Push.between(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.75, 0.0, 0.0))
    assert any("swept area overlaps block 1" in e for e in check(sc2, through).errors)


def test_pushing_fingertips_behind_the_block_must_be_free():
    # a block just behind the pushed one: the block's own sweep is free, the fingers' is not
    sc = scene({0: (0.5, 0.0, 0.0), 1: (0.5 - S - 0.005, 0.0, 0.0)}, {0: (0.6, 0.0, 0.0)})
    push = Push.between(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.6, 0.0, 0.0))
    assert any("fingertip" in e for e in check(sc, push).errors)


def test_wrong_start_pose_unknown_block_and_unreached_goal_are_flagged():
    sc = scene({0: (0.5, 0.0, 0.0)}, {0: (0.8, 0.1, 0.0)})
    wrong = PickPlace(0, Pose2D(0.52, 0.0, 0.0), Pose2D(0.8, 0.1, 0.0), 0)
    assert any("not at 'from'" in e for e in check(sc, wrong).errors)
    assert any("unknown block 5" in e for e in check(
        sc, PickPlace(5, Pose2D(0.5, 0.0, 0.0), Pose2D(0.8, 0.1, 0.0), 0)).errors)
    short = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.7, 0.1, 0.0), 0)
    assert any("off its goal" in e for e in check(sc, short).errors)


def test_goal_yaw_is_met_modulo_90_degrees():
    sc = scene({0: (0.5, 0.0, 0.0)}, {0: (0.8, 0.1, 0.0)})
    turned = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.8, 0.1, math.pi / 2), 0)
    assert check(sc, turned).ok


def test_fingers_off_the_table_and_a_too_wide_opening_are_flagged():
    sc = scene({0: (0.5, 0.0, 0.0)}, {0: (WS.x_min + S / 2, 0.0, 0.0)})
    edge = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(WS.x_min + S / 2, 0.0, 0.0), 0)
    no_table = dict(PARAMS, table_margin=0.0)
    assert any("leaves the table" in e for e in check(sc, edge, params=no_table).errors)
    assert check(sc, edge).ok  # with the default margin the table extends past the edge
    wide = dict(PARAMS, approach_clearance=0.02)
    assert any("stroke" in e for e in check(sc, edge, params=wide).errors)


def test_missing_params_are_reported():
    sc = scene({0: (0.5, 0.0, 0.0)}, {0: (0.5, 0.0, 0.0)})
    params = dataclasses.asdict(PlannerConfig())
    assert not validate_plan(Plan(actions=(), params=params, scene=sc)).ok


def test_first_error_stops_the_replay_at_the_first_bad_action():
    """A pass that only asks whether a plan variant is valid stops at its first violation;
    the full replay lists every one."""
    sc = scene({0: (0.5, 0.0, 0.0), 1: (0.8, 0.1, 0.0)}, {0: (0.8, 0.1 + S / 2, 0.0)})
    onto = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.8, 0.1 + S / 2, 0.0), 0)
    stale = PickPlace(1, Pose2D(0.9, 0.1, 0.0), Pose2D(0.6, -0.1, 0.0), 0)  # not where 1 is
    plan = Plan(actions=(onto, stale), params=dict(PARAMS), scene=sc)
    full = validate_plan(plan)
    first = validate_plan(plan, first_error=True)
    assert any(e.startswith("action 1") for e in full.errors)
    assert first.errors and all(e.startswith("action 0") for e in first.errors)
    assert not first.ok
