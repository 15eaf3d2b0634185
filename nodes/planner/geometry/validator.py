"""Independent replay validator: does a plan, executed on its scene, obey the planar model?

Deliberately a separate code path from the planner's edge checks: footprints are built here
one action at a time with ``shapely.geometry.box`` + ``shapely.affinity`` (the planner uses
vectorised corner arithmetic), swept areas are convex hulls of the start and end footprints
(the planner builds swept rectangles directly), and every block other than the moving one is
an obstacle (the planner distinguishes fixed from movable). Geometry comes only from the
plan's own ``params``, so a plan read back from JSON is checked on its own.

For every action: the block exists and stands at ``from``; the action moves it (``to`` is not
``from`` again, yaw modulo 90 degrees unless yaw_exact); a pick-and-place's fingers at both
ends and its block at ``to`` overlap no other block, the open gripper fits the stroke; a
push goes along a face normal of the block, keeps the yaw, and the swept block and fingertips
overlap no other block; the block stays in the workspace and the fingers on the table. At
the end, every block with a goal stands on it (yaw modulo 90 degrees unless yaw_exact).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from shapely import affinity
from shapely.geometry import Polygon, box

from msgs_py import PickPlace, Plan, Pose2D, Push, Scene

#: Overlap area (m^2) tolerated between shapes: a little looser than the planner's 1e-9 so
#: floating-point differences between the two constructions never flag a planner-valid plan.
AREA_TOL = 1e-8
#: How far (m, rad) ``from`` may differ from the replayed pose (JSON round trips).
POSE_TOL = 1e-6
REQUIRED = ("block_size", "finger_thickness", "finger_width", "approach_clearance",
            "push_opening", "push_contact_depth", "table_margin", "stroke")


@dataclass(frozen=True)
class ValidationReport:
    errors: tuple[str, ...]
    final: dict[int, Pose2D]

    @property
    def ok(self) -> bool:
        return not self.errors


def _rect(cx: float, cy: float, yaw: float, length: float, width: float) -> Polygon:
    shape = box(-0.5 * length, -0.5 * width, 0.5 * length, 0.5 * width)
    shape = affinity.rotate(shape, yaw, origin=(0.0, 0.0), use_radians=True)
    return affinity.translate(shape, cx, cy)


class _Replay:
    def __init__(self, scene: Scene, params: Mapping[str, Any]) -> None:
        self.scene = scene
        self.p = {k: float(params[k]) for k in REQUIRED}
        w = scene.workspace
        self.workspace = box(w.x_min, w.y_min, w.x_max, w.y_max)
        m = self.p["table_margin"]
        self.table = box(w.x_min - m, w.y_min - m, w.x_max + m, w.y_max + m)
        self.poses = {b.id: b.pose for b in scene.blocks}
        self._squares: dict[int, tuple[Pose2D, Polygon]] = {}
        self._order = sorted(self.poses)
        self._row = {b: k for k, b in enumerate(self._order)}
        self._bounds = np.array([self.square(self.poses[b]).bounds for b in self._order]
                                ).reshape(-1, 4)
        self.errors: list[str] = []

    def square(self, pose: Pose2D) -> Polygon:
        s = self.p["block_size"]
        return _rect(pose.x, pose.y, pose.theta, s, s)

    def grasp_pads(self, pose: Pose2D, grasp: int) -> list[Polygon]:
        axis = pose.theta + grasp * 0.5 * math.pi
        r = 0.5 * self.p["block_size"] + self.p["approach_clearance"] \
            + 0.5 * self.p["finger_thickness"]
        return [_rect(pose.x + sign * r * math.cos(axis), pose.y + sign * r * math.sin(axis), axis,
                      self.p["finger_thickness"], self.p["finger_width"]) for sign in (1, -1)]

    def push_shapes(self, a: Push) -> tuple[Polygon, list[Polygon]]:
        s, w = self.p["block_size"], self.p["finger_width"]
        depth, t = self.p["push_contact_depth"], self.p["finger_thickness"]
        dx, dy = a.direction
        swept_block = self.square(a.from_).union(self.square(a.to)).convex_hull
        back = 0.5 * s + depth + 0.5 * w
        tcp0 = (a.from_.x - back * dx, a.from_.y - back * dy)
        tcp1 = (tcp0[0] + (a.distance + depth) * dx, tcp0[1] + (a.distance + depth) * dy)
        yaw, off = math.atan2(dy, dx), 0.5 * self.p["push_opening"] + 0.5 * t
        pads = []
        for sign in (1, -1):
            ox, oy = -dy * off * sign, dx * off * sign
            ends = [_rect(cx + ox, cy + oy, yaw, w, t) for cx, cy in (tcp0, tcp1)]
            pads.append(ends[0].union(ends[1]).convex_hull)
        return swept_block, pads

    def standing(self, block: int) -> Polygon:
        """The footprint of a block where it stands (kept until it moves)."""
        pose = self.poses[block]
        known = self._squares.get(block)
        if known is None or known[0] != pose:
            known = (pose, self.square(pose))
            self._squares[block] = known
        return known[1]

    def moved(self, block: int, pose: Pose2D) -> None:
        self.poses[block] = pose
        self._bounds[self._row[block]] = self.standing(block).bounds

    def hits(self, k: int, moving: int, shape: Polygon, what: str) -> None:
        x0, y0, x1, y1 = shape.bounds
        b = self._bounds
        near = (b[:, 0] <= x1) & (b[:, 2] >= x0) & (b[:, 1] <= y1) & (b[:, 3] >= y0)
        for row in np.flatnonzero(near):  # bounding boxes apart: no overlap
            other = self._order[row]
            if other != moving and shape.intersection(self.standing(other)).area > AREA_TOL:
                self.errors.append(f"action {k}: {what} overlaps block {other}")

    def inside(self, k: int, shape: Polygon, region: Polygon, what: str) -> None:
        if shape.difference(region).area > AREA_TOL:
            self.errors.append(f"action {k}: {what} leaves the "
                               f"{'table' if region is self.table else 'workspace'}")

    def check_gripper(self) -> None:
        p = self.p
        if p["block_size"] + 2 * p["approach_clearance"] > p["stroke"] + 1e-12:
            self.errors.append("params: block_size + 2*approach_clearance exceeds the stroke")
        if 0.5 * p["push_opening"] + p["finger_thickness"] > 0.5 * p["block_size"] + 1e-12:
            self.errors.append("params: pushing fingertips would miss the rear face")
        if abs(p["block_size"] - self.scene.block_size) > 1e-12:
            self.errors.append("params: block_size differs from the scene's")

    def check_moves(self, k: int, a: PickPlace | Push) -> None:
        """An action whose block ends where it started (the cube looks the same every quarter
        turn) does nothing but cost time and risk."""
        goal = self.scene.goal
        period = 2 * math.pi if goal is not None and goal.yaw_exact else 0.5 * math.pi
        if (math.hypot(a.to.x - a.from_.x, a.to.y - a.from_.y) <= POSE_TOL
                and abs(math.remainder(a.to.theta - a.from_.theta, period)) <= POSE_TOL):
            self.errors.append(f"action {k}: block {a.block} ends where it started")

    def step(self, k: int, a: PickPlace | Push) -> None:
        if a.block not in self.poses:
            self.errors.append(f"action {k}: unknown block {a.block}")
            return
        now = self.poses[a.block]
        if (math.hypot(now.x - a.from_.x, now.y - a.from_.y) > POSE_TOL
                or abs(math.remainder(now.theta - a.from_.theta, 2 * math.pi)) > POSE_TOL):
            self.errors.append(f"action {k}: block {a.block} is at {now.to_dict()}, "
                               f"not at 'from' {a.from_.to_dict()}")
        self.check_moves(k, a)
        self.inside(k, self.square(a.to), self.workspace, f"block {a.block} at 'to'")
        if isinstance(a, PickPlace):
            for where, pose in (("pick", a.from_), ("place", a.to)):
                for pad in self.grasp_pads(pose, a.grasp):
                    self.hits(k, a.block, pad, f"a finger at {where}")
                    self.inside(k, pad, self.table, f"a finger at {where}")
            self.hits(k, a.block, self.square(a.to), f"block {a.block} at 'to'")
        else:
            normals = [a.from_.theta + q * 0.5 * math.pi for q in range(4)]
            dx, dy = a.direction
            if max(dx * math.cos(n) + dy * math.sin(n) for n in normals) < 1.0 - 1e-9:
                self.errors.append(f"action {k}: push direction is not a face normal")
            swept, pads = self.push_shapes(a)
            self.hits(k, a.block, swept, f"block {a.block}'s swept area")
            for pad in pads:
                self.hits(k, a.block, pad, "a pushing fingertip's sweep")
                self.inside(k, pad, self.table, "a pushing fingertip's sweep")
        self.moved(a.block, a.to)

    def check_goal(self, tol_xy: float, tol_yaw: float) -> None:
        goal = self.scene.goal
        if goal is None:
            return
        period = 2 * math.pi if goal.yaw_exact else 0.5 * math.pi
        for block, target in sorted(self.scene.goal_assignment().items()):
            pose = self.poses[block]
            off = math.hypot(pose.x - target.x, pose.y - target.y)
            dyaw = abs(math.remainder(pose.theta - target.theta, period))
            if off > tol_xy + 1e-9 or dyaw > tol_yaw + 1e-9:
                self.errors.append(f"end: block {block} is {off * 1000:.1f} mm / "
                                   f"{math.degrees(dyaw):.1f} deg off its goal")


    def check_slots_filled(self, tol_xy: float, tol_yaw: float) -> None:
        """Unlabeled goal: every slot holds some block (slots never overlap, so with
        tolerances far below a block size a block can stand on at most one slot)."""
        goal = self.scene.goal
        period = 2 * math.pi if goal.yaw_exact else 0.5 * math.pi
        for k, slot in enumerate(goal.slot_poses(self.scene.block_size)):
            if not any(math.hypot(p.x - slot.x, p.y - slot.y) <= tol_xy + 1e-9
                       and abs(math.remainder(p.theta - slot.theta, period)) <= tol_yaw + 1e-9
                       for p in self.poses.values()):
                self.errors.append(f"end: goal slot {k} is empty")


def validate_plan(plan: Plan, scene: Scene | None = None, first_error: bool = False
                  ) -> ValidationReport:
    """Replay ``plan`` on ``scene`` (default ``plan.scene``) and list every violation; with
    ``first_error``, stop at the first action that has one (a pass asking only whether a
    variant of a plan is valid rejects most variants early on)."""
    scene = scene if scene is not None else plan.scene
    if scene is None:
        return ValidationReport(("plan has no scene to replay on",), {})
    missing = [k for k in REQUIRED if k not in plan.params]
    if missing:
        return ValidationReport((f"params lack {missing}",), {})
    replay = _Replay(scene, plan.params)
    replay.check_gripper()
    for k, action in enumerate(plan.actions):
        replay.step(k, action)
        if first_error and replay.errors:
            return ValidationReport(tuple(replay.errors), dict(replay.poses))
    tol_xy = float(plan.params.get("goal_tolerance_xy", 0.0))
    tol_yaw = float(plan.params.get("goal_tolerance_yaw", 0.0))
    if scene.goal is not None and not scene.goal.labeled:
        replay.check_slots_filled(tol_xy, tol_yaw)
    else:
        replay.check_goal(tol_xy, tol_yaw)
    return ValidationReport(tuple(replay.errors), dict(replay.poses))
