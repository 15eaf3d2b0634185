"""A block a little off its goal in the middle of a dense grid can be neither grasped nor
pushed: the planner leaves it where it stands (within the near-goal tolerance) rather than
fail the blocks that still have somewhere to go."""

from __future__ import annotations

import dataclasses
import math

from msgs_py import BlockPose, Goal, GridSpec, Scene
from msgs_py.scene import Workspace
from nodes.planner.config import PlannerConfig
from nodes.planner.dispatch import plan_goal
from nodes.planner.geometry.validator import validate_plan

BLOCK = 0.0508
GRID = GridSpec(3, 3, (0.70, 0.0), 0.0, 0.003)
CONFIG = dataclasses.replace(PlannerConfig(), budget_s=20.0, near_goal_budget_s=1.0)


def grid_scene(centre_twist_deg: float) -> Scene:
    """Blocks 0-7 on their slots (the centre, block 4, twisted), block 8 off the grid."""
    slots = GRID.slot_poses(BLOCK)
    blocks = [BlockPose(k, p.x, p.y, p.theta + (math.radians(centre_twist_deg) if k == 4
                                                  else 0.0))
              for k, p in enumerate(slots[:8])]
    blocks.append(BlockPose(8, 0.55, 0.25, 0.4))
    return Scene(Workspace(0.45, 0.95, -0.35, 0.35), BLOCK, tuple(blocks), Goal(grid=GRID))


def test_a_walled_in_block_near_its_goal_is_left_and_the_rest_is_planned():
    outcome = plan_goal(grid_scene(1.8), CONFIG)
    assert outcome.ok, outcome.error
    assert {a.block for a in outcome.plan.actions} == {8}
    assert outcome.metrics["near_goal_left"] == 1.0
    assert validate_plan(outcome.plan).ok


def test_a_block_beyond_the_near_goal_tolerance_is_not_left():
    outcome = plan_goal(grid_scene(3.0), dataclasses.replace(CONFIG, budget_s=3.0))
    assert not outcome.ok
    assert "near_goal_left" not in outcome.metrics
