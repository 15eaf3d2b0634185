"""Seeded random scenes: n blocks scattered in a workspace sized for a density, and a grid goal.

Used by the sim's random scene generator and by every benchmark, so all of them draw the
same instances for the same (n, density, seed). Density = total block footprint area /
workspace area.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from msgs_py import BlockPose, Goal, GridSpec, Scene, Workspace
from msgs_py.cell import BLOCK_SIZE
from msgs_py.footprint import block_polygon

DEFAULT_CENTER = (0.70, 0.0)
MAX_ATTEMPTS_PER_BLOCK = 20_000


def workspace_for(
    n_blocks: int,
    density: float,
    block_size: float = BLOCK_SIZE,
    center: tuple[float, float] = DEFAULT_CENTER,
    aspect: float = 1.0,
) -> Workspace:
    """A workspace of area n s^2 / density, ``aspect`` = y extent / x extent, at ``center``."""
    if not 0.0 < density < 0.6:
        raise ValueError(f"density must be in (0, 0.6), got {density}")
    area = n_blocks * block_size**2 / density
    width = math.sqrt(area / aspect)
    height = area / width
    cx, cy = center
    return Workspace(cx - width / 2, cx + width / 2, cy - height / 2, cy + height / 2)


def grid_goal(
    n_blocks: int, workspace: Workspace, gap: float = 0.003, theta: float = 0.0,
    labeled: bool = True, center: tuple[float, float] | None = None,
) -> Goal:
    """The densest near-square grid for n blocks (rows x cols >= n, rows <= cols)."""
    cols = math.ceil(math.sqrt(n_blocks))
    rows = math.ceil(n_blocks / cols)
    if rows * cols != n_blocks:
        raise ValueError(f"{n_blocks} blocks do not fill a rows x cols grid exactly")
    return Goal(grid=GridSpec(rows, cols, center or workspace.center, theta, gap),
                labeled=labeled)


def scatter_blocks(
    n_blocks: int,
    workspace: Workspace,
    rng: np.random.Generator,
    block_size: float = BLOCK_SIZE,
    min_gap: float = 0.0,
    first_id: int = 0,
    reachable: Callable[[tuple[float, float]], bool] | None = None,
) -> tuple[BlockPose, ...]:
    """n non-overlapping blocks, uniform position and yaw, footprints inside the workspace
    and centres where ``reachable`` holds (the arm's reach: this package cannot know it, the
    caller passes it; a large workspace reaches past it in its far corners).

    Raises:
        RuntimeError: the workspace is too crowded to place them by rejection sampling.
    """
    placed: list[BlockPose] = []
    inflated = []
    for k in range(n_blocks):
        for _ in range(MAX_ATTEMPTS_PER_BLOCK):
            theta = float(rng.uniform(-math.pi, math.pi))
            x = float(rng.uniform(workspace.x_min, workspace.x_max))
            y = float(rng.uniform(workspace.y_min, workspace.y_max))
            candidate = BlockPose(first_id + k, x, y, theta)
            if not workspace.contains_square(candidate, block_size):
                continue
            if reachable is not None and not reachable((x, y)):
                continue
            poly = block_polygon(x, y, theta, block_size + 2 * min_gap)
            if any(poly.intersects(other) for other in inflated):
                continue
            placed.append(candidate)
            inflated.append(block_polygon(x, y, theta, block_size + 2 * min_gap))
            break
        else:
            raise RuntimeError(
                f"could not place block {k + 1} of {n_blocks} in {workspace} "
                f"(density {n_blocks * block_size**2 / workspace.area:.2f})"
            )
    return tuple(placed)


def random_scene(
    n_blocks: int,
    density: float,
    seed: int,
    block_size: float = BLOCK_SIZE,
    gap: float = 0.003,
    labeled: bool = True,
    center: tuple[float, float] = DEFAULT_CENTER,
    aspect: float = 1.0,
    min_gap: float = 0.002,
    reachable: Callable[[tuple[float, float]], bool] | None = None,
) -> Scene:
    """Random start -> dense grid goal, reproducible for (n_blocks, density, seed); block
    centres where ``reachable`` holds (``scatter_blocks``)."""
    workspace = workspace_for(n_blocks, density, block_size, center, aspect)
    rng = np.random.default_rng(seed)
    blocks = scatter_blocks(n_blocks, workspace, rng, block_size, min_gap,
                            reachable=reachable)
    return Scene(workspace, block_size, blocks, grid_goal(n_blocks, workspace, gap,
                                                          labeled=labeled))
