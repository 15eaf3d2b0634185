"""No wasted action: nothing that ends where it started, no detour a plan does without, and
the enclosed-centre case of a dense grid in a handful of actions."""

from __future__ import annotations

import math

from msgs_py import BlockPose, Goal, GoalSlot, GridSpec, PickPlace, Plan, Pose2D, Push, Scene
from msgs_py.scene import Workspace
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import plan_goal
from nodes.planner.geometry.context import same_pose
from nodes.planner.geometry.validator import validate_plan
from nodes.planner.passes.necessity import drop_no_ops, necessary_actions

S = 0.0508
WS = Workspace(0.40, 1.00, -0.30, 0.30)
PARAMS = PlannerConfig().to_params(S)
A, B, C = Pose2D(0.5, 0.0, 0.0), Pose2D(0.5, 0.2, 0.0), Pose2D(0.8, 0.0, 0.0)


def scene(blocks, goals, yaw_exact=False) -> Scene:
    slots = tuple(GoalSlot(p.x, p.y, p.theta, b) for b, p in goals.items())
    return Scene(WS, S, tuple(BlockPose(b, p.x, p.y, p.theta) for b, p in blocks.items()),
                 Goal(slots=slots, yaw_exact=yaw_exact))


def test_a_turn_by_a_quarter_or_a_half_in_place_is_a_no_op_unless_yaw_exact():
    half = Pose2D(A.x, A.y, math.pi)
    assert same_pose(A, half, yaw_exact=False)
    assert same_pose(A, Pose2D(A.x, A.y, 0.5 * math.pi), yaw_exact=False)
    assert not same_pose(A, half, yaw_exact=True)
    assert not same_pose(A, Pose2D(A.x + 1e-3, A.y, 0.0), yaw_exact=False)


def test_the_validator_refuses_an_action_that_does_nothing():
    turn = PickPlace(0, A, Pose2D(A.x, A.y, math.pi), 0)
    loose = scene({0: A}, {0: A})
    report = validate_plan(Plan(actions=(turn,), params=PARAMS, scene=loose))
    assert report.errors == ("action 0: block 0 ends where it started",)
    exact = scene({0: A}, {0: Pose2D(A.x, A.y, math.pi)}, yaw_exact=True)
    assert validate_plan(Plan(actions=(turn,), params=PARAMS, scene=exact)).ok


def test_no_ops_are_dropped_and_the_blocks_later_moves_follow():
    sc = scene({0: A}, {0: C})
    turned = Pose2D(A.x, A.y, 0.5 * math.pi)
    plan = [PickPlace(0, A, turned, 0), PickPlace(0, turned, C, 1)]
    out = drop_no_ops(sc, plan)
    assert len(out) == 1 and out[0].from_ == A
    assert validate_plan(Plan(actions=tuple(out), params=PARAMS, scene=sc)).ok


def test_a_detour_and_an_away_and_back_are_not_needed():
    sc = scene({0: A, 1: B}, {0: C, 1: B})
    plan = [PickPlace(0, A, Pose2D(0.7, 0.2, 0.3), 0), PickPlace(1, B, Pose2D(0.9, 0.2, 0.0), 0),
            PickPlace(1, Pose2D(0.9, 0.2, 0.0), B, 0), PickPlace(0, Pose2D(0.7, 0.2, 0.3), C, 0)]
    assert validate_plan(Plan(actions=tuple(plan), params=PARAMS, scene=sc)).ok
    out = necessary_actions(sc, PARAMS, plan)
    assert [(a.block, a.to) for a in out] == [(0, C)]
    assert validate_plan(Plan(actions=tuple(out), params=PARAMS, scene=sc)).ok


def enclosed_centre() -> Scene:
    """A 3x3 grid with 3 mm gaps, every block on its slot but the centre's, which stands
    outside the grid."""
    goal = Goal(grid=GridSpec(3, 3, (0.70, 0.0), 0.0, 0.003))
    slots = goal.slot_poses(S)
    blocks = [BlockPose(k, p.x, p.y, p.theta) for k, p in enumerate(slots) if k != 4]
    blocks.insert(4, BlockPose(4, 0.55, 0.20, 0.3))
    return Scene(WS, S, tuple(blocks), goal)


def test_the_enclosed_centre_takes_at_most_six_actions_and_none_is_wasted():
    sc = enclosed_centre()
    for seed in range(3):
        out = plan_goal(sc, PlannerConfig(budget_s=20.0, seed=seed))
        assert out.ok, out.error
        actions = out.plan.actions
        assert len(actions) <= 6, [(a.type, a.block) for a in actions]
        assert out.lower_bound == 4  # one neighbour away and back, the centre pushed in
        assert any(isinstance(a, Push) and a.block == 4 for a in actions)
        assert not any(same_pose(a.from_, a.to, False) for a in actions)
        assert validate_plan(out.plan).ok
