"""An assembly order for the goal layout: which block to place next so that none gets walled
in and as few as possible need a push.

A goal slot is *enterable* given a set of filled slots when its block can be set down on it
with some grasp (*pick-and-place-able*), or pushed into it along a face normal from a pose
where it can be set down, without fingers or swept block touching a filled slot. All the
footprint tests are done once, in bulk, against the other slots; afterwards a slot set is a
Python int bit mask and every test is integer arithmetic.

``feasible(filled)``: removing blocks only frees space, so peeling off enterable slots round
after round is a complete test (for this relaxation) of whether the empty slots can still all
be filled. ``order()``: greedily fill next a pick-and-place-able slot whose filling keeps the
rest feasible, else a push-only one, sweeping the layout from -y to +y so that lanes stay open
(a 3x3 grid needs 2 pushes this way, 4 ring by ring).
"""

from __future__ import annotations

from functools import cache

import numpy as np

from msgs_py import Pose2D
from msgs_py.footprint import block_corners, face_normals, grasp_finger_corners, push_corners
from nodes.planner.context import PlanContext
from nodes.planner.geometry import Obstacles, mask_to_int

#: Push lengths (in block sizes) tried when testing whether a slot can be pushed into (those
#: up to the roadmap's push_max_distance).
PUSH_STEPS = (0.1, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 5.0)


def _masks(obstacles: Obstacles, corners: np.ndarray) -> list[int]:
    """Per row of ``corners`` (K, m, 4, 2), the bit mask of slots it overlaps (Python ints)."""
    _, mask = obstacles.query(corners)
    return [mask_to_int(row) for row in mask]


class Assembly:
    """Goal-layout reasoning over the slots ``slots`` (block id -> goal pose)."""

    def __init__(self, ctx: PlanContext, slots: dict[int, Pose2D]) -> None:
        self.ids = sorted(slots)
        self.bit = {b: 1 << k for k, b in enumerate(self.ids)}
        self.all = (1 << len(self.ids)) - 1
        geom = ctx.geom
        poses = [slots[b] for b in self.ids]
        x = np.array([p.x for p in poses])
        y = np.array([p.y for p in poses])
        th = np.array([p.theta for p in poses])
        n = len(self.ids)
        obstacles = Obstacles(list(range(n)), block_corners(x, y, th, geom.block_size),
                              [True] * n, {k: k for k in range(n)}) if n else None
        # set-down at the slot, per grasp
        fingers = grasp_finger_corners(geom, x[:, None], y[:, None], th[:, None], np.arange(2))
        f_in = ctx.table.contains(fingers).all(-1)  # (n, 2)
        # pushes into the slot: from q = slot - d * L along each face normal
        steps = np.array(PUSH_STEPS) * geom.block_size
        steps = steps[steps <= ctx.config.push_max_distance + 1e-9]
        d = face_normals(th)  # (n, 4, 2)
        d = np.repeat(d, len(steps), axis=1)  # (n, P, 2)
        length = np.tile(steps, 4)[None, :].repeat(n, 0)  # (n, P)
        qx, qy = x[:, None] - d[..., 0] * length, y[:, None] - d[..., 1] * length
        sweep = push_corners(geom, qx, qy, d[..., 0], d[..., 1], length)  # (n, P, 3, 4, 2)
        s_in = ctx.workspace.contains(sweep[..., 0, :, :]) & ctx.table.contains(
            sweep[..., 1:, :, :]).all(-1)
        q_fingers = grasp_finger_corners(geom, qx[..., None], qy[..., None], th[:, None, None],
                                         np.arange(2))  # (n, P, 2, 2, 4, 2)
        q_in = ctx.table.contains(q_fingers).all(-1)  # (n, P, 2)
        self.set_down: list[list[int]] = [[] for _ in range(n)]  # masks of usable grasps
        self.push_in: list[list[tuple[int, list[int]]]] = [[] for _ in range(n)]
        if obstacles is None:
            return
        own = [1 << k for k in range(n)]
        fm = _masks(obstacles, fingers.reshape(n * 2, 2, 4, 2))
        sm = _masks(obstacles, sweep.reshape(-1, 3, 4, 2))
        qm = _masks(obstacles, q_fingers.reshape(-1, 2, 4, 2))
        n_p = sweep.shape[1]
        for c in range(n):
            self.set_down[c] = [fm[c * 2 + g] & ~own[c] for g in range(2) if f_in[c, g]]
            for p in range(n_p):
                if not s_in[c, p]:
                    continue
                grasps = [qm[(c * n_p + p) * 2 + g] & ~own[c] for g in range(2)
                          if q_in[c, p, g]]
                if grasps:
                    self.push_in[c].append((sm[c * n_p + p] & ~own[c], grasps))
        self._y = {b: (round(slots[b].y, 4), round(slots[b].x, 4), b) for b in self.ids}

    # --- tests on bit masks of filled slots -------------------------------------------------
    def placeable(self, block: int, filled: int) -> bool:
        """Pick-and-place straight onto the slot with the slots ``filled``."""
        c = self.ids.index(block)
        return any(m & filled == 0 for m in self.set_down[c])

    def enterable(self, c: int, filled: int) -> bool:
        if any(m & filled == 0 for m in self.set_down[c]):
            return True
        return any(sweep & filled == 0 and any(g & filled == 0 for g in grasps)
                   for sweep, grasps in self.push_in[c])

    def mask(self, blocks) -> int:
        out = 0
        for b in blocks:
            out |= self.bit[b]
        return out

    def feasible(self, filled: int) -> bool:
        return self._feasible(filled & self.all)

    @cache  # noqa: B019 - one Assembly per planning run; the cache dies with it
    def _feasible(self, filled: int) -> bool:
        return not self.stuck(filled)

    def stuck(self, filled: int) -> list[int]:
        """Empty slots (block ids) that no peeling order of the empty ones can fill."""
        empty = self.all & ~filled
        occupied = self.all
        while empty:
            peel = [c for c in range(len(self.ids))
                    if empty >> c & 1 and self.enterable(c, occupied & ~(1 << c))]
            if not peel:
                break
            for c in peel:
                empty &= ~(1 << c)
                occupied &= ~(1 << c)
        return [self.ids[c] for c in range(len(self.ids)) if empty >> c & 1]

    def order(self, filled: int = 0) -> list[int]:
        """A greedy assembly order (block ids) of the slots not in ``filled``: a
        pick-and-place-able slot that keeps the rest feasible first, else a push-only one."""
        out = []
        for _ in range(len(self.ids) - (filled & self.all).bit_count()):
            rest = [b for b in self.ids if not filled & self.bit[b]]
            rest.sort(key=lambda b: (not self.placeable(b, filled), self._y[b]))
            pick = next((b for b in rest if self.feasible(filled | self.bit[b])), rest[0])
            out.append(pick)
            filled |= self.bit[pick]
        return out

    def future_pushes(self, filled: int) -> int:
        """Push-only placements the greedy order still needs from ``filled`` (a lookahead)."""
        return self._future_pushes(filled & self.all)

    @cache  # noqa: B019 - see _feasible
    def _future_pushes(self, filled: int) -> int:
        if filled == self.all:
            return 0
        if not self.feasible(filled):
            return len(self.ids)
        nxt = self.order(filled)[0]
        push = 0 if self.placeable(nxt, filled) else 1
        return push + self._future_pushes(filled | self.bit[nxt])
