"""A block walled in where it stands is nudged: a short push slides it off the neighbours
that block its grasp, then it is picked (roadmap.nudge_poses)."""

from __future__ import annotations

import numpy as np

from msgs_py import BlockPose, Goal, GoalSlot, PickPlace, Pose2D, Push, Scene, Workspace
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.labeled.roadmap import NUDGE_LENGTHS, nudge_poses, plan_route

S = 0.0508
C = (0.70, 0.0)
TARGET = Pose2D(0.55, -0.15, 0.0)


def hemmed_scene(neighbours: bool = True) -> Scene:
    """Block 0 with a block 3 mm off each side face, both shifted up so they cover the top
    5 mm of the side grasp's pads, and one 12 mm below it: no grasp is free and the only
    push is down, by less than 12 mm; 8 mm down, the side grasp clears both."""
    blocks = [BlockPose(0, *C, 0.0)]
    if neighbours:
        blocks += [BlockPose(1, C[0] + S + 0.003, C[1] + 0.006 + S / 2, 0.0),
                   BlockPose(2, C[0] - S - 0.003, C[1] + 0.006 + S / 2, 0.0),
                   BlockPose(3, C[0], C[1] - S - 0.012, 0.0)]
    return Scene(Workspace(0.45, 0.95, -0.25, 0.25), S, tuple(blocks),
                 Goal(slots=(GoalSlot(TARGET.x, TARGET.y, TARGET.theta, 0),)))


def context_and_state(scene: Scene) -> tuple[PlanContext, dict[int, Pose2D]]:
    return PlanContext.for_scene(scene, PlannerConfig()), {b.id: b.pose for b in scene.blocks}


def route_of_block_0(scene: Scene, seed: int):
    ctx, state = context_and_state(scene)
    return plan_route(ctx, 0, state, TARGET, frozenset(), np.random.default_rng(seed))


def test_a_hemmed_in_block_is_pushed_a_few_millimetres_clear_and_then_picked():
    for seed in range(3):
        route = route_of_block_0(hemmed_scene(), seed)
        kinds = [type(a) for a in route.actions]
        assert kinds == [Push, PickPlace], route
        nudge = route.actions[0]
        assert nudge.from_.distance_to(nudge.to) in NUDGE_LENGTHS
        assert nudge.to.y < C[1]  # down, the one free way
        assert route.blocked == ()


def nudges_of_block_0(scene: Scene, movable: tuple[int, ...] = ()) -> np.ndarray:
    ctx, state = context_and_state(scene)
    return nudge_poses(ctx, ctx.obstacles(state, exclude=(0,), movable=movable), state[0])


def test_only_a_block_that_no_clearing_lets_grasp_gets_nudge_poses():
    assert len(nudges_of_block_0(hemmed_scene(neighbours=False))) == 0  # a free grasp
    # neighbours pIRS may clear first: no nudge (they often have to move anyway)
    assert len(nudges_of_block_0(hemmed_scene(), movable=(1, 2, 3))) == 0
    poses = nudges_of_block_0(hemmed_scene())  # neighbours that stay: nudged
    assert 0 < len(poses) <= 4 * len(NUDGE_LENGTHS)
    assert np.allclose(poses[:, 2], 0.0)  # a push keeps the yaw
