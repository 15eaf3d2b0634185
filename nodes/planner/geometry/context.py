"""What every single-block query of one planning run shares: geometry, reach, costs, id bits.

The world state during search is a plain ``dict[int, Pose2D]`` (block id -> pose) treated as
immutable (copied on write), so a failed branch of the search never leaks into another.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cached_property

from msgs_py import MessageError, Pose2D, Scene
from msgs_py.cell import GripperGeometry
from msgs_py.footprint import block_corners
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.obstacles import Bounds, Obstacles, words
from nodes.planner.geometry.transfer import CostModel
from nodes.robot.reach import Reach, check_scene_reach, ur10e_reach

State = Mapping[int, Pose2D]
#: Poses closer than this (m, rad) are the same pose: an action between them does nothing.
SAME_POSE_TOL = 1e-6
#: Most blocks, and most goal slots, one scene may hold: twice the largest benchmark scene
#: (100 blocks plan in seconds); the footprint tests grow with the square of the count.
MAX_SCENE_BLOCKS = 200


def check_scene_size(scene: Scene) -> None:
    """Refuse a scene with more blocks or goal slots than ``MAX_SCENE_BLOCKS``, naming the
    field, before anything is built for it."""
    if len(scene.blocks) > MAX_SCENE_BLOCKS:
        raise MessageError("blocks", f"{len(scene.blocks)} blocks", f"the planner takes at "
                           f"most {MAX_SCENE_BLOCKS} blocks per scene")
    if scene.goal is not None and scene.goal.n_slots > MAX_SCENE_BLOCKS:
        raise MessageError("goal", f"{scene.goal.n_slots} slots", f"the planner takes at most "
                           f"{MAX_SCENE_BLOCKS} goal slots per scene")


def planning_workspace(scene: Scene, reach: Reach) -> tuple[Bounds, bool]:
    """The part of the scene's workspace the planner uses, and whether it is smaller: no block
    can stand beyond the arm's reach (every grasp and push puts the TCP over or behind it), so
    the workspace is clipped to the square around the reach; every lattice and sample drawn
    over it is then bounded by the arm, not by the scene file."""
    w = scene.workspace
    given = Bounds(w.x_min, w.x_max, w.y_min, w.y_max)
    r = reach.r_max
    used = given.clipped(Bounds(-r, r, -r, r))
    return used, used != given


@dataclass(frozen=True)
class PlanContext:
    config: PlannerConfig
    geom: GripperGeometry
    workspace: Bounds
    table: Bounds
    ids: tuple[int, ...]
    reach: Reach
    cost: CostModel

    @classmethod
    def for_scene(cls, scene: Scene, config: PlannerConfig) -> PlanContext:
        """Raises ValueError when the gripper does not fit the scene's blocks, MessageError
        when the scene holds too many blocks or a block or a goal slot is out of the arm's
        reach (naming it). The workspace is the part within the arm's reach
        (``planning_workspace``)."""
        check_scene_size(scene)
        config.check_block(scene.block_size)
        reach = ur10e_reach()
        check_scene_reach(scene, reach)
        workspace, _ = planning_workspace(scene, reach)
        return cls(config, config.gripper(scene.block_size), workspace,
                   workspace.grown(config.table_margin), tuple(sorted(scene.block_ids)),
                   reach, CostModel.of(config))

    @cached_property
    def bit_of(self) -> dict[int, int]:
        return {block: k for k, block in enumerate(self.ids)}

    @property
    def n_words(self) -> int:
        return words(len(self.ids))

    def obstacles(self, state: State, exclude: Iterable[int], movable: Iterable[int]
                  ) -> Obstacles:
        """Every block of ``state`` except ``exclude``; those in ``movable`` are in O_R."""
        skip, mov = set(exclude), set(movable)
        ids = [b for b in self.ids if b in state and b not in skip]
        poses = [state[b] for b in ids]
        corners = block_corners([p.x for p in poses], [p.y for p in poses],
                                [p.theta for p in poses], self.geom.block_size)
        return Obstacles(ids, corners.reshape(-1, 4, 2), [b in mov for b in ids], self.bit_of,
                         self.n_words)


def at_pose(a: Pose2D, b: Pose2D, tol_xy: float, tol_yaw: float, yaw_exact: bool) -> bool:
    """Whether pose a stands on pose b (yaw modulo 90 degrees unless ``yaw_exact``)."""
    period = 2.0 * math.pi if yaw_exact else 0.5 * math.pi
    return (math.hypot(a.x - b.x, a.y - b.y) <= tol_xy
            and abs(math.remainder(a.theta - b.theta, period)) <= tol_yaw)


def same_pose(a: Pose2D, b: Pose2D, yaw_exact: bool) -> bool:
    """Whether a block at a and at b looks the same (the cube's 90-degree symmetry unless
    ``yaw_exact``): an action from a to b would do nothing."""
    return at_pose(a, b, SAME_POSE_TOL, SAME_POSE_TOL, yaw_exact)


def nearest_goal_yaw(goal: Pose2D, start_theta: float, yaw_exact: bool) -> Pose2D:
    """The goal pose with the yaw of its 90-degree class nearest the start yaw (cube symmetry)."""
    if yaw_exact:
        return goal
    quarter = 0.5 * math.pi
    theta = start_theta + math.remainder(goal.theta - start_theta, quarter)
    return Pose2D(goal.x, goal.y, theta)
