"""One-action transfer queries (for the unlabeled planner) and unlabeled end-state checks."""

from __future__ import annotations

from msgs_py import BlockPose, Goal, GoalSlot, PickPlace, Plan, Pose2D, Scene, Workspace
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.transfer import direct_transfers
from nodes.planner.geometry.validator import validate_plan

S = 0.0508
WS = Workspace(0.40, 1.00, -0.30, 0.30)


def ctx_for(n: int) -> PlanContext:
    blocks = tuple(BlockPose(i, 0.45 + 0.06 * i, -0.25, 0.0) for i in range(n))
    return PlanContext.for_scene(Scene(WS, S, blocks), PlannerConfig())


def test_grasps_blocked_by_a_neighbour_are_left_out_and_movable_hits_listed():
    ctx = ctx_for(3)
    start, end = Pose2D(0.5, 0.0, 0.0), Pose2D(0.8, 0.0, 0.0)
    near = {1: Pose2D(0.5 + S + 0.003, 0.0, 0.0)}  # beside the start along x: grasp 0 blocked
    assert [t.grasp for t in direct_transfers(ctx, near, start, end)] == [1]
    both = direct_transfers(ctx, near, start, end, movable=[1])
    assert [(t.kind, t.grasp, t.hits) for t in both] == [
        ("pick_place", 1, ()), ("pick_place", 0, (1,)), ("push", None, (1,))]  # push goes through 1
    assert both[0].cost < both[1].cost


def test_a_push_along_a_face_normal_is_offered_and_a_diagonal_one_is_not():
    ctx = ctx_for(2)
    start = Pose2D(0.5, 0.0, 0.0)
    kinds = [t.kind for t in direct_transfers(ctx, {}, start, Pose2D(0.6, 0.0, 0.0))]
    assert sorted(kinds) == ["pick_place", "pick_place", "push"]
    kinds = [t.kind for t in direct_transfers(ctx, {}, start, Pose2D(0.6, 0.05, 0.0))]
    assert "push" not in kinds


def test_validator_checks_that_every_unlabeled_slot_is_filled():
    scene = Scene(WS, S, (BlockPose(0, 0.5, 0.0, 0.0), BlockPose(1, 0.8, 0.2, 0.0)),
                  Goal(slots=(GoalSlot(0.6, 0.0, 0.0), GoalSlot(0.8, 0.2, 0.0)), labeled=False))
    params = PlannerConfig().to_params(S)
    move = PickPlace(0, Pose2D(0.5, 0.0, 0.0), Pose2D(0.6, 0.0, 0.0), 1)
    assert validate_plan(Plan(actions=(move,), params=params, scene=scene)).ok
    report = validate_plan(Plan(actions=(), params=params, scene=scene))
    assert report.errors == ("end: goal slot 0 is empty",)


def test_a_finger_pad_flush_with_a_neighbour_is_refused_unless_the_clearance_is_zero():
    # the neighbour stands diagonally beside the place, its side 0.5 mm from where grasp 0's
    # pad would stand: a tenth of a millimetre of placement error makes them touch
    blocks = (BlockPose(0, 0.5, 0.1, 0.3), BlockPose(1, 0.8 + S + 0.003, -0.0369, 0.0))
    scene = Scene(WS, S, blocks)
    start, end = blocks[0].pose, Pose2D(0.8, 0.0, 0.0)  # not on a push line
    near = {1: blocks[1].pose}
    kept = PlanContext.for_scene(scene, PlannerConfig())
    assert [t.grasp for t in direct_transfers(kept, near, start, end)] == [1]
    flush = PlanContext.for_scene(scene, PlannerConfig(finger_clearance=0.0))
    assert sorted(t.grasp for t in direct_transfers(flush, near, start, end)) == [0, 1]
    # the plan's params keep the pads' own width (the executor and the validator use it)
    assert PlannerConfig().to_params(S)["finger_width"] == PlannerConfig().finger_width
