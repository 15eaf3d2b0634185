"""Snug buffer poses: beside each block at the snug gap, along the workspace's edges, and what
a crowded scene's clearing poses fall back to."""

from __future__ import annotations

import numpy as np

from msgs_py import BlockPose, Goal, GoalSlot, Scene, Workspace
from msgs_py.footprint import block_corners
from nodes.bench.instances import instance
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.transfer import grasp_checks
from nodes.planner.labeled.cell_pirs import CellPirs
from nodes.planner.labeled.snug import SNUG_GAP, snug_poses

S = 0.0508


def test_snug_poses_stand_beside_each_block_and_inside_the_workspace():
    blocks = (BlockPose(0, 0.70, 0.0, 0.3), BlockPose(1, 0.55, 0.15, 0.0))
    scene = Scene(Workspace(0.45, 0.95, -0.25, 0.25), S, blocks,
                  Goal(slots=(GoalSlot(0.80, -0.15, 0.0, 1),)))
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    state = {b.id: b.pose for b in blocks}
    poses = snug_poses(ctx, state, exclude=1)
    d = np.hypot(poses[:, 0] - 0.70, poses[:, 1] - 0.0)
    beside = poses[np.isclose(d, S + SNUG_GAP)]
    assert len(beside) == 4  # level with each face
    others = ctx.obstacles(state, exclude=(1,), movable=())
    assert grasp_checks(ctx, others, beside).block_ok.all()  # touching nothing
    corners = block_corners(poses[:, 0], poses[:, 1], poses[:, 2], S)
    edge = poses[~np.isclose(d, S + SNUG_GAP) & (d > S)]
    assert ctx.workspace.contains(block_corners(edge[:, 0], edge[:, 1], edge[:, 2], S)).all()
    assert len(corners) == len(poses)


def test_a_crowded_start_still_gets_clearing_poses():
    scene = instance("random", 49, 0.4, 2)  # random draws find no room here
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    goals = scene.goal_assignment()
    state = {b.id: b.pose for b in scene.blocks}
    space = CellPirs(ctx, goals, False, np.random.default_rng(0))
    free = [b for b in sorted(state)
            if grasp_checks(ctx, ctx.obstacles(state, exclude=(b,), movable=()),
                            np.array([[state[b].x, state[b].y, state[b].theta]])
                            ).fingers_ok.any()]
    poses = space.clear_poses(free[0], state, frozenset(), np.zeros((0, 4, 2)), 4)
    assert poses
    others = ctx.obstacles(state, exclude=(free[0],), movable=())
    arr = np.array([[p.x, p.y, p.theta] for p in poses])
    checks = grasp_checks(ctx, others, arr)
    assert checks.block_ok.all() and checks.fingers_ok.any(-1).all()


def test_clearing_poses_keep_off_the_last_free_grasp_of_a_block_still_to_move():
    # blocks 1, 2, 3 in a row 5 mm apart along x: each has only its y grasp free
    gap = 0.005
    blocks = (BlockPose(0, 0.55, -0.15, 0.0), BlockPose(1, 0.70, 0.0, 0.0),
              BlockPose(2, 0.70 + S + gap, 0.0, 0.0), BlockPose(3, 0.70 - S - gap, 0.0, 0.0))
    scene = Scene(Workspace(0.45, 0.95, -0.25, 0.25), S, blocks,
                  Goal(slots=(GoalSlot(0.85, -0.18, 0.0, 0),)))
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    state = {b.id: b.pose for b in blocks}
    space = CellPirs(ctx, scene.goal_assignment(), False, np.random.default_rng(0))
    others = ctx.obstacles(state, exclude=(0,), movable=())
    spare = space.last_grasps(0, state, frozenset(), others)
    assert spare is not None and len(spare.corners) == 3 * 2  # two fingers each
    poses = space.clear_poses(0, state, frozenset(), np.zeros((0, 4, 2)), 8)
    arr = np.array([[p.x, p.y, p.theta] for p in poses])
    feet = block_corners(arr[:, 0], arr[:, 1], arr[:, 2], S)
    assert not spare.query(feet[:, None])[0].any()
