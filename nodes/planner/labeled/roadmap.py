"""The single-block PRM of Section III-B: sample poses, connect them with every feasible
pick-and-place (per grasp) and push, Dijkstra from the start to the target.

Which single actions are feasible, which movable blocks they hit and what they cost is
``transfer``'s business: pick-and-place feasibility splits per endpoint (fingers at the pick
pose; fingers and block at the place pose), so it is computed once per node and grasp and
combined for all pairs at once; Nc is the popcount of the OR of the hit masks. Push edges only
join poses of equal yaw on a line along a face normal, so they are searched within groups of
equal yaw (the push-line samples), and their swept areas are checked in one bulk query.
Samples whose block centre the arm cannot reach are dropped.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from msgs_py import PickPlace, Pose2D, Push
from msgs_py.actions import Action
from msgs_py.footprint import block_corners, face_normals, grasp_finger_corners, push_corners
from nodes.planner.geometry.context import PlanContext, State
from nodes.planner.geometry.obstacles import Obstacles, mask_to_ids, popcount
from nodes.planner.geometry.transfer import grasp_checks, push_checks, push_line
from nodes.planner.labeled.pirs import NoRoute, Route

#: Sampling gives up after this many rounds of rejection.
SAMPLE_ROUNDS = 8
#: Lengths (m) of the short pushes ("nudges") a block walled in where it stands gets along each
#: face normal: the push that slides it off its neighbours so that a grasp fits. Sampling
#: alone puts a few poses on the start's push lines, anywhere up to ``push_max_distance``,
#: and in a cramped scene none of them may be both reachable and graspable.
NUDGE_LENGTHS = (0.008, 0.015, 0.025, 0.04)
#: What the fixed blocks named in a failure are: not only placed ones (the search also holds
#: the block whose way is being cleared, and the blocks of the clearing chain, in place).
HELD = "that stay where they are for this move (placed, or held while their way is cleared)"


def sample_poses(ctx: PlanContext, obstacles: Obstacles, n: int, rng: np.random.Generator,
                 draw) -> np.ndarray:
    """``n`` poses (n, 3) from ``draw(rng, k) -> (k, 3)`` whose block lies inside the workspace,
    clear of fixed blocks and in the arm's reach (rejection sampling, fewer if it keeps
    failing)."""
    found: list[np.ndarray] = []
    have = 0
    for _ in range(SAMPLE_ROUNDS):
        if have >= n:
            break
        good = _standing(ctx, obstacles, draw(rng, 2 * (n - have) + 4))
        found.append(good[: n - have])
        have += len(found[-1])
    return np.concatenate(found) if found else np.zeros((0, 3))


def _standing(ctx: PlanContext, obstacles: Obstacles, cand: np.ndarray) -> np.ndarray:
    """The poses of ``cand`` (k, 3) where the block lies in the workspace, clear of fixed
    blocks, with its centre in the arm's reach."""
    corners = block_corners(cand[:, 0], cand[:, 1], cand[:, 2], ctx.geom.block_size)
    ok = ctx.workspace.contains(corners) & ctx.reach.contains(cand[:, :2])
    fixed, _ = obstacles.query(corners[:, None])
    return cand[ok & ~fixed]


def nudge_poses(ctx: PlanContext, obstacles: Obstacles, start: Pose2D) -> np.ndarray:
    """Where the short pushes of ``NUDGE_LENGTHS`` along each face normal take a block that
    cannot be grasped at ``start`` whatever moves first (each grasp's fingers hit a fixed
    block, or leave the table or the reach); none for a block that can: where only movable
    blocks cover its grasp, pIRS clears them, and they often have to move anyway (nudging
    instead cost random 9-block scenes at density 0.3 an action in 2 of 20)."""
    here = np.array([[start.x, start.y, start.theta]])
    if grasp_checks(ctx, obstacles, here).fingers_ok[0].any():
        return np.zeros((0, 3))
    normals = np.repeat(face_normals(start.theta), len(NUDGE_LENGTHS), axis=0)
    return _standing(ctx, obstacles, _along(start, normals, np.tile(NUDGE_LENGTHS, 4)))


def _along(anchor: Pose2D, directions: np.ndarray, distances: np.ndarray) -> np.ndarray:
    """Poses (k, 3) ``distances`` from ``anchor`` along ``directions`` (k, 2), at its yaw: the
    poses a push of ``anchor``'s block reaches."""
    return np.column_stack([anchor.x + distances * directions[:, 0],
                            anchor.y + distances * directions[:, 1],
                            np.full(len(distances), anchor.theta)])


def uniform_draw(ctx: PlanContext):
    w = ctx.workspace

    def draw(rng: np.random.Generator, k: int) -> np.ndarray:
        return np.column_stack([rng.uniform(w.x_min, w.x_max, k), rng.uniform(w.y_min, w.y_max, k),
                                rng.uniform(-math.pi, math.pi, k)])
    return draw


def line_draw(ctx: PlanContext, anchor: Pose2D, towards: bool):
    """Poses on the push lines through ``anchor`` (same yaw): push *into* the anchor
    (``towards``) or out of it."""
    normals = face_normals(anchor.theta)
    sign = -1.0 if towards else 1.0
    lo = min(0.005, ctx.config.push_max_distance)

    def draw(rng: np.random.Generator, k: int) -> np.ndarray:
        d = normals[rng.integers(0, 4, k)]
        return _along(anchor, sign * d, rng.uniform(lo, ctx.config.push_max_distance, k))
    return draw


def plan_route(ctx: PlanContext, block: int, state: State, target: Pose2D,
               movable: frozenset[int], rng: np.random.Generator, exact_yaw: bool = False
               ) -> Route | NoRoute:
    """Cheapest roadmap path moving ``block`` from its pose in ``state`` to ``target``.

    Blocks in ``movable`` (O_R) may be hit (counted in Nc, returned as O_b); all other blocks
    are fixed. Unless ``exact_yaw``, the target yaw + 90 degrees (same footprint) is a second
    target node: it lets the grasp that is free at the start set the block down along the
    other axis too, so no regrasp is ever needed just to change grasps (ties go to
    ``target``'s own yaw).
    """
    cfg = ctx.config
    start = state[block]
    obstacles = ctx.obstacles(state, exclude=(block,), movable=movable)
    kinds = rng.random(cfg.n_samples)
    n_goal = int(np.sum(kinds < cfg.eps))
    n_start = int(np.sum((kinds >= cfg.eps) & (kinds < cfg.eps + cfg.eps_start)))
    n_uniform = cfg.n_samples - n_goal - n_start
    ends = [[target.x, target.y, target.theta]]
    if not exact_yaw:
        ends.append([target.x, target.y, float(Pose2D(0, 0, target.theta + 0.5 * math.pi).theta)])
    nodes = np.concatenate([
        np.array([[start.x, start.y, start.theta], *ends]),
        sample_poses(ctx, obstacles, n_goal, rng, line_draw(ctx, target, towards=True)),
        sample_poses(ctx, obstacles, n_start, rng, line_draw(ctx, start, towards=False)),
        sample_poses(ctx, obstacles, n_uniform, rng, uniform_draw(ctx)),
        nudge_poses(ctx, obstacles, start),
    ])
    graph = _build_graph(ctx, nodes, obstacles)
    n_ends = len(ends)
    dist, prev = _dijkstra(graph.weight, source=0, targets=n_ends)
    end = 1 + int(np.argmin(dist[1:1 + n_ends]))
    if not math.isfinite(dist[end]):
        return _diagnose(ctx, graph, obstacles, nodes, n_ends)
    return _route(ctx, block, graph, nodes, prev, end, float(dist[end]))


@dataclass
class _Graph:
    weight: np.ndarray  # (M, M) cheapest edge cost, inf where none
    kind: np.ndarray  # (M, M) 0/1 grasp of the best pick-place, 2 push
    mask: np.ndarray  # (M, M, W) movable blocks hit by the best edge
    fingers_ok: np.ndarray  # (M, 2)
    block_ok: np.ndarray  # (M,)
    pushes: dict[tuple[int, int], tuple[float, float, float]]  # (i, j) -> dx, dy, L


def _build_graph(ctx: PlanContext, nodes: np.ndarray, obstacles: Obstacles) -> _Graph:
    m = len(nodes)
    grasps = grasp_checks(ctx, obstacles, nodes)
    ok, hit = grasps.pick_place(np.arange(m)[:, None], np.arange(m)[None, :], ctx.reach)
    moved = np.hypot(nodes[:, None, 0] - nodes[None, :, 0], nodes[:, None, 1] - nodes[None, :, 1])
    costs = np.where(ok, ctx.cost.pick_place(moved[..., None], popcount(hit)), np.inf)
    grasp = np.argmin(costs, axis=-1)  # (M, M): ties go to grasp 0
    weight = np.take_along_axis(costs, grasp[..., None], -1)[..., 0]
    mask = np.take_along_axis(hit, grasp[..., None, None], 2)[:, :, 0]
    np.fill_diagonal(weight, np.inf)
    graph = _Graph(weight, grasp.astype(np.int8), mask, grasps.fingers_ok, grasps.block_ok, {})
    _add_pushes(ctx, graph, nodes, obstacles)
    return graph


def _add_pushes(ctx: PlanContext, graph: _Graph, nodes: np.ndarray, obstacles: Obstacles
                ) -> None:
    key = np.round(np.mod(nodes[:, 2], 2.0 * math.pi) * 1e9).astype(np.int64)
    order = np.argsort(key, kind="stable")
    groups = [g for g in np.split(order, np.flatnonzero(np.diff(key[order])) + 1) if len(g) > 1]
    if not groups:
        return
    i = np.concatenate([np.repeat(g, len(g)) for g in groups])
    j = np.concatenate([np.tile(g, len(g)) for g in groups])
    on_line, d, length = push_line(nodes[i], nodes[j])
    i, j, d, length = i[on_line], j[on_line], d[on_line], length[on_line]
    if not len(i):
        return
    ok, hit = push_checks(ctx, obstacles, nodes[i], d, length)
    cost = ctx.cost.push(length, popcount(hit))
    for n in np.flatnonzero(ok):
        a, b = i[n], j[n]
        if cost[n] < graph.weight[a, b]:
            graph.weight[a, b] = cost[n]
            graph.kind[a, b] = 2
            graph.mask[a, b] = hit[n]
            graph.pushes[(a, b)] = (d[n, 0], d[n, 1], length[n])


def _dijkstra(weight: np.ndarray, source: int, targets: int) -> tuple[np.ndarray, np.ndarray]:
    """Dense Dijkstra (O(M^2) numpy) until nodes 1..targets are settled; ties go to the
    lowest node index (deterministic)."""
    m = len(weight)
    dist = np.full(m, np.inf)
    prev = np.full(m, -1, dtype=np.int64)
    done = np.zeros(m, dtype=bool)
    dist[source] = 0.0
    for _ in range(m):
        open_dist = np.where(done, np.inf, dist)
        u = int(np.argmin(open_dist))
        if not math.isfinite(open_dist[u]):
            break
        done[u] = True
        if done[1:1 + targets].all():
            break
        alt = dist[u] + weight[u]
        better = (alt < dist) & ~done
        dist[better] = alt[better]
        prev[better] = u
    return dist, prev


def _route(ctx: PlanContext, block: int, graph: _Graph, nodes: np.ndarray, prev: np.ndarray,
           end: int, cost: float) -> Route:
    path = [end]
    while path[-1] != 0:
        path.append(int(prev[path[-1]]))
    path.reverse()
    actions: list[Action] = []
    blocked: list[int] = []
    region: list[np.ndarray] = []
    pose = Pose2D(*nodes[0])
    geom = ctx.geom
    for a, b in itertools.pairwise(path):
        kind = int(graph.kind[a, b])
        if kind == 2:
            dx, dy, length = graph.pushes[(a, b)]
            action: Action = Push.between(block, pose, Pose2D(nodes[b, 0], nodes[b, 1],
                                                              pose.theta))
            region.append(push_corners(geom, pose.x, pose.y, dx, dy, length).reshape(-1, 4, 2))
        else:
            to = Pose2D(*nodes[b])
            action = PickPlace(block, pose, to, kind)
            region.append(grasp_finger_corners(geom, pose.x, pose.y, pose.theta, kind)
                          .reshape(-1, 4, 2))
            region.append(grasp_finger_corners(geom, to.x, to.y, to.theta, kind).reshape(-1, 4, 2))
            region.append(block_corners(to.x, to.y, to.theta, geom.block_size).reshape(-1, 4, 2))
        for hit in mask_to_ids(graph.mask[a, b], ctx.ids):
            if hit not in blocked:
                blocked.append(hit)
        actions.append(action)
        pose = action.to
    return Route(tuple(actions), tuple(blocked), cost, pose, np.concatenate(region))


def _diagnose(ctx: PlanContext, graph: _Graph, obstacles: Obstacles, nodes: np.ndarray,
              n_ends: int) -> NoRoute:
    """Name the likeliest reason no path exists: the target or the start is walled in."""
    geom = ctx.geom
    tx, ty, tt = nodes[1]
    target_block = block_corners(tx, ty, tt, geom.block_size)[None]
    if not ctx.workspace.contains(target_block)[0]:
        return NoRoute("its target pose leaves the workspace")
    if not ctx.reach.contains(nodes[1, :2]):
        return NoRoute(f"its target pose is out of the arm's reach ({ctx.reach.describe()})")
    if not graph.block_ok[1]:
        ids = obstacles.fixed_ids_hit(target_block[:, None])
        return NoRoute(f"its target pose overlaps block(s) {ids} {HELD}", tuple(ids))
    if not np.isfinite(graph.weight[:, 1:1 + n_ends]).any():
        fingers = grasp_finger_corners(geom, tx, ty, tt, np.arange(2))
        ids = obstacles.fixed_ids_hit(fingers.reshape(1, -1, 4, 2))
        return NoRoute(f"no grasp or push reaches its target: fingers hit block(s) {ids} {HELD} "
                       "or leave the table, and no push lane into it is free", tuple(ids))
    if not ctx.reach.contains(nodes[0, :2]):
        return NoRoute(f"it stands out of the arm's reach ({ctx.reach.describe()})")
    if not np.isfinite(graph.weight[0]).any():
        sx, sy, st = nodes[0]
        fingers = grasp_finger_corners(geom, sx, sy, st, np.arange(2))
        ids = obstacles.fixed_ids_hit(fingers.reshape(1, -1, 4, 2))
        return NoRoute(f"it can be neither grasped nor pushed where it stands: fingers hit "
                       f"block(s) {ids} {HELD} or leave the table", tuple(ids))
    return NoRoute("no roadmap path from its pose to the target among "
                   f"{len(nodes) - 1 - n_ends} samples")
