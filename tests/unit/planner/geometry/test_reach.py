"""The planner's use of the reach: a scene out of reach is refused by name, a workspace partly
out of it is planned within it."""

from __future__ import annotations

import numpy as np
import pytest

from msgs_py import BlockPose, Goal, GoalSlot, MessageError, PickPlace, Scene, Workspace
from msgs_py.cell import ACTION_HEIGHTS
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import check_goal, plan_goal
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.transfer import push_tcp_path
from nodes.robot.reach import working_branch_reaches

S = 0.0508
CONFIG = PlannerConfig(budget_s=20.0)


def scene_with(block: tuple[float, float], goal: tuple[float, float]) -> Scene:
    ws = Workspace(0.40, 2.80, -0.50, 0.50)
    blocks = (BlockPose(0, 0.60, 0.30, 0.0), BlockPose(3, *block, 0.2))
    slots = (GoalSlot(0.60, -0.30, 0.0, 0), GoalSlot(*goal, 0.0, 3))
    return Scene(ws, S, blocks, Goal(slots=slots))


def test_a_block_out_of_reach_is_refused_by_name():
    with pytest.raises(MessageError) as err:
        plan_goal(scene_with((2.50, 0.0), (0.80, 0.0)), CONFIG)
    assert err.value.field == "blocks[1]"
    assert "block 3 stands 2.50 m from the robot base" in str(err.value)


def test_a_goal_out_of_reach_is_refused_by_name():
    with pytest.raises(MessageError) as err:
        check_goal(scene_with((0.80, 0.0), (2.50, 0.0)))
    assert "the goal of block 3 lies 2.50 m" in str(err.value)


def test_a_workspace_partly_out_of_reach_is_planned_within_reach():
    scene = scene_with((1.00, 0.0), (0.95, 0.35))  # the workspace runs out to 2.8 m
    out = plan_goal(scene, CONFIG)
    assert out.ok, out.error
    ctx = PlanContext.for_scene(scene, CONFIG)
    for a in out.plan.actions:
        if isinstance(a, PickPlace):
            points = [(a.from_.x, a.from_.y), (a.to.x, a.to.y)]
        else:
            land, end = push_tcp_path(ctx, np.array([[a.from_.x, a.from_.y]]),
                                      np.array([a.direction]), np.array([a.distance]))
            points = [tuple(land[0]), tuple(end[0])]
        for x, y in points:
            assert all(working_branch_reaches(x, y, z, 0.3) for z in ACTION_HEIGHTS), (a, x, y)


def test_the_heights_reach_is_checked_at_are_the_executors():
    from nodes.executor.config import ExecutorConfig

    cfg = ExecutorConfig()
    executor = (cfg.push_height, cfg.grasp_height, cfg.grasp_height + cfg.place_drop,
                cfg.travel_height)
    assert executor == ACTION_HEIGHTS
