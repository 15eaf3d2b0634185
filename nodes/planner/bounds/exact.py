"""Exact search for small instances: the fewest actions over a fixed set of poses.

What the benchmarks measure the planners' optimality gap against (up to ``MAX_BLOCKS``
blocks, goals without ``yaw_exact``). A block may stand on: its start; any goal slot
(labeled: its own); a pose on a push line into each slot and out of each start, at
``LINE_STEPS`` block sizes; buffers on a fixed lattice (``BUFFER_STEP`` block sizes, the
goal's yaw) over the workspace, clear of every slot. Poses are footprints (the cube's 90-degree
symmetry). A state is the pose of every block (unlabeled: the set of occupied poses); a move
takes one block to another pose of the set by one action with the other blocks where they
stand: a pick-and-place with any free grasp axis at each end, or a push along a line.

Every per-pose test is done once, by ``transfer`` with the planner's footprints, against all
poses at once (boolean matrices); A* then searches on the number of actions with the
certified lower bound (``bound.Relaxation``) of each state as its heuristic, so the first goal
taken off the queue is optimal for this pose set. The result is realised as msgs_py actions
(``pick_place_between``) for the replay validator.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from msgs_py import Pose2D, Push
from msgs_py.actions import Action
from msgs_py.footprint import block_corners, face_normals
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import INF
from nodes.planner.bounds.pose_search import ExactLimit as ExactLimit  # re-exported
from nodes.planner.bounds.pose_search import NoShorterPlan as NoShorterPlan  # re-exported
from nodes.planner.bounds.pose_search import PoseSearch
from nodes.planner.geometry.context import at_pose
from nodes.planner.geometry.obstacles import Obstacles, mask_to_bools, words
from nodes.planner.geometry.transfer import (
    FOOTPRINT_PERIOD,
    grasp_checks,
    pick_place_between,
    push_checks,
    push_line,
)

MAX_BLOCKS = 5
LINE_STEPS = (0.5, 1.0, 2.0)
BUFFER_STEP = 1.5
#: Most buffer poses on that lattice (the moves are tested between every pair of poses).
BUFFER_MAX = 400


@dataclass(frozen=True)
class ExactResult:
    actions: list[Action]
    expansions: int
    poses: int  # size of the pose set


class PoseSet:
    """The fixed poses and every one-action test between them, as boolean matrices."""

    def __init__(self, ctx, poses: list[Pose2D]) -> None:
        self.ctx = ctx
        self.poses = poses
        p = len(poses)
        arr = np.array([[q.x, q.y, q.theta] for q in poses])
        self.arr = arr
        obstacles = Obstacles(list(range(p)), block_corners(
            arr[:, 0], arr[:, 1], arr[:, 2], ctx.geom.block_size), [True] * p,
            {k: k for k in range(p)}, words(p))
        grasps = grasp_checks(ctx, obstacles, arr)
        self.conflict = mask_to_bools(grasps.block_hit, p) | np.eye(p, dtype=bool)
        self.stand_ok = grasps.block_ok & self.ctx.reach.contains(arr[:, :2])
        self.fingers = mask_to_bools(grasps.fingers_hit, p)  # (P, 2, P)
        self.fingers_ok = grasps.fingers_ok
        self.carry_ok = ctx.reach.segment(arr[:, None, :2], arr[None, :, :2])
        self.pushes = self._pushes(obstacles)

    def _pushes(self, obstacles: Obstacles) -> dict[int, list[tuple[int, np.ndarray]]]:
        p = len(self.poses)
        i, j = np.nonzero(~np.eye(p, dtype=bool))
        on, d, length = push_line(self.arr[i], self.arr[j], FOOTPRINT_PERIOD)
        on &= length <= self.ctx.config.push_max_distance
        i, j, d, length = i[on], j[on], d[on], length[on]
        out: dict[int, list[tuple[int, np.ndarray]]] = {}
        if len(i):
            ok, hit = push_checks(self.ctx, obstacles, self.arr[i], d, length)
            sweep = mask_to_bools(hit, p)
            for k in np.flatnonzero(ok & self.stand_ok[j]):
                blocked = sweep[k].copy()
                blocked[i[k]] = False
                out.setdefault(int(i[k]), []).append((int(j[k]), blocked))
        return out

    def moves(self, state: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every one-action move as flat arrays: block index, pose, whether a push (a pose
        reached both ways is a pick-and-place). The other blocks' conflicts with each pose
        are counted once for the state, and each block's own taken off again."""
        ps = self
        here = np.array(state)
        conflicts = ps.conflict[:, here]  # (P, m): pose overlaps block i
        fingers = ps.fingers[:, :, here]  # (P, 2, m): fingers there hit block i
        free = (conflicts.sum(axis=1)[:, None] == conflicts) & ps.stand_ok[:, None]
        grips = ps.fingers_ok[:, :, None] & (fingers.sum(axis=-1)[:, :, None] == fingers)
        lift = grips[here, :, np.arange(len(here))].any(-1)  # (m,): a grasp where it stands
        reach = free & grips.any(axis=1) & ps.carry_ok[here].T & lift[None, :]
        reach[here, np.arange(len(here))] = False
        v, i = np.nonzero(reach)
        occupied = np.zeros(len(ps.poses), dtype=bool)
        occupied[here] = True
        pushes_i, pushes_v = [], []
        for k, u in enumerate(state):
            occupied[u] = False
            for w, blocked in ps.pushes.get(u, ()):
                if free[w, k] and not reach[w, k] and not occupied[blocked].any():
                    pushes_i.append(k)
                    pushes_v.append(w)
            occupied[u] = True
        blocks = np.concatenate([i, np.array(pushes_i, dtype=np.int64)])
        poses = np.concatenate([v, np.array(pushes_v, dtype=np.int64)])
        return blocks, poses, np.arange(len(blocks)) >= len(i)

    def axes(self, u: int, v: int, occupied: np.ndarray) -> tuple[int, int]:
        """Free grasp axes (at u, at v) for a pick-and-place u -> v."""
        def free(k: int) -> int:
            ok = self.fingers_ok[k] & ~(self.fingers[k] & occupied).any(-1)
            return int(np.argmax(ok))
        return free(u), free(v)


def pose_set(ctx, starts: list[Pose2D], slots: list[Pose2D]) -> list[Pose2D]:
    """Starts, slots, push-line poses into every slot and out of every start, buffers."""
    s = ctx.geom.block_size
    out = list(starts) + list(slots)
    for anchor, sign in [(q, -1.0) for q in slots] + [(q, 1.0) for q in starts]:
        for n in face_normals(anchor.theta):
            for step in LINE_STEPS:
                out.append(Pose2D(anchor.x + sign * n[0] * step * s,
                                  anchor.y + sign * n[1] * step * s, anchor.theta))
    w, yaw = ctx.workspace, slots[0].theta if slots else 0.0
    slot_feet = block_corners([q.x for q in slots], [q.y for q in slots],
                              [q.theta for q in slots], s)
    slot_obstacles = Obstacles(list(range(len(slots))), slot_feet, [False] * len(slots), {})
    xy = w.lattice(s, BUFFER_STEP * s, BUFFER_MAX)
    feet = block_corners(xy[:, 0], xy[:, 1], np.full(len(xy), yaw), s)
    clear = ~slot_obstacles.query(feet[:, None])[0]
    out += [Pose2D(float(x), float(y), yaw) for x, y in xy[clear]]
    arr = np.array([[q.x, q.y, q.theta] for q in out])
    stand = (ctx.workspace.contains(block_corners(arr[:, 0], arr[:, 1], arr[:, 2], s))
             & ctx.reach.contains(arr[:, :2]))
    stand[:len(starts) + len(slots)] = True
    return [q for q, ok in zip(out, stand, strict=True) if ok]


def _realize(ps: PoseSet, ids: list[int], start: Mapping[int, Pose2D],
             state: tuple[int, ...], moves: list[tuple[int, int, str]]) -> list[Action]:
    pose = {b: start[b] for b in ids}
    at = list(state)
    actions: list[Action] = []
    for i, v, kind in moves:
        block, u = ids[i], at[i]
        target = ps.poses[v]
        if kind == "push":
            act: Action = Push.between(block, pose[block], Pose2D(target.x, target.y,
                                                                  pose[block].theta))
        else:
            occupied = np.zeros(len(ps.poses), dtype=bool)
            occupied[[w for j, w in enumerate(at) if j != i]] = True
            axis_u, axis_v = ps.axes(u, v, occupied)
            act = pick_place_between(block, pose[block], ps.poses[u].theta, target,
                                     axis_u, axis_v)
        actions.append(act)
        pose[block] = act.to
        at[i] = v
    return actions


@dataclass(frozen=True)
class PoseProblem:
    """One scene over its pose set: blocks (goal blocks first), the start state (a block on
    its goal stands on its goal's pose index), the goal slots' pose indices (labeled: slot k
    is block ``ids[k]``'s goal) and the layout reasoning of the slots."""

    ids: list[int]
    start: Mapping[int, Pose2D]
    poses: PoseSet
    state: tuple[int, ...]
    slots: list[int]
    labeled: bool
    assembly: Assembly

    def realize(self, moves: list[tuple[int, int, str]]) -> list[Action]:
        """(block index, pose index, kind) moves as msgs_py actions."""
        return _realize(self.poses, self.ids, self.start, self.state, moves)


def pose_problem(ctx, start: Mapping[int, Pose2D], goal_slots: list[Pose2D],
                 assignment: Mapping[int, int] | None) -> PoseProblem:
    """The scene over ``pose_set``; ``assignment`` (block id -> slot index) for a labeled
    goal, None for an unlabeled one."""
    named = sorted(assignment) if assignment is not None else sorted(start)
    ids = named + sorted(set(start) - set(named))  # blocks with a goal first
    starts = [start[b] for b in ids]
    ps = PoseSet(ctx, pose_set(ctx, starts, goal_slots))
    n_start = len(ids)
    slot_idx = [n_start + k for k in range(len(goal_slots))]
    cfg = ctx.config
    if assignment is not None:  # labeled: slot k of the problem is block ids[k]'s goal
        slots = [slot_idx[assignment[b]] for b in named]
        asm = Assembly(ctx, {k: goal_slots[assignment[b]] for k, b in enumerate(named)})
        # a block already on its goal stands on its goal's pose index
        state = tuple(slots[k] if k < len(named) and at_pose(
            starts[k], ps.poses[slots[k]], cfg.goal_tolerance_xy, cfg.goal_tolerance_yaw,
            False) else k for k in range(n_start))
    else:
        slots = slot_idx
        asm = Assembly(ctx, dict(enumerate(goal_slots)))
        taken: set[int] = set()
        fixed = []
        for k in range(n_start):
            on = next((s for s in slots if s not in taken and at_pose(
                starts[k], ps.poses[s], cfg.goal_tolerance_xy, cfg.goal_tolerance_yaw,
                False)), None)
            if on is not None:
                taken.add(on)
            fixed.append(on if on is not None else k)
        state = tuple(fixed)
    return PoseProblem(ids, dict(start), ps, state, slots, assignment is not None, asm)


def exact_plan(ctx, start: Mapping[int, Pose2D], goal_slots: list[Pose2D],
               assignment: Mapping[int, int] | None, max_expansions: int = 20000,
               max_blocks: int = MAX_BLOCKS, seconds: float | None = None,
               stop: Callable[[], bool] | None = None, upper: float = INF) -> ExactResult:
    """The fewest actions (over ``pose_set``) moving the blocks ``start`` onto the slots;
    ``assignment`` (block id -> slot index) for a labeled goal, None for an unlabeled one;
    with ``upper``, only a plan of fewer actions than that.

    Raises:
        ValueError: more than ``max_blocks`` blocks.
        NoShorterPlan: none has fewer than ``upper`` actions over the pose set.
        ExactLimit: no optimum proven within ``max_expansions`` or ``seconds``, or ``stop()``
            became true (or no plan in the set).
    """
    if len(start) > max_blocks:
        raise ValueError(f"the exact search takes at most {max_blocks} blocks, got "
                         f"{len(start)}")
    pp = pose_problem(ctx, start, goal_slots, assignment)
    search = PoseSearch(pp.poses, pp.state, pp.slots, pp.labeled, pp.assembly)
    moves, expansions = search.solve(max_expansions, seconds, stop, upper)
    return ExactResult(pp.realize(moves), expansions, len(pp.poses.poses))
