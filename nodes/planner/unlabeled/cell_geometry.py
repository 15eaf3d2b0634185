"""The work cell as a transfer space: sites are block poses, transfers are gripper actions.

``CellSites`` holds the sites of one scene (block poses, goal slots, buffers) and answers the
pebble-graph search (``rpg.TransferSpace``, ``hypergraph.SearchSpace``): which sites
conflict, the transfers among a set of sites with every other one occupied (the RPG's edges),
the cheapest transfer for an actual occupancy (cached on the blocks within reach), fresh
buffer sites out of the goal's way, what obstructs the goal. The transfers themselves, and
the single actions they are made of, are ``cell_transfers``' (on
``nodes.planner.geometry.transfer``).

Site yaws are kept as given; a block standing on a site may be turned by a multiple of 90
degrees from it (the footprint is the same), and ``cell_transfers.realize`` turns a
transfer into msgs_py actions for the block's actual yaw.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon

from msgs_py import Pose2D
from msgs_py.cell import OVERLAP_AREA_TOL
from msgs_py.footprint import block_corners, to_polygons
from msgs_py.poses import poses_to_array
from nodes.planner.geometry.context import PlanContext
from nodes.planner.geometry.obstacles import Obstacles
from nodes.planner.geometry.transfer import grasp_checks
from nodes.planner.unlabeled.cell_transfers import TransferBatch, ways
from nodes.planner.unlabeled.rpg import Site, Transfer

QUARTER = 0.5 * math.pi
#: Candidate positions drawn per buffer request, plus a lattice of this step (block sizes)
#: over the whole workspace, so that crowded tables still yield the free spots they have.
BUFFER_CANDIDATES = 400
LATTICE_STEP = 0.125
#: Most buffer candidates on that lattice (the default 0.5 x 0.7 m workspace has 7400).
LATTICE_MAX = 20_000
#: How much (m) the zone is shrunk for the fast overlap test of buffer candidates.
ZONE_SHRINK = 1e-5
#: Smallest gap (m) between a buffer and any block.
MIN_BUFFER_GAP = 0.001


class CellSites:
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
            xy = self.ctx.workspace.lattice(self.s, LATTICE_STEP * self.s, LATTICE_MAX)
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
        return self._batch(list(nodes)).transfers()

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
                found = self._batch([u, v, *others]).transfers(pair=(0, 1))
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
        xy, yaw, feet, ok, in_zone, in_core = self._buffer_candidates(rng)
        blocks = [self.footprints[n] for n in nodes] + self.fixed_polys
        room = np.full(len(feet), np.inf)
        if blocks:
            room[ok] = shapely.distance(feet[ok], shapely.union_all(blocks))
        ok &= room >= MIN_BUFFER_GAP
        roomy = room >= self.buffer_clearance
        graspable = roomy.copy()
        tight = np.flatnonzero(ok & ~roomy & ~in_core)
        if len(tight) and blocks:
            arr = poses_to_array([self.poses[n] for n in nodes] + self.fixed)
            obstacles = Obstacles(list(range(len(arr))), block_corners(
                arr[:, 0], arr[:, 1], arr[:, 2], self.s), [False] * len(arr), {})
            cand = np.column_stack([xy[tight], yaw[tight]])
            graspable[tight] = grasp_checks(self.ctx, obstacles, cand).fingers_ok.any(-1)
        tier = np.select([in_core, roomy & ~in_zone, roomy, graspable & ~in_zone, graspable],
                         [5, 0, 1, 2, 3], 4)
        dist = np.zeros(len(feet))
        if near:
            ref = poses_to_array([self.poses[n] for n in near])[:, :2]
            dist = np.min(np.hypot(xy[:, None, 0] - ref[None, :, 0],
                                   xy[:, None, 1] - ref[None, :, 1]), axis=1)
        squeeze = np.where(tier >= 2, -np.minimum(room, self.buffer_clearance), 0.0)
        chosen = self._spread(np.lexsort((dist, squeeze, tier)), ok, feet, count)
        return [self.add_site(Pose2D(float(xy[c, 0]), float(xy[c, 1]), float(yaw[c])))
                for c in chosen]

    def _buffer_candidates(self, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
        """Random candidates at any yaw (a turned block may fit a gap) and a fixed lattice
        square to the goal (zone tests cached): xy, yaw, footprints, inside the workspace
        and in reach, in the zone, on a slot."""
        w, half, k = self.ctx.workspace, 0.5 * self.s, BUFFER_CANDIDATES
        rand_xy = np.column_stack([rng.uniform(w.x_min + half, w.x_max - half, k),
                                   rng.uniform(w.y_min + half, w.y_max - half, k)])
        rand_yaw = rng.uniform(-QUARTER / 2, QUARTER / 2, k) + self.buffer_yaw
        r_corners = block_corners(rand_xy[:, 0], rand_xy[:, 1], rand_yaw, self.s)
        r_feet = to_polygons(r_corners)
        random_part = (rand_xy, rand_yaw, r_feet, *self._zone_flags(r_corners, r_feet))
        xy, yaw, feet, ok, in_zone, in_core = (
            np.concatenate([a, b]) for a, b in zip(random_part, self._lattice(), strict=True))
        return xy, yaw, feet, ok & self.ctx.reach.contains(xy), in_zone, in_core

    def _spread(self, order: np.ndarray, ok: np.ndarray, feet: np.ndarray, count: int
                ) -> list[int]:
        """The first ``count`` usable candidates in ``order`` that keep half the buffer
        clearance from each other."""
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
        return chosen

    # --- one block's ways from u to v, and the room each needs ----------------------------
    def set_fixed(self, poses: Sequence[Pose2D]) -> None:
        """Blocks that are obstacles from now on (e.g. the block being retrieved)."""
        self.fixed = list(poses)
        self.fixed_polys = list(self.footprints_of(self.fixed)) if self.fixed else []
        self._transfer_cache.clear()

    def options(self, u: Site, v: Site) -> list[tuple[Transfer, Polygon]]:
        """Every way to move a block from u to v ignoring the other blocks but the fixed
        ones, with the area each needs free of them (``cell_transfers.ways``)."""
        fixed = self.fixed
        arr = poses_to_array(fixed) if fixed else np.zeros((0, 3))
        obstacles = Obstacles(list(range(len(fixed))), block_corners(
            arr[:, 0], arr[:, 1], arr[:, 2], self.s), [False] * len(fixed), {})
        return ways(self.ctx, obstacles, u, v, self.poses[u], self.poses[v], self.push_lengths)

    def _batch(self, nodes: list[Site]) -> TransferBatch:
        return TransferBatch(self.ctx, nodes, [self.poses[s] for s in nodes], self.fixed,
                             self.push_lengths)
