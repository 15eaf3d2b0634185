"""The planner's reach check: the UR10e's own IK decides, a scene out of reach is refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py import BlockPose, Goal, GoalSlot, MessageError, PickPlace, Scene, Workspace
from msgs_py.cell import ACTION_HEIGHTS
from nodes.common.transforms import tool_down_matrix
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import check_goal, plan_goal
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.reach import ur10e_reach
from nodes.planner.geometry.transfer import push_tcp_path
from nodes.sim.kinematics import solve_tcp_ik

S = 0.0508
CONFIG = PlannerConfig(budget_s=20.0)


def ik_reaches(x: float, y: float, z: float, yaw: float) -> bool:
    t = np.eye(4)
    t[:3, :3] = tool_down_matrix(yaw)
    t[:3, 3] = (x, y, z)
    return solve_tcp_ik(t, np.zeros(6)).ok


def test_the_reach_annulus_agrees_with_the_arms_ik_at_every_action_height():
    reach = ur10e_reach()
    rng = np.random.default_rng(4)
    for _ in range(150):
        r = rng.uniform(0.0, 1.6)
        a, yaw = rng.uniform(-math.pi, math.pi, 2)
        x, y = r * math.cos(a), r * math.sin(a)
        inside = bool(reach.contains((x, y)))
        by_ik = all(ik_reaches(x, y, z, yaw) for z in ACTION_HEIGHTS)
        margin = min(abs(r - reach.r_min), abs(r - reach.r_max))
        if margin > 0.011:  # the annulus is the IK's, shrunk by a 1 cm safety margin
            assert inside == by_ik, (x, y, yaw)
        elif inside:
            assert by_ik


def test_a_straight_carry_past_the_base_is_out_of_reach():
    reach = ur10e_reach()
    assert reach.segment((0.8, 0.4), (0.8, -0.4))
    assert not reach.segment((0.6, 0.05), (-0.6, -0.05))  # through the column of the base


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
    scene = scene_with((1.10, 0.0), (0.95, 0.35))  # the workspace runs out to 2.8 m
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
            assert all(ik_reaches(x, y, z, 0.3) for z in ACTION_HEIGHTS), (a, x, y)


def test_the_heights_reach_is_checked_at_are_the_executors():
    from nodes.executor.config import ExecutorConfig

    cfg = ExecutorConfig()
    executor = (cfg.push_height, cfg.grasp_height, cfg.grasp_height + cfg.place_drop,
                cfg.travel_height)
    assert executor == ACTION_HEIGHTS
