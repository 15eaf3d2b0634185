"""Scenes for the sim: load or generate them, and check they fit the cell.

A scene fits when its whole workspace lies on the table, inside the camera's image (with a
margin of a tag's size, so a tag at the border is still whole) and inside the arm's reach
with the gripper pointing down at grasp and transfer heights, at both grasp yaws.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from msgs_py import Scene, load_scene
from nodes.common.paths import config_path
from nodes.common.scenes import random_scene
from nodes.common.transforms import tool_down_matrix
from nodes.robot.kinematics import solve_tcp_ik
from nodes.robot.reach import ur10e_reach
from nodes.sim import robot_model as rm
from nodes.sim.camera import SimCamera

#: Random scenes are centred under the camera and shaped like the default workspace
#: (0.5 m along x by 0.7 m along y), so they stay in reach and in the camera's view.
RANDOM_CENTER = (0.70, 0.0)
RANDOM_ASPECT = 1.4
#: TCP heights at which every workspace corner must be reachable (grasp and transfer).
REACH_HEIGHTS = (0.010, 0.25)


def random_sim_scene(n_blocks: int, density: float, seed: int) -> Scene:
    """A seeded random scene for the cell, its blocks where the arm reaches them on its
    working branch (``nodes.robot.reach``: 25 blocks at density 0.1 run 1.14 m out in the
    workspace's far corners, past the branch's 1.05)."""
    return random_scene(n_blocks, density, seed, center=RANDOM_CENTER, aspect=RANDOM_ASPECT,
                        reachable=ur10e_reach().contains)


def load_sim_scene(scene_file: str, n_random: int = 0, density: float = 0.25,
                   seed: int = 0) -> Scene:
    """The scene the sim runs: random when ``n_random > 0``, else the scene file."""
    if n_random > 0:
        return random_sim_scene(n_random, density, seed)
    return load_scene(config_path(scene_file))


def scene_problems(scene: Scene, camera: SimCamera, q_ref) -> list[str]:
    """Why ``scene`` does not fit the cell (empty when it does)."""
    ws, s = scene.workspace, scene.block_size
    problems = []
    x0, x1, y0, y1 = rm.TABLE_EXTENT
    if ws.x_min < x0 or ws.x_max > x1 or ws.y_min < y0 or ws.y_max > y1:
        problems.append(f"workspace {ws.to_dict()} is not on the table {rm.TABLE_EXTENT}")
    corners = np.array([[x, y, s] for x in (ws.x_min, ws.x_max) for y in (ws.y_min, ws.y_max)])
    tag_px = camera.fx * rm.TAG_SIZE / float(np.max(camera.position[2] - corners[:, 2]))
    visible = camera.sees(corners, margin_px=tag_px)
    if not visible.all():
        problems.append(f"workspace corners {corners[~visible, :2].tolist()} are outside the "
                        f"camera image (margin {tag_px:.0f} px)")
    for (x, y, _), z, yaw in itertools.product(corners, REACH_HEIGHTS, (0.0, math.pi / 2)):
        t = np.eye(4)
        t[:3, :3] = tool_down_matrix(yaw)
        t[:3, 3] = (x, y, z)
        if not solve_tcp_ik(t, q_ref).ok:
            problems.append(f"workspace corner ({x:.3f}, {y:.3f}) is out of reach at "
                            f"TCP z = {z} m, yaw {math.degrees(yaw):.0f} deg")
            break
    return problems
