"""Benchmark instances: random, cramped and structured scenes for both planner benchmarks.

Every set is a dense grid goal (3 mm gaps, the most nearly square rows x cols = n) at the
centre of a square workspace sized for the density (block area / workspace area), seeded:

* ``random``: n blocks scattered uniformly (position and yaw), as
  ``nodes.common.scenes.random_scene`` draws them; at density 0.3 the workspace is cramped.
  A draw that leaves blocks *locked* (``frozen.locked_blocks``: no grasp fits them and no
  nudge frees one even with every other block gone, so no two-finger gripper could have set
  them down in any order) is no valid start and is drawn again, as a jammed draw is.
  Blocks stand where the arm reaches them on its working branch (``nodes.robot.reach``,
  1.05 m): a workspace whose far corners lie beyond (49 blocks at 0.3: 1.08 m; 100 at 0.3:
  1.25 m) gets no block there, where random_scene without ``reachable`` may put one; those
  seeds then differ from its scenes.
* ``enclosed``: the grid is built except for its interior slots on a checkerboard (the
  centre of a 3x3; two of the four inner slots of a 4x4; five of the nine of a 5x5), each
  walled in by four neighbours on their goals; those slots' blocks stand scattered outside
  the grid.
* ``rotated``: as ``random``, the grid turned by 45 degrees.
* ``permuted``: every block on the grid stands on another block's slot (a random
  derangement) and one slot is empty, its block outside the grid. (A dense grid with every
  slot full cannot be touched at all: no grasp fits and no fingertip gets behind a block.)

Unlabeled goals use the same blocks: for ``enclosed`` and ``permuted`` the blocks on the
grid already fill their slots, only the empty ones need a block.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from msgs_py import BlockPose, Goal, GridSpec, Pose2D, Scene, Workspace
from msgs_py.cell import BLOCK_SIZE
from msgs_py.footprint import block_corners, block_polygon, to_polygons
from msgs_py.scene import square_half_extent
from nodes.common.scenes import workspace_for
from nodes.planner.bounds.frozen import locked_blocks
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.obstacles import Bounds
from nodes.robot.reach import ur10e_reach

SETS = ("random", "enclosed", "rotated", "permuted")
GAP = 0.003
MIN_GAP = 0.002  # between scattered blocks and from the grid's slots, as random_scene
ATTEMPTS = 20_000
#: Lattice step (m) and yaws tried when the uniform draws jam (``gap_pose``).
GAP_STEP = 0.002
GAP_YAWS = 8
#: Fresh draws of a random scene whose blocks jam or lock before it fails (``_scattered``):
#: near density 0.4 most draws lock some blocks (49 blocks: 14 of the first 20).
REDRAWS = 30


def grid_shape(n: int) -> tuple[int, int]:
    """The most nearly square rows x cols = n (rows <= cols)."""
    rows = max(r for r in range(1, math.isqrt(n) + 1) if n % r == 0)
    return rows, n // rows


def grid_goal(n: int, workspace: Workspace, theta: float, labeled: bool) -> Goal:
    rows, cols = grid_shape(n)
    return Goal(grid=GridSpec(rows, cols, workspace.center, theta, GAP), labeled=labeled)


def enclosed_slots(rows: int, cols: int) -> list[int]:
    """Interior slots on a checkerboard (r + c even): each has four filled neighbours."""
    return [r * cols + c for r in range(1, rows - 1) for c in range(1, cols - 1)
            if (r + c) % 2 == 0]


def scatter(count: int, workspace: Workspace, taken: list[Pose2D], rng: np.random.Generator,
            ids: list[int]) -> list[BlockPose]:
    """``count`` blocks uniformly in the workspace (position and yaw, drawn as
    ``nodes.common.scenes.scatter_blocks`` draws them, so with nothing ``taken`` and every
    draw in reach the scenes are the same), MIN_GAP clear of ``taken`` and of each other,
    centres in the UR10e's reach (a 100-block workspace reaches beyond it).

    Raises:
        RuntimeError: no room for them.
    """
    s, reach = BLOCK_SIZE, ur10e_reach()
    walls = [block_polygon(p.x, p.y, p.theta, s + 2 * MIN_GAP) for p in taken]
    placed: list[BlockPose] = []
    grown = []
    for k in range(count):
        for _ in range(ATTEMPTS):
            theta = float(rng.uniform(-math.pi, math.pi))
            x = float(rng.uniform(workspace.x_min, workspace.x_max))
            y = float(rng.uniform(workspace.y_min, workspace.y_max))
            cand = BlockPose(ids[k], x, y, theta)
            if not workspace.contains_square(cand, s) or not reach.contains((x, y)):
                continue
            mine = block_polygon(x, y, theta, s + 2 * MIN_GAP)
            if any(mine.intersects(w) for w in walls) or any(mine.intersects(g) for g in grown):
                continue
            placed.append(cand)
            grown.append(mine)
            break
        else:  # rejection sampling has jammed: search the gaps left, on a fine lattice
            cand = gap_pose(ids[k], workspace, walls + grown, rng)
            if cand is None:
                raise RuntimeError(f"no room for block {ids[k]} in {workspace}")
            placed.append(cand)
            grown.append(block_polygon(cand.x, cand.y, cand.theta, s + 2 * MIN_GAP))
    return placed


def gap_pose(block: int, workspace: Workspace, taken: list, rng: np.random.Generator
             ) -> BlockPose | None:
    """A pose for ``block`` in a gap that uniform draws did not hit (dense scenes jam near
    density 0.4): every point of a ``GAP_STEP`` lattice over the workspace, in a random
    order, at ``GAP_YAWS`` random yaws, tested at once against what stands (``taken``,
    grown by MIN_GAP); None when no gap fits a block. Only reached where the draws of
    ``scatter`` fail, so scenes that drew before are unchanged."""
    s, reach = BLOCK_SIZE, ur10e_reach()
    ws = Bounds(workspace.x_min, workspace.x_max, workspace.y_min, workspace.y_max)
    tree = shapely.STRtree(taken)
    for theta in rng.uniform(-math.pi, math.pi, GAP_YAWS):
        half = square_half_extent(s, float(theta)) + 1e-6
        xy = ws.grown(-half + 0.5 * s).lattice(s, GAP_STEP, 10**6)
        xy = xy[reach.contains(xy)]
        if not len(xy):
            continue
        xy = xy[rng.permutation(len(xy))]
        feet = to_polygons(block_corners(xy[:, 0], xy[:, 1], np.full(len(xy), theta),
                                         s + 2 * MIN_GAP))
        hit = np.zeros(len(xy), dtype=bool)
        if len(taken):
            hit[tree.query(feet, predicate="intersects")[0]] = True
        for k in np.flatnonzero(~hit):
            cand = BlockPose(block, float(xy[k, 0]), float(xy[k, 1]), float(theta))
            if workspace.contains_square(cand, s):
                return cand
    return None


def _from_grid(n: int, density: float, seed: int, labeled: bool, empty: list[int],
               deranged: bool) -> Scene:
    """Blocks on the goal grid (their own slots, or deranged) but for ``empty`` slots, whose
    blocks are scattered outside."""
    rng = np.random.default_rng(seed)
    workspace = workspace_for(n, density)
    goal = grid_goal(n, workspace, 0.0, labeled)
    slots = goal.slot_poses(BLOCK_SIZE)
    owner = list(range(n))  # block standing on each slot
    if deranged:
        while any(owner[k] == k for k in range(n)):
            owner = [int(b) for b in rng.permutation(n)]
    on_grid = [BlockPose(owner[k], slots[k].x, slots[k].y, slots[k].theta)
               for k in range(n) if k not in empty]
    outside = scatter(len(empty), workspace, slots, rng, [owner[k] for k in empty])
    blocks = tuple(sorted(on_grid + outside, key=lambda b: b.id))
    return Scene(workspace, BLOCK_SIZE, blocks, goal)


def _scattered(n: int, workspace: Workspace, seed: int, goal: Goal) -> Scene:
    """n blocks scattered with the seed's generator; where they jam (no gap left for the
    last blocks, near density 0.4) or lock (``locked_blocks``), drawn again from the streams
    (seed, 1), (seed, 2), ... (``REDRAWS``): a seed that drew a valid start before keeps its
    scene.

    Raises:
        RuntimeError: no valid start in ``REDRAWS`` + 1 draws.
    """
    why = ""
    for redraw in range(REDRAWS + 1):
        rng = np.random.default_rng(seed if redraw == 0 else [seed, redraw])
        try:
            blocks = tuple(scatter(n, workspace, [], rng, list(range(n))))
        except RuntimeError as jam:
            why = str(jam)
            continue
        scene = Scene(workspace, BLOCK_SIZE, blocks, goal)
        ctx = PlanContext.for_scene(scene, PlannerConfig())
        locked = locked_blocks(ctx, {b.id: b.pose for b in blocks})
        if not locked:
            return scene
        why = f"blocks {locked} locked where they stand"
    raise RuntimeError(f"no valid start of {n} blocks in {workspace} in {REDRAWS + 1} draws "
                       f"(the last: {why})")


def instance(kind: str, n: int, density: float, seed: int, labeled: bool = True) -> Scene:
    """The scene of set ``kind`` with n blocks (slot k of a labeled grid is block k's).

    Raises:
        ValueError: an unknown set, or a grid that has no enclosed slot.
        RuntimeError: the blocks do not fit the workspace at that density.
    """
    if kind in ("random", "rotated"):
        workspace = workspace_for(n, density)
        theta = 0.25 * math.pi if kind == "rotated" else 0.0
        return _scattered(n, workspace, seed, grid_goal(n, workspace, theta, labeled))
    if kind == "enclosed":
        empty = enclosed_slots(*grid_shape(n))
        if not empty:
            raise ValueError(f"a {grid_shape(n)} grid has no enclosed slot")
        return _from_grid(n, density, seed, labeled, empty, deranged=False)
    if kind == "permuted":
        hole = int(np.random.default_rng(seed + 10_000).integers(n))
        return _from_grid(n, density, seed, labeled, [hole], deranged=True)
    raise ValueError(f"unknown instance set {kind!r}; sets: {SETS}")
