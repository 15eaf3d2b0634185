"""Single actions between poses: what a pick-and-place or a push needs, and what it costs.

The one place that knows what makes one action feasible (docs/contracts.md) and
what it costs. The roadmap, the plan passes (shortcut, necessity), the goal-layout order,
the lower bound, the exact search and the unlabeled cell geometry all ask it, vectorised
over many poses at once:

* ``CostModel``: ``a1`` per pick-and-place, ``a2`` per push, ``a3`` per movable block hit,
  and with ``distance_cost`` ``a_dist`` per metre the block moves plus ``a_push_len`` per
  metre pushed (the paper's proposed terms).
* ``grasp_checks`` -> ``Grasps``: per pose and grasp, whether the fingers stand on the table,
  over a TCP position the arm reaches, off fixed blocks, and which movable blocks they hit;
  per pose, whether the block may stand there (workspace, fixed blocks) and what it hits. A
  pick-and-place u -> v with grasp g needs fingers g free at u and at v, the block free at v
  and a carry the arm can follow (``Grasps.pick_place``): feasibility splits per endpoint,
  so the roadmap combines all of its node pairs at once.
* ``push_line``: whether v lies on a push line of u (along a face normal, same yaw), and
  ``push_checks``: the swept block in the workspace, the fingertips on the table, the TCP's
  path in reach, the blocks the sweep hits.
* ``direct_transfers``: every single action between two poses, sorted by cost (the scalar
  form, for the passes that edit a plan).

Grasp g closes the fingers along the block's local x (0) or y (1) axis, as in a plan.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from msgs_py import PickPlace, Pose2D, Push
from msgs_py.actions import Action
from msgs_py.footprint import block_corners, face_normals, grasp_finger_corners, push_corners
from nodes.planner.geometry.obstacles import Obstacles, mask_to_ids

#: Tolerances for "on a push line": off-line distance (m), the shortest push (m), yaw (rad).
LINE_TOL = 1e-7
MIN_PUSH = 1e-4
YAW_TOL = 1e-9
#: Yaw period of a block's footprint (a cube looks the same turned a quarter turn):
#: ``push_line``'s period where poses stand for footprints, not a block's own yaw.
FOOTPRINT_PERIOD = 0.5 * math.pi
GRASPS = np.arange(2)


@dataclass(frozen=True)
class CostModel:
    """The edge cost: ``a1*[pick_place] + a2*[push] + a3*Nc`` (+ distance terms)."""

    a1: float
    a2: float
    a3: float
    per_metre: float = 0.0  # a_dist with distance_cost, else 0
    per_metre_pushed: float = 0.0  # a_dist + a_push_len with distance_cost, else 0

    @classmethod
    def of(cls, config) -> CostModel:
        """From a ``PlannerConfig``."""
        if not config.distance_cost:
            return cls(config.a1, config.a2, config.a3)
        return cls(config.a1, config.a2, config.a3, config.a_dist,
                   config.a_dist + config.a_push_len)

    def pick_place(self, moved, hits=0):
        """Cost of pick-and-places moving a block ``moved`` metres, hitting ``hits`` blocks."""
        return self.a1 + self.per_metre * moved + self.a3 * hits

    def push(self, length, hits=0):
        return self.a2 + self.per_metre_pushed * length + self.a3 * hits

    def action(self, action: Action) -> float:
        moved = action.from_.distance_to(action.to)
        return self.pick_place(moved) if isinstance(action, PickPlace) else self.push(moved)

    def plan(self, actions: Iterable[Action]) -> float:
        """A plan's cost (no collisions in a final plan)."""
        return float(sum(self.action(a) for a in actions))


def _xy(poses: np.ndarray) -> np.ndarray:
    return np.asarray(poses, dtype=float)[..., :2]


@dataclass(frozen=True)
class Grasps:
    """Grasp and set-down checks at K poses (see ``grasp_checks``)."""

    xy: np.ndarray  # (K, 2)
    fingers_ok: np.ndarray  # (K, 2): table, reach, no fixed block
    fingers_hit: np.ndarray  # (K, 2, W): movable blocks under the fingers
    block_ok: np.ndarray  # (K,): the block may stand here (workspace, no fixed block)
    block_hit: np.ndarray  # (K, W): movable blocks it overlaps

    def pick_place(self, i, j, reach) -> tuple[np.ndarray, np.ndarray]:
        """Pick-and-place from pose i to pose j (index arrays, broadcast) per grasp:
        ok (..., 2) and the movable blocks hit (..., 2, W)."""
        i, j = np.asarray(i), np.asarray(j)
        carry = reach.segment(self.xy[i], self.xy[j])
        ok = self.fingers_ok[i] & self.fingers_ok[j] & (self.block_ok[j] & carry)[..., None]
        hit = self.fingers_hit[i] | self.fingers_hit[j] | self.block_hit[j][..., None, :]
        return ok, hit


def grasp_checks(ctx, obstacles: Obstacles, poses: np.ndarray) -> Grasps:
    """Fingers of both grasps and the block itself at ``poses`` (K, 3) against ``obstacles``;
    fingers count as usable only where the TCP (the block's centre) is in the arm's reach."""
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    k = len(poses)
    x, y, th = poses[:, 0], poses[:, 1], poses[:, 2]
    fingers = grasp_finger_corners(ctx.geom, x[:, None], y[:, None], th[:, None], GRASPS)
    f_fixed, f_hit = obstacles.query(fingers.reshape(k * 2, 2, 4, 2))
    in_reach = ctx.reach.contains(poses[:, :2])
    fingers_ok = (~f_fixed.reshape(k, 2) & ctx.table.contains(fingers).all(-1)
                  & in_reach[:, None])
    blocks = block_corners(x, y, th, ctx.geom.block_size)
    b_fixed, b_hit = obstacles.query(blocks[:, None])
    block_ok = ~b_fixed & ctx.workspace.contains(blocks)
    return Grasps(poses[:, :2], fingers_ok, f_hit.reshape(k, 2, -1), block_ok, b_hit)


def push_line(starts: np.ndarray, ends: np.ndarray, period: float = 2.0 * math.pi
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Whether each end (K, 3) lies on a push line of its start (K, 3): along one of the
    start's face normals, at the same yaw (modulo ``period``: 2 pi for a block's own pose,
    pi/2 for footprints). Returns (on_line (K,), unit direction (K, 2), length (K,))."""
    starts = np.asarray(starts, dtype=float).reshape(-1, 3)
    ends = np.asarray(ends, dtype=float).reshape(-1, 3)
    v = ends[:, :2] - starts[:, :2]
    normals = face_normals(starts[:, 2])  # (K, 4, 2)
    along = np.einsum("kj,kij->ki", v, normals)
    cross = v[:, None, 0] * normals[..., 1] - v[:, None, 1] * normals[..., 0]
    best = np.argmax(along, axis=-1)
    rows = np.arange(len(starts))
    turn = np.remainder(ends[:, 2] - starts[:, 2] + 0.5 * period, period) - 0.5 * period
    ok = ((np.abs(turn) < YAW_TOL) & (np.abs(cross[rows, best]) < LINE_TOL)
          & (along[rows, best] > MIN_PUSH))
    return ok, normals[rows, best], along[rows, best]


def push_tcp_path(ctx, starts: np.ndarray, directions: np.ndarray, lengths: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Where the TCP lands behind each pushed block and where the push leaves it (K, 2)."""
    geom = ctx.geom
    d = np.asarray(directions, dtype=float)
    land = _xy(starts) - d * geom.push_tcp_offset
    end = land + d * (np.asarray(lengths, dtype=float) + geom.push_contact_depth)[..., None]
    return land, end


def push_checks(ctx, obstacles: Obstacles, starts: np.ndarray, directions: np.ndarray,
                lengths: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pushes of the blocks at ``starts`` (K, >=2) along unit ``directions`` (K, 2) by
    ``lengths`` (K,): ok (K,) and the movable blocks the sweep hits (K, W)."""
    starts = np.asarray(starts, dtype=float)
    d = np.asarray(directions, dtype=float).reshape(-1, 2)
    lengths = np.asarray(lengths, dtype=float).reshape(-1)
    sweep = push_corners(ctx.geom, starts[:, 0], starts[:, 1], d[:, 0], d[:, 1], lengths)
    fixed, hit = obstacles.query(sweep)
    inside = ctx.workspace.contains(sweep[:, 0]) & ctx.table.contains(sweep[:, 1:]).all(-1)
    reach = ctx.reach.segment(*push_tcp_path(ctx, starts, d, lengths))
    return ~fixed & inside & reach, hit


def pick_place_between(block: int, current: Pose2D, start_yaw: float, end: Pose2D,
                       axis_from: int, axis_to: int) -> PickPlace:
    """The pick-and-place of ``block`` standing at ``current`` whose fingers close along the
    world axis ``start_yaw + axis_from * 90 deg`` there and along ``end.theta + axis_to *
    90 deg`` at ``end``. A footprint repeats every quarter turn, so ``start_yaw`` and
    ``end.theta`` may be any yaw of the block's class; the block is set down at the yaw of
    ``end``'s class that needs the least turn."""
    quarter = 0.5 * math.pi
    alpha = start_yaw + axis_from * quarter
    grasp = round(math.remainder(alpha - current.theta, math.pi) / quarter) % 2
    beta = end.theta + axis_to * quarter - grasp * quarter
    yaw = current.theta + math.remainder(beta - current.theta, math.pi)
    return PickPlace(block, current, Pose2D(end.x, end.y, yaw), grasp)


@dataclass(frozen=True)
class DirectTransfer:
    """A feasible one-action move: ``kind`` "pick_place" (with ``grasp``) or "push"."""

    kind: str
    grasp: int | None
    hits: tuple[int, ...]  # movable blocks in the way (Nc = len)
    cost: float

    def action(self, block: int, start: Pose2D, end: Pose2D) -> Action:
        if self.kind == "push":
            return Push.between(block, start, end)
        return PickPlace(block, start, end, self.grasp)


def direct_transfers(ctx, occupied, start: Pose2D, end: Pose2D, movable: Iterable[int] = ()
                     ) -> list[DirectTransfer]:
    """Every single action taking a block from ``start`` to ``end`` among ``occupied``
    (block id -> pose, without the moving block). Blocks in ``movable`` may be hit (listed in
    ``hits``); any other overlap rules the action out. Sorted by cost."""
    obstacles = ctx.obstacles(occupied, exclude=(), movable=movable)
    poses = np.array([[start.x, start.y, start.theta], [end.x, end.y, end.theta]])
    ids_by_bit = ctx.ids
    moved = math.hypot(end.x - start.x, end.y - start.y)
    out: list[DirectTransfer] = []
    ok, hit = grasp_checks(ctx, obstacles, poses).pick_place(0, 1, ctx.reach)
    for g in np.flatnonzero(ok):
        hits = tuple(mask_to_ids(hit[g], ids_by_bit))
        out.append(DirectTransfer("pick_place", int(g), hits,
                                  ctx.cost.pick_place(moved, len(hits))))
    on_line, d, length = push_line(poses[:1], poses[1:])
    if on_line[0]:
        ok, hit = push_checks(ctx, obstacles, poses[:1], d, length)
        if ok[0]:
            hits = tuple(mask_to_ids(hit[0], ids_by_bit))
            out.append(DirectTransfer("push", None, hits,
                                      ctx.cost.push(float(length[0]), len(hits))))
    return sorted(out, key=lambda t: (t.cost, t.kind, t.grasp or 0))


__all__ = ["CostModel", "DirectTransfer", "Grasps", "direct_transfers", "grasp_checks",
           "pick_place_between", "push_checks", "push_line", "push_tcp_path"]
