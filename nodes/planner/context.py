"""What every single-block query of one planning run shares: geometry, bounds, id bits.

The world state during search is a plain ``dict[int, Pose2D]`` (block id -> pose) treated as
immutable (copied on write), so a failed branch of the search never leaks into another.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from msgs_py import Pose2D, Scene
from msgs_py.cell import GripperGeometry
from msgs_py.footprint import block_corners
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry import MAX_BLOCKS, Bounds, Obstacles

State = Mapping[int, Pose2D]


@dataclass(frozen=True)
class PlanContext:
    config: PlannerConfig
    geom: GripperGeometry
    workspace: Bounds
    table: Bounds
    ids: tuple[int, ...]

    @classmethod
    def for_scene(cls, scene: Scene, config: PlannerConfig) -> PlanContext:
        """Raises ValueError when the scene has more blocks than the masks hold."""
        config.check_block(scene.block_size)
        ids = tuple(sorted(scene.block_ids))
        if len(ids) > MAX_BLOCKS:
            raise ValueError(f"{len(ids)} blocks: the planner handles at most {MAX_BLOCKS}")
        w = scene.workspace
        workspace = Bounds(w.x_min, w.x_max, w.y_min, w.y_max)
        return cls(config, config.gripper(scene.block_size), workspace,
                   workspace.grown(config.table_margin), ids)

    @property
    def bit_of(self) -> dict[int, int]:
        return {block: k for k, block in enumerate(self.ids)}

    def obstacles(self, state: State, exclude: Iterable[int], movable: Iterable[int]
                  ) -> Obstacles:
        """Every block of ``state`` except ``exclude``; those in ``movable`` are in O_R."""
        skip, mov = set(exclude), set(movable)
        ids = [b for b in self.ids if b in state and b not in skip]
        poses = [state[b] for b in ids]
        corners = block_corners([p.x for p in poses], [p.y for p in poses],
                                [p.theta for p in poses], self.geom.block_size)
        return Obstacles(ids, corners.reshape(-1, 4, 2), [b in mov for b in ids], self.bit_of)


def at_pose(a: Pose2D, b: Pose2D, tol_xy: float, tol_yaw: float, yaw_exact: bool) -> bool:
    """Whether pose a stands on pose b (yaw modulo 90 degrees unless ``yaw_exact``)."""
    period = 2.0 * math.pi if yaw_exact else 0.5 * math.pi
    return (math.hypot(a.x - b.x, a.y - b.y) <= tol_xy
            and abs(math.remainder(a.theta - b.theta, period)) <= tol_yaw)


def nearest_goal_yaw(goal: Pose2D, start_theta: float, yaw_exact: bool) -> Pose2D:
    """The goal pose with the yaw of its 90-degree class nearest the start yaw (cube symmetry)."""
    if yaw_exact:
        return goal
    quarter = 0.5 * math.pi
    theta = start_theta + math.remainder(goal.theta - start_theta, quarter)
    return Pose2D(goal.x, goal.y, theta)
