"""A slot walled in on three sides (entered only by a push from the east), and helpers to
check hand-made plans on it: shared by the plan-improvement passes' tests."""

from __future__ import annotations

from msgs_py import BlockPose, Pose2D, Scene, Workspace
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.passes.shortcut import _replay

S = 0.0508
GAP = 0.003
WS = Workspace(0.40, 1.00, -0.30, 0.30)
G = Pose2D(0.70, 0.15, 0.0)  # walled in on the west, north and south: entered by a push
WALLS = (BlockPose(2, G.x - S - GAP, G.y, 0.0), BlockPose(4, G.x, G.y + S + GAP, 0.0),
         BlockPose(5, G.x, G.y - S - GAP, 0.0))


def ctx_and_start(blocks):
    scene = Scene(WS, S, tuple(blocks))
    return PlanContext.for_scene(scene, PlannerConfig()), {b.id: b.pose for b in blocks}


def feasible(ctx, start, plan) -> bool:
    return _replay(ctx, dict(start), plan) is not None
