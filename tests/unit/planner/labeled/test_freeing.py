"""What frees a block the chain of clears cannot free (a short push of a held neighbour), and
what shuts one in for good (``labeled.freeing``)."""

from __future__ import annotations

import numpy as np

from msgs_py import BlockPose, Goal, GoalSlot, Pose2D, Push, Scene, Workspace
from nodes.planner.budget import Budget
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.transfer import grasp_checks
from nodes.planner.labeled.cell_pirs import CellPirs
from nodes.planner.labeled.freeing import freeing_nudges, shut_in
from nodes.planner.labeled.pirs import Pirs
from nodes.planner.labeled.roadmap import NUDGE_LENGTHS

S = 0.0508
G = 0.003  # gap between neighbours: no finger fits
C = (0.70, 0.0)
SIDES = {"right": (S + G, 0.0), "left": (-S - G, 0.0), "top": (0.0, S + G),
         "bottom": (0.0, -S - G)}


def scene_of(around: dict[int, str], goals: dict[int, tuple[float, float]]) -> Scene:
    blocks = [BlockPose(0, *C, 0.0)] + [BlockPose(b, C[0] + SIDES[s][0], C[1] + SIDES[s][1], 0.0)
                                        for b, s in around.items()]
    slots = tuple(GoalSlot(x, y, 0.0, b) for b, (x, y) in goals.items())
    return Scene(Workspace(0.45, 0.95, -0.25, 0.25), S, tuple(blocks), Goal(slots=slots))


def setup(scene: Scene) -> tuple[PlanContext, dict[int, Pose2D]]:
    return PlanContext.for_scene(scene, PlannerConfig()), {b.id: b.pose for b in scene.blocks}


def grasp_free(ctx: PlanContext, state: dict[int, Pose2D], block: int) -> bool:
    p = state[block]
    others = ctx.obstacles(state, exclude=(block,), movable=())
    return bool(grasp_checks(ctx, others, np.array([[p.x, p.y, p.theta]])).fingers_ok[0].any())


# block 0 with 1 on its right (held by the search), 2 on top and 3 below (placed): no grasp
HEMMED = {1: "right", 2: "top", 3: "bottom"}
GOALS = {0: (0.55, -0.18), 1: (0.85, -0.18), 2: (C[0], C[1] + S + G), 3: (C[0], C[1] - S - G)}


def test_a_held_neighbour_is_pushed_a_little_aside_so_that_a_grasp_fits():
    ctx, state = setup(scene_of(HEMMED, GOALS))
    assert not grasp_free(ctx, state, 0)
    nudges = freeing_nudges(ctx, 0, state, held={1}, movable=())
    assert nudges
    for h, route in nudges:
        (push,) = route.actions
        assert h == 1 and isinstance(push, Push) and push.block == 1
        assert round(push.distance, 6) in NUDGE_LENGTHS
        assert abs(push.to.x - push.from_.x) < 1e-9  # along y: the side faces are free
        assert grasp_free(ctx, {**state, 1: route.end}, 0)
    # the blocks it may nudge are the held ones only (placed ones stay on their goal)
    assert freeing_nudges(ctx, 0, state, held=(), movable=()) == []
    # and none where nothing frees a grasp: a held neighbour boxed in itself
    ctx, state = setup(scene_of({**HEMMED, 4: "left"}, GOALS))
    assert freeing_nudges(ctx, 0, state, held={1}, movable=()) == []


def test_the_clearing_chain_nudges_the_block_it_holds_and_then_clears_the_hemmed_one():
    scene = scene_of(HEMMED, GOALS)
    ctx, state = setup(scene)
    space = CellPirs(ctx, scene.goal_assignment(), False, np.random.default_rng(0))
    search = Pirs(space, frozenset(GOALS), frozenset(), Budget.of(30.0))
    placed = frozenset({2, 3})
    region = np.zeros((0, 4, 2))
    # 1 is held (the block whose way is being cleared): only the nudge frees 0
    assert search.clear(0, frozenset(), dict(state), placed, region, 1, nudge=False) is None
    done = search.clear(0, frozenset(), dict(state), placed, region, 1)
    assert done is not None
    first = done.actions[0]
    assert isinstance(first, Push) and first.block == 1
    assert all(a.block == 0 for a in done.actions[1:]) and done.state[0] != state[0]
    assert search.stats.nudges >= 1


def test_a_placement_that_leaves_a_block_with_no_grasp_and_no_push_is_found():
    # 0 between placed blocks above and below, free on the left: it can still be pushed left
    # out of the gap (fingers behind its right face) or right; 1 placed on its right ends that
    scene = scene_of({1: "right", 2: "top", 3: "bottom"}, GOALS)
    ctx, after = setup(scene)
    before = {**after, 1: Pose2D(0.85, -0.18, 0.0)}
    goals = scene.goal_assignment()
    assert shut_in(ctx, goals, 1, before, after, {2, 3}, off_goal=[0]) == [0]
    # placed elsewhere, it shuts nothing in
    assert shut_in(ctx, goals, 1, after, before, {2, 3}, off_goal=[0]) == []
    # a block on its goal (not to move) is not counted
    assert shut_in(ctx, goals, 1, before, after, {2, 3}, off_goal=[]) == []


def test_a_block_is_not_cleared_onto_its_own_goal_where_it_would_shut_a_neighbour_in():
    # 1's goal is right beside 0, which placed blocks hold above and below: 1 standing there
    # (as it would, unplaced, until its turn) leaves 0 no grasp and no push
    goals = {**GOALS, 1: (C[0] + S + G, C[1])}
    base = scene_of({2: "top", 3: "bottom"}, {0: GOALS[0]})
    slots = tuple(GoalSlot(x, y, 0.0, b) for b, (x, y) in goals.items())
    scene = Scene(base.workspace, S, (*base.blocks, BlockPose(1, 0.85, 0.15, 0.0)),
                  Goal(slots=slots))
    ctx, state = setup(scene)
    space = CellPirs(ctx, scene.goal_assignment(), False, np.random.default_rng(0))
    region = np.zeros((0, 4, 2))
    assert space.clear_goal(1, state, frozenset({2, 3}), region) is None
    assert space.shuts_in(1, state, {**state, 1: space.goal_pose(1, state)},
                          frozenset({2, 3})) == [0]
    # with 2 and 3 not placed (they may still move), 0 is not shut in: the goal is offered
    assert space.clear_goal(1, state, frozenset(), region) is not None
