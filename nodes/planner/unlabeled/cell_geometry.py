"""The work cell as a transfer space: sites are block poses, transfers are gripper actions.

Footprints are the planner's (``nodes.planner.geometry``, DESIGN §6, docs/contracts.md): two
finger pads per grasp axis, a straight push sweeping the block and two fingertips. A transfer
of one block from site u to site v is one of

* ``pick_place``: pads at u (pick) and at v (place) on some grasp axis each;
* ``push``: u lies on a push line of v (same yaw modulo 90 degrees);
* ``place_push``: pick-and-place onto a transient pose p on a push line of v, then push p -> v
  (how a block gets into a slot whose neighbours leave no room for the fingers);
* ``push_place``: push u out to a transient p, then pick-and-place p -> v (how a block whose
  neighbours hide its faces gets out).

``transfers(nodes)`` lists those feasible when every other node holds a block (the RPG's
edges; computed in bulk with one STRtree query per batch of shapes), ``transfer(u, v,
occupied)`` the cheapest for an actual occupancy (smoothing, retrieval). Cost of a transfer:
``a1`` per pick-and-place, ``a2`` per push, plus the planner's distance terms.

Site yaws are kept as given; a block standing on a site may be turned by a multiple of 90
degrees from it (the footprint is the same), and ``realize`` turns a transfer into msgs_py
actions for the block's actual yaw.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from msgs_py import Pose2D, Push
from msgs_py.actions import Action
from msgs_py.cell import OVERLAP_AREA_TOL
from msgs_py.footprint import (
    block_corners,
    face_normals,
    grasp_finger_corners,
    overlapping_pairs,
    push_corners,
    to_polygons,
)
from msgs_py.poses import poses_to_array
from nodes.planner.context import PlanContext
from nodes.planner.transfer import pick_place_between
from nodes.planner.unlabeled.rpg import Site, Transfer

QUARTER = 0.5 * math.pi
#: Tolerances (m) for "u lies on a push line of v" and the shortest push.
LINE_TOL = 1e-7
MIN_PUSH = 1e-4
#: Candidate positions drawn per buffer request, plus a lattice of this step (block sizes)
#: over the whole workspace, so that crowded tables still yield the free spots they have.
BUFFER_CANDIDATES = 400
LATTICE_STEP = 0.125
#: How much (m) the zone is shrunk for the fast overlap test of buffer candidates.
ZONE_SHRINK = 1e-5
#: Smallest gap (m) between a buffer and any block.
MIN_BUFFER_GAP = 0.001


@dataclass(frozen=True)
class TransferPrimitive:
    """One primitive of a transfer, at site level: ``axis_from``/``axis_to`` pick the grasp
    axis (site yaw + axis * 90 degrees) at each end of a pick-and-place."""

    kind: str  # "pick_place" | "push"
    start: Pose2D
    end: Pose2D
    axis_from: int = 0
    axis_to: int = 0


class CellSpace:
    """Block poses in one scene's workspace and the transfers between them.

    Args:
        ctx: the planner's context (config, gripper geometry, workspace and table bounds).
        fixed: poses of blocks that are obstacles, never moved (e.g. a block being retrieved).
        push_lengths: transient push lengths tried, in block sizes, shortest first.
        buffer_yaw: yaw of buffer sites (rad), e.g. the goal grid's.
    """

    def __init__(self, ctx: PlanContext, fixed: Sequence[Pose2D] = (),
                 push_lengths: Sequence[float] = (0.5, 1.0), buffer_yaw: float = 0.0) -> None:
        self.ctx = ctx
        self.cfg = ctx.config
        self.geom = ctx.geom
        self.s = ctx.geom.block_size
        self.push_lengths = tuple(float(v) * self.s for v in push_lengths)
        self.buffer_yaw = buffer_yaw
        self.poses: list[Pose2D] = []
        self.footprints: list[Polygon] = []
        self.fixed = list(fixed)
        self.fixed_polys = list(self.footprints_of(self.fixed))
        self.zone: Polygon | None = None
        self.core: Polygon | None = None
        self._lattice_cache: tuple[np.ndarray, ...] | None = None
        self._zone_in: Polygon | None = None
        self._core_in: Polygon | None = None
        self.zone_slots: frozenset[Site] = frozenset()
        self._conflicts: dict[tuple[Site, Site], bool] = {}
        self._obstructs: dict[Site, bool] = {}
        self._transfer_cache: dict[tuple[Site, Site, tuple[Site, ...]], Transfer | None] = {}
        #: clearance (m) kept around buffers: the pads reach this far past a block's face.
        self.buffer_clearance = self.geom.approach_clearance + self.geom.finger_thickness + 0.002

    # --- sites -----------------------------------------------------------------------------
    def footprints_of(self, poses: Sequence[Pose2D]) -> np.ndarray:
        """Block footprint polygons at ``poses``."""
        arr = poses_to_array(poses)
        return to_polygons(block_corners(arr[:, 0], arr[:, 1], arr[:, 2], self.s))

    def add_site(self, pose: Pose2D) -> Site:
        self.poses.append(pose)
        self.footprints.append(self.footprints_of([pose])[0])
        return len(self.poses) - 1

    def pose(self, site: Site) -> Pose2D:
        return self.poses[site]

    def inside(self, pose: Pose2D) -> bool:
        corners = block_corners(pose.x, pose.y, pose.theta, self.s)
        return bool(self.ctx.workspace.contains(corners))

    def hits_fixed(self, pose: Pose2D) -> bool:
        foot = self.footprints_of([pose])[0]
        return any(foot.intersection(f).area > OVERLAP_AREA_TOL for f in self.fixed_polys)

    def conflicts(self, a: Site, b: Site) -> bool:
        key = (min(a, b), max(a, b))
        if key not in self._conflicts:
            fa, fb = self.footprints[a], self.footprints[b]
            self._conflicts[key] = a == b or fa.intersection(fb).area > OVERLAP_AREA_TOL
        return self._conflicts[key]

    def set_zone(self, zone: Polygon | None, slots: Collection[Site] = (),
                 core: Polygon | None = None) -> None:
        """Where blocks are in the goal's way unless on one of ``slots`` (``zone``), and where
        they must never be parked (``core``: the slots themselves)."""
        self.zone = zone
        self.core = core
        self._lattice_cache = None
        # shrunk a hair and prepared: "intersects" then means a real overlap, fast
        self._zone_in, self._core_in = (
            None if r is None else shapely.buffer(r, -ZONE_SHRINK, join_style="mitre")
            for r in (zone, core))
        for r in (self._zone_in, self._core_in):
            if r is not None:
                shapely.prepare(r)
        self.zone_slots = frozenset(slots)
        self._obstructs.clear()

    def _zone_flags(self, corners: np.ndarray, feet: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Candidate footprints: inside the workspace, in the zone, on a slot."""
        inside = self.ctx.workspace.contains(corners)
        in_zone = np.zeros(len(feet), dtype=bool)
        in_core = np.zeros(len(feet), dtype=bool)
        if self._core_in is not None:
            in_core = shapely.intersects(self._core_in, feet)
        if self._zone_in is not None:
            in_zone = shapely.intersects(self._zone_in, feet)
        return inside, in_zone, in_core

    def _lattice(self) -> tuple[np.ndarray, ...]:
        """Buffer candidates on a fixed lattice over the workspace, with their zone flags
        (computed once per zone)."""
        if self._lattice_cache is None:
            w, half = self.ctx.workspace, 0.5 * self.s
            xs = np.arange(w.x_min + half, w.x_max - half + 1e-9, LATTICE_STEP * self.s)
            ys = np.arange(w.y_min + half, w.y_max - half + 1e-9, LATTICE_STEP * self.s)
            xy = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
            yaw = np.full(len(xy), self.buffer_yaw)
            corners = block_corners(xy[:, 0], xy[:, 1], yaw, self.s)
            feet = to_polygons(corners)
            shapely.prepare(feet)
            self._lattice_cache = (xy, yaw, feet, *self._zone_flags(corners, feet))
        return self._lattice_cache

    def obstructs(self, site: Site) -> bool:
        if site not in self._obstructs:
            self._obstructs[site] = (
                self.zone is not None and site not in self.zone_slots
                and self.footprints[site].intersection(self.zone).area > OVERLAP_AREA_TOL)
        return self._obstructs[site]

    def overlaps(self, site: Site, region: Polygon) -> bool:
        return self.footprints[site].intersection(region).area > OVERLAP_AREA_TOL

    # --- transfers -------------------------------------------------------------------------
    def transfers(self, nodes: Sequence[Site]) -> list[Transfer]:
        """Every feasible transfer among ``nodes`` with all the other nodes occupied."""
        return _Batch(self, list(nodes)).transfers()

    @property
    def reach(self) -> float:
        """How far (m, centre to centre) a block may stand from u or v and still matter to a
        transfer u -> v: the longest transient push, the fingers behind it, a block's
        half-diagonal, with margin."""
        g = self.geom
        return (max(self.push_lengths) + 0.5 * self.s + g.push_contact_depth + g.finger_width
                + g.finger_offset + g.finger_thickness + math.sqrt(0.5) * self.s + 0.01)

    def nearby(self, sites: Collection[Site], anchors: Sequence[Site]) -> list[Site]:
        """The ``sites`` within ``reach`` of some anchor."""
        if not sites:
            return []
        cand = sorted(sites)
        xy = poses_to_array([self.poses[s] for s in cand])[:, :2]
        ref = poses_to_array([self.poses[a] for a in anchors])[:, :2]
        d = np.hypot(xy[:, None, 0] - ref[None, :, 0], xy[:, None, 1] - ref[None, :, 1])
        return [cand[k] for k in np.flatnonzero(d.min(axis=1) <= self.reach)]

    def transfer(self, u: Site, v: Site, occupied: frozenset[Site]) -> Transfer | None:
        """The cheapest transfer u -> v while the sites ``occupied`` hold blocks (only the
        blocks within reach matter, and the answer is cached on them)."""
        others = tuple(self.nearby(set(occupied) - {u, v}, (u, v)))
        key = (u, v, others)
        if key not in self._transfer_cache:
            if any(self.conflicts(v, o) for o in others) or self.hits_fixed(self.poses[v]):
                best = None
            else:
                found = _Batch(self, [u, v, *others]).transfers(pair=(0, 1))
                best = min(found, key=lambda t: (t.n_actions, t.cost)) if found else None
            self._transfer_cache[key] = best
        return self._transfer_cache[key]

    # --- buffers ---------------------------------------------------------------------------
    def buffers(self, nodes: Collection[Site], near: Sequence[Site], count: int,
                rng: np.random.Generator) -> list[Site]:
        """Up to ``count`` new sites clear of ``nodes`` and fixed blocks.

        Preferred, in turn: room for fingers all around (the pads reach
        ``buffer_clearance`` past a face) out of the goal zone, then in it; room for the
        fingers on one grasp axis, out of the zone, then in it; the roomiest spots left (at
        least 1 mm); on a slot, when nothing else is left (a crowded table). Within a tier,
        nearest to the sites ``near`` (short moves).
        """
        if count <= 0:
            return []
        w, half = self.ctx.workspace, 0.5 * self.s
        k = BUFFER_CANDIDATES
        # random candidates at any yaw (a turned block may fit a gap) and a fixed lattice
        # square to the goal, whose zone tests are cached
        rand_xy = np.column_stack([rng.uniform(w.x_min + half, w.x_max - half, k),
                                   rng.uniform(w.y_min + half, w.y_max - half, k)])
        rand_yaw = rng.uniform(-QUARTER / 2, QUARTER / 2, k) + self.buffer_yaw
        r_corners = block_corners(rand_xy[:, 0], rand_xy[:, 1], rand_yaw, self.s)
        r_feet = to_polygons(r_corners)
        r_ok, r_zone, r_core = self._zone_flags(r_corners, r_feet)
        l_xy, l_yaw, l_feet, l_ok, l_zone, l_core = self._lattice()
        xy = np.concatenate([rand_xy, l_xy])
        yaw = np.concatenate([rand_yaw, l_yaw])
        feet = np.concatenate([r_feet, l_feet])
        ok = np.concatenate([r_ok, l_ok])
        in_zone = np.concatenate([r_zone, l_zone])
        in_core = np.concatenate([r_core, l_core])
        blocks = [self.footprints[n] for n in nodes] + self.fixed_polys
        room = np.full(len(feet), np.inf)
        if blocks:
            room[ok] = shapely.distance(feet[ok], shapely.union_all(blocks))
        ok &= room >= MIN_BUFFER_GAP
        roomy = room >= self.buffer_clearance
        graspable = roomy.copy()
        tight = np.flatnonzero(ok & ~roomy & ~in_core)
        if len(tight) and blocks:
            pads = grasp_finger_corners(self.geom, xy[tight, 0, None], xy[tight, 1, None],
                                        yaw[tight, None], np.arange(2))  # (T, 2, 2, 4, 2)
            left, _ = shapely.STRtree(blocks).query(to_polygons(pads.reshape(-1, 4, 2)),
                                                    predicate="intersects")
            hit = np.zeros(len(tight) * 4, dtype=bool)
            hit[left] = True
            axis_free = ~hit.reshape(-1, 2, 2).any(-1) & self.ctx.table.contains(pads).all(-1)
            graspable[tight] = axis_free.any(-1)
        tier = np.select([in_core, roomy & ~in_zone, roomy, graspable & ~in_zone, graspable],
                         [5, 0, 1, 2, 3], 4)
        dist = np.zeros(len(feet))
        if near:
            ref = poses_to_array([self.poses[n] for n in near])[:, :2]
            dist = np.min(np.hypot(xy[:, None, 0] - ref[None, :, 0],
                                   xy[:, None, 1] - ref[None, :, 1]), axis=1)
        squeeze = np.where(tier >= 2, -np.minimum(room, self.buffer_clearance), 0.0)
        order = np.lexsort((dist, squeeze, tier))
        chosen: list[int] = []
        grown: list[Polygon] = []
        for c in order:
            if len(chosen) == count:
                break
            if not ok[c]:
                continue
            mine = shapely.buffer(feet[c], 0.5 * self.buffer_clearance, join_style="mitre")
            if all(not mine.intersects(g) for g in grown):
                chosen.append(int(c))
                grown.append(mine)
        return [self.add_site(Pose2D(float(xy[c, 0]), float(xy[c, 1]), float(yaw[c])))
                for c in chosen]

    # --- one block's ways from u to v, and the room each needs ----------------------------
    def set_fixed(self, poses: Sequence[Pose2D]) -> None:
        """Blocks that are obstacles from now on (e.g. the block being retrieved)."""
        self.fixed = list(poses)
        self.fixed_polys = list(self.footprints_of(self.fixed)) if self.fixed else []
        self._transfer_cache.clear()

    def options(self, u: Site, v: Site) -> list[tuple[Transfer, Polygon]]:
        """Every way to move a block from u to v that stays in the workspace and on the
        table and clear of fixed blocks, *ignoring the other blocks*, with the area each
        needs free of them (fingers, swept area, the block wherever it is set down); fewest
        actions, then cheapest, first."""
        cfg, geom = self.cfg, self.geom
        a, b = self.poses[u], self.poses[v]
        out: list[tuple[Transfer, Polygon]] = []
        pads_a = grasp_finger_corners(geom, a.x, a.y, a.theta, np.arange(2))  # (2, 2, 4, 2)
        per_m = cfg.a_dist if cfg.distance_cost else 0.0
        per_push = (cfg.a_dist + cfg.a_push_len) if cfg.distance_cost else 0.0

        def usable(corners: np.ndarray, region: str = "table") -> bool:
            bounds = self.ctx.table if region == "table" else self.ctx.workspace
            flat = corners.reshape(-1, 4, 2)
            if not bounds.contains(flat).all():
                return False
            polys = to_polygons(flat)
            return not any(p.intersection(f).area > OVERLAP_AREA_TOL
                           for p in polys for f in self.fixed_polys)

        def room(*parts: np.ndarray) -> Polygon:
            return shapely.union_all(to_polygons(np.concatenate(
                [p.reshape(-1, 4, 2) for p in parts])))

        def pads_at(p: Pose2D) -> np.ndarray:
            return grasp_finger_corners(geom, p.x, p.y, p.theta, np.arange(2))

        foot_b = block_corners(b.x, b.y, b.theta, self.s)[None]
        pads_b = pads_at(b)
        for ca in range(2):
            for cb in range(2):
                if usable(pads_a[ca]) and usable(pads_b[cb]) and usable(foot_b, "workspace"):
                    t = Transfer(u, v, 1, cfg.a1 + per_m * a.distance_to(b),
                                 (TransferPrimitive("pick_place", a, b, ca, cb),))
                    out.append((t, room(pads_a[ca], pads_b[cb], foot_b)))
        for sign, anchor in ((-1.0, b), (1.0, a)):
            for n in face_normals(anchor.theta):
                for length in self.push_lengths:
                    p = Pose2D(float(anchor.x + sign * n[0] * length),
                               float(anchor.y + sign * n[1] * length), anchor.theta)
                    start = p if sign < 0 else a
                    sweep = push_corners(geom, start.x, start.y, n[0], n[1], length)
                    if not (usable(sweep[0], "workspace") and usable(sweep[1:])):
                        continue
                    pads_p = pads_at(p)
                    for cp in range(2):
                        for c_other in range(2):
                            if sign < 0:  # place on p, push into b
                                if not (usable(pads_a[c_other]) and usable(pads_p[cp])):
                                    continue
                                steps = (TransferPrimitive("pick_place", a, p, c_other, cp),
                                         TransferPrimitive("push", p, b))
                                need = room(pads_a[c_other], pads_p[cp], sweep)
                                carried = a.distance_to(p)
                            else:  # push a out to p, then place on b
                                if not (usable(pads_p[cp]) and usable(pads_b[c_other])
                                        and usable(foot_b, "workspace")):
                                    continue
                                steps = (TransferPrimitive("push", a, p),
                                         TransferPrimitive("pick_place", p, b, cp, c_other))
                                need = room(sweep, pads_p[cp], pads_b[c_other], foot_b)
                                carried = p.distance_to(b)
                            cost = cfg.a1 + cfg.a2 + per_m * carried + per_push * length
                            out.append((Transfer(u, v, 2, cost, steps), need))
        out.sort(key=lambda o: (o[0].n_actions, o[0].cost))
        return out

    # --- actions ---------------------------------------------------------------------------
    def realize(self, transfer: Transfer, block: int, current: Pose2D
                ) -> tuple[list[Action], Pose2D]:
        """The actions of ``transfer`` for ``block`` standing at ``current`` (its actual yaw),
        and its pose afterwards."""
        actions: list[Action] = []
        for step in transfer.recipe:
            if step.kind == "push":
                act: Action = Push.between(block, current,
                                           Pose2D(step.end.x, step.end.y, current.theta))
            else:
                act = pick_place_between(block, current, step.start.theta, step.end,
                                         step.axis_from, step.axis_to)
            actions.append(act)
            current = act.to
        return actions, current


class _Batch:
    """Transfers among one list of nodes: node k's footprint is obstacle k."""

    def __init__(self, space: CellSpace, nodes: list[Site]) -> None:
        self.space = space
        self.nodes = nodes
        self.n = len(nodes)
        self.arr = poses_to_array([space.poses[s] for s in nodes])
        polys = [space.footprints[s] for s in nodes] + space.fixed_polys
        self.polys = np.array(polys, dtype=object)
        self.tree = shapely.STRtree(self.polys) if polys else None
        cfg = space.cfg
        self.per_m = cfg.a_dist if cfg.distance_cost else 0.0
        self.per_push_m = (cfg.a_dist + cfg.a_push_len) if cfg.distance_cost else 0.0

    def hits(self, corners: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For shapes (..., 4, 2): which nodes each overlaps (..., n) and whether it
        overlaps a fixed block (...)."""
        lead = corners.shape[:-2]
        flat = corners.reshape(-1, 4, 2)
        node_hit = np.zeros((len(flat), self.n), dtype=bool)
        fixed_hit = np.zeros(len(flat), dtype=bool)
        if self.tree is not None and len(flat):
            left, right = overlapping_pairs(self.tree, self.polys, flat)
            is_node = right < self.n
            node_hit[left[is_node], right[is_node]] = True
            fixed_hit[left[~is_node]] = True
        return node_hit.reshape(*lead, self.n), fixed_hit.reshape(lead)

    @staticmethod
    def clear_except(hit: np.ndarray, i: np.ndarray | int, j: np.ndarray | int) -> np.ndarray:
        """hit (..., n) touches nothing but nodes i and j (broadcast)."""
        total = hit.sum(-1)
        hi = np.take_along_axis(hit, np.asarray(i)[..., None], -1)[..., 0]
        hj = np.take_along_axis(hit, np.asarray(j)[..., None], -1)[..., 0]
        return total - hi - (hj & (np.asarray(i) != np.asarray(j))) == 0

    # --- pads at the nodes -----------------------------------------------------------------
    def pads(self) -> tuple[np.ndarray, np.ndarray]:
        """ok[i, j, c]: grasp axis c at node i is clear of every node but i and j, on the
        table and off fixed blocks; and the best axis per (i, j)."""
        geom, ctx = self.space.geom, self.space.ctx
        x, y, th = self.arr[:, 0], self.arr[:, 1], self.arr[:, 2]
        pads = grasp_finger_corners(geom, x[:, None], y[:, None], th[:, None], np.arange(2))
        hit, fixed = self.hits(pads)  # (n, 2, 2, n), (n, 2, 2)
        hit, fixed = hit.any(axis=2), fixed.any(axis=2)  # per node and axis
        base = ctx.table.contains(pads).all(-1) & ~fixed  # (n, 2)
        ii = np.arange(self.n)[:, None, None]
        jj = np.arange(self.n)[None, :, None]
        ok = base[:, None, :] & self.clear_except(hit[:, None, :, :], ii, jj)  # (n, n, 2)
        return ok, np.argmax(ok, axis=-1)

    def transfers(self, pair: tuple[int, int] | None = None) -> list[Transfer]:
        if self.n < 2:
            return []
        pad_ok, pad_axis = self.pads()
        self.pad_axis = pad_axis
        can = pad_ok.any(-1)  # can[i, j]: pads fit at i while the block goes i <-> j
        np.fill_diagonal(can, False)
        out: list[Transfer] = []
        src = range(self.n) if pair is None else [pair[0]]
        dst = range(self.n) if pair is None else [pair[1]]
        for i in src:
            for j in dst:
                if i != j and can[i, j] and can[j, i]:
                    out.append(self._pick_place(i, j, int(pad_axis[i, j]), int(pad_axis[j, i])))
        need_in = [j for j in dst if not all(can[j, i] for i in src if i != j)]
        need_out = [i for i in src if not all(can[i, j] for j in dst if j != i)]
        out += self._direct_pushes(src, dst)
        if need_in:
            out += self._composites(need_in, list(src), -1.0, can)
        if need_out:
            out += self._composites(need_out, list(dst), 1.0, can)
        return out

    # --- transfer kinds --------------------------------------------------------------------
    def _pose(self, k: int) -> Pose2D:
        return self.space.poses[self.nodes[k]]

    def _pick_place(self, i: int, j: int, ci: int, cj: int) -> Transfer:
        a, b = self._pose(i), self._pose(j)
        cost = self.space.cfg.a1 + self.per_m * a.distance_to(b)
        step = TransferPrimitive("pick_place", a, b, ci, cj)
        return Transfer(self.nodes[i], self.nodes[j], 1, cost, (step,))

    def _direct_pushes(self, src: Sequence[int], dst: Sequence[int]) -> list[Transfer]:
        cfg = self.space.cfg
        cand = []
        for j in dst:
            normals = face_normals(self.arr[j, 2])
            for i in src:
                if i == j or abs(math.remainder(self.arr[i, 2] - self.arr[j, 2], QUARTER)) > 1e-9:
                    continue
                v = self.arr[j, :2] - self.arr[i, :2]
                along = normals @ v
                cross = normals[:, 0] * v[1] - normals[:, 1] * v[0]
                k = int(np.argmax(along))
                if abs(cross[k]) < LINE_TOL and MIN_PUSH < along[k] <= cfg.push_max_distance:
                    cand.append((i, j, normals[k], float(along[k])))
        if not cand:
            return []
        i_arr = np.array([c[0] for c in cand])
        d = np.array([c[2] for c in cand])
        dist = np.array([c[3] for c in cand])
        sweep = push_corners(self.space.geom, self.arr[i_arr, 0], self.arr[i_arr, 1],
                             d[:, 0], d[:, 1], dist)
        ok = self._sweep_ok(sweep)
        hit, _ = self.hits(sweep)
        hit = hit.any(axis=1)
        out = []
        for k, (i, j, _, length) in enumerate(cand):
            if ok[k] and self.clear_except(hit[k], i, j):
                step = TransferPrimitive("push", self._pose(i), self._pose(j))
                cost = cfg.a2 + self.per_push_m * length
                out.append(Transfer(self.nodes[i], self.nodes[j], 1, cost, (step,)))
        return out

    def _sweep_ok(self, sweep: np.ndarray) -> np.ndarray:
        """Push sweeps (K, 3, 4, 2): block inside the workspace, fingertips on the table,
        nothing fixed hit."""
        ctx = self.space.ctx
        _, fixed = self.hits(sweep)
        return (ctx.workspace.contains(sweep[:, 0]) & ctx.table.contains(sweep[:, 1:]).all(-1)
                & ~fixed.any(-1))

    def _stagings(self, anchors: Sequence[int], sign: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Transient poses on the push lines of ``anchors``: p = anchor + sign * n * L.

        Returns (anchor index (K,), p (K, 3), unit push direction n (K, 2), L (K,)): the push
        runs along n from p *into* the anchor (sign -1) or from the anchor *out* to p (+1).
        """
        rows_a, rows_p, rows_d, rows_l = [], [], [], []
        for a in anchors:
            x, y, th = self.arr[a]
            for n in face_normals(th):
                for length in self.space.push_lengths:
                    rows_a.append(a)
                    rows_p.append((x + sign * n[0] * length, y + sign * n[1] * length, th))
                    rows_d.append(n)
                    rows_l.append(length)
        return (np.array(rows_a, dtype=int), np.array(rows_p), np.array(rows_d),
                np.array(rows_l))

    @staticmethod
    def _clear_matrix(hit: np.ndarray, anchor: np.ndarray) -> np.ndarray:
        """[k, i]: shape k (hits ``hit`` (K, n)) touches no node but i and anchor[k]."""
        k = np.arange(len(anchor))
        total = hit.sum(-1)[:, None]
        at_anchor = hit[k, anchor][:, None]
        other = np.arange(hit.shape[-1])[None, :] != anchor[:, None]
        return total - hit - (at_anchor & other) == 0

    def _composites(self, anchors: list[int], others: list[int], sign: float, can: np.ndarray
                    ) -> list[Transfer]:
        """Two-action transfers through a transient pose on a push line of each anchor:
        ``place_push`` into the anchor (sign -1: others are sources) or ``push_place`` out
        of it (sign +1: others are targets)."""
        cfg, geom, ctx = self.space.cfg, self.space.geom, self.space.ctx
        anchor, p, d, length = self._stagings(anchors, sign)
        origin = p if sign < 0 else self.arr[anchor]
        sweep = push_corners(geom, origin[:, 0], origin[:, 1], d[:, 0], d[:, 1], length)
        sweep_hit, sweep_fixed = self.hits(sweep)
        sweep_ok = (ctx.workspace.contains(sweep[:, 0]) & ctx.table.contains(sweep[:, 1:]).all(-1)
                    & ~sweep_fixed.any(-1))
        sweep_clear = self._clear_matrix(sweep_hit.any(axis=1), anchor)
        pads = grasp_finger_corners(geom, p[:, 0, None], p[:, 1, None], p[:, 2, None],
                                    np.arange(2))
        pad_hit, pad_fixed = self.hits(pads)
        pad_ok = ctx.table.contains(pads).all(-1) & ~pad_fixed.any(axis=2)  # (K, 2)
        pad_hit = pad_hit.any(axis=2)  # (K, 2, n)
        stage = np.stack([pad_ok[:, c, None] & self._clear_matrix(pad_hit[:, c], anchor)
                          for c in range(2)], axis=-1)  # (K, n, 2)
        wanted = np.zeros(self.n, dtype=bool)
        wanted[others] = True
        feasible = (sweep_ok[:, None] & sweep_clear & stage.any(-1) & can[:, anchor].T
                    & wanted[None, :] & (np.arange(self.n)[None, :] != anchor[:, None]))
        best: dict[tuple[int, int], Transfer] = {}
        for k, other in zip(*np.nonzero(feasible), strict=True):
            a = int(anchor[k])
            i, j = (int(other), a) if sign < 0 else (a, int(other))
            start, mid, end = self._pose(i), Pose2D(*map(float, p[k])), self._pose(j)
            carried = start.distance_to(mid) if sign < 0 else mid.distance_to(end)
            cost = cfg.a1 + cfg.a2 + self.per_m * carried + self.per_push_m * float(length[k])
            if (i, j) in best and best[(i, j)].cost <= cost:
                continue
            axis_mid = int(np.argmax(stage[k, other]))
            if sign < 0:
                steps = (TransferPrimitive("pick_place", start, mid, int(self.pad_axis[i, j]),
                                           axis_mid),
                         TransferPrimitive("push", mid, end))
            else:
                steps = (TransferPrimitive("push", start, mid),
                         TransferPrimitive("pick_place", mid, end, axis_mid,
                                           int(self.pad_axis[j, i])))
            best[(i, j)] = Transfer(self.nodes[i], self.nodes[j], 2, cost, steps)
        return list(best.values())
