"""Transfers between sites of the work cell: one block from site u to site v.

A transfer is one of

* ``pick_place``: pads at u (pick) and at v (place) on some grasp axis each;
* ``push``: u lies on a push line of v (same yaw modulo 90 degrees);
* ``place_push``: pick-and-place onto a transient pose p on a push line of v, then push p -> v
  (how a block gets into a slot whose neighbours leave no room for the fingers);
* ``push_place``: push u out to a transient p, then pick-and-place p -> v (how a block whose
  neighbours hide its faces gets out).

Whether a single action is feasible and what it costs is
``nodes.planner.geometry.transfer``'s answer
(fingers, sweeps, workspace, table, reach; ``CostModel``): the same as the labeled planner's
roadmap. ``TransferBatch`` asks it for all pairs of a list of sites at once, every site's
footprint an obstacle (the RPG's edges need every other site occupied), and keeps what
touches no site but the two ends. ``ways`` lists a block's ways from u to v ignoring the other
blocks, with the area each needs (retrieval); ``realize`` turns a transfer into msgs_py
actions for the block's actual yaw (a site's yaw is one of its class's).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from msgs_py import Pose2D, Push
from msgs_py.actions import Action
from msgs_py.footprint import (
    block_corners,
    face_normals,
    grasp_finger_corners,
    push_corners,
    to_polygons,
)
from nodes.planner.geometry.obstacles import Obstacles, mask_to_bools, words
from nodes.planner.geometry.transfer import (
    FOOTPRINT_PERIOD,
    grasp_checks,
    pick_place_between,
    push_checks,
    push_line,
)
from nodes.planner.unlabeled.rpg import Transfer


@dataclass(frozen=True)
class TransferPrimitive:
    """One primitive of a transfer, at site level: ``axis_from``/``axis_to`` pick the grasp
    axis (site yaw + axis * 90 degrees) at each end of a pick-and-place."""

    kind: str  # "pick_place" | "push"
    start: Pose2D
    end: Pose2D
    axis_from: int = 0
    axis_to: int = 0


def realize(transfer: Transfer, block: int, current: Pose2D) -> tuple[list[Action], Pose2D]:
    """The actions of ``transfer`` for ``block`` standing at ``current`` (its actual yaw),
    and its pose afterwards."""
    actions: list[Action] = []
    for step in transfer.recipe:
        if step.kind == "push":
            act: Action = Push.between(block, current, Pose2D(step.end.x, step.end.y,
                                                              current.theta))
        else:
            act = pick_place_between(block, current, step.start.theta, step.end,
                                     step.axis_from, step.axis_to)
        actions.append(act)
        current = act.to
    return actions, current


def realize_all(block_at: Mapping[int, int], poses: Mapping[int, Pose2D],
                transfers: Iterable[Transfer]) -> list[Action]:
    """The actions of ``transfers``: each moves the block standing on its source site
    (``block_at``: site -> block id; ``poses``: block id -> its actual pose)."""
    at, pose = dict(block_at), dict(poses)
    actions: list[Action] = []
    for t in transfers:
        block = at.pop(t.source)
        acts, pose[block] = realize(t, block, pose[block])
        at[t.target] = block
        actions += acts
    return actions


def _array(poses: Sequence[Pose2D]) -> np.ndarray:
    return np.array([[p.x, p.y, p.theta] for p in poses], dtype=float).reshape(-1, 3)


class TransferBatch:
    """Transfers among one list of sites: site k's footprint is obstacle k, fixed blocks
    are obstacles too. ``sites`` are the space's site ids, ``poses`` their poses."""

    def __init__(self, ctx, sites: list[int], poses: list[Pose2D],
                 fixed: Sequence[Pose2D], push_lengths: Sequence[float]) -> None:
        self.ctx = ctx
        self.sites = sites
        self.n = len(sites)
        self.arr = _array(poses)
        self.push_lengths = tuple(push_lengths)
        both = np.concatenate([self.arr, _array(fixed)])
        n_all = len(both)
        self.obstacles = Obstacles(list(range(n_all)), block_corners(
            both[:, 0], both[:, 1], both[:, 2], ctx.geom.block_size),
            [k < self.n for k in range(n_all)], {k: k for k in range(self.n)},
            words(max(self.n, 1)))

    def hits(self, masks: np.ndarray) -> np.ndarray:
        """Site masks (..., W) as booleans (..., n)."""
        return mask_to_bools(masks, self.n)

    @staticmethod
    def clear_except(hit: np.ndarray, i, j) -> np.ndarray:
        """hit (..., n) touches nothing but sites i and j (broadcast)."""
        total = hit.sum(-1)
        hi = np.take_along_axis(hit, np.asarray(i)[..., None], -1)[..., 0]
        hj = np.take_along_axis(hit, np.asarray(j)[..., None], -1)[..., 0]
        return total - hi - (hj & (np.asarray(i) != np.asarray(j))) == 0

    def pads(self) -> tuple[np.ndarray, np.ndarray]:
        """ok[i, j, c]: grasp axis c at site i is clear of every site but i and j, on the
        table, in reach and off fixed blocks; and the best axis per (i, j)."""
        grasps = grasp_checks(self.ctx, self.obstacles, self.arr)
        hit = self.hits(grasps.fingers_hit)  # (n, 2, n)
        ii = np.arange(self.n)[:, None, None]
        jj = np.arange(self.n)[None, :, None]
        ok = grasps.fingers_ok[:, None, :] & self.clear_except(hit[:, None, :, :], ii, jj)
        return ok, np.argmax(ok, axis=-1)

    def transfers(self, pair: tuple[int, int] | None = None) -> list[Transfer]:
        if self.n < 2:
            return []
        pad_ok, self.pad_axis = self.pads()
        can = pad_ok.any(-1)  # can[i, j]: pads fit at i while the block goes i <-> j
        np.fill_diagonal(can, False)
        src = list(range(self.n)) if pair is None else [pair[0]]
        dst = list(range(self.n)) if pair is None else [pair[1]]
        out = [self._pick_place(i, j) for i in src for j in dst
               if i != j and can[i, j] and can[j, i]]
        out += self._direct_pushes(src, dst)
        need_in = [j for j in dst if not all(can[j, i] for i in src if i != j)]
        need_out = [i for i in src if not all(can[i, j] for j in dst if j != i)]
        if need_in:
            out += self._composites(need_in, src, -1.0, can)
        if need_out:
            out += self._composites(need_out, dst, 1.0, can)
        return out

    def _pose(self, k: int) -> Pose2D:
        return Pose2D(*map(float, self.arr[k]))

    def _pick_place(self, i: int, j: int) -> Transfer:
        a, b = self._pose(i), self._pose(j)
        step = TransferPrimitive("pick_place", a, b, int(self.pad_axis[i, j]),
                                 int(self.pad_axis[j, i]))
        return Transfer(self.sites[i], self.sites[j], 1,
                        self.ctx.cost.pick_place(a.distance_to(b)), (step,))

    def _direct_pushes(self, src: list[int], dst: list[int]) -> list[Transfer]:
        pairs = np.array([(i, j) for i in src for j in dst if i != j], dtype=int).reshape(-1, 2)
        if not len(pairs):
            return []
        on, d, length = push_line(self.arr[pairs[:, 0]], self.arr[pairs[:, 1]],
                                   FOOTPRINT_PERIOD)
        on &= length <= self.ctx.config.push_max_distance
        pairs, d, length = pairs[on], d[on], length[on]
        if not len(pairs):
            return []
        ok, masks = push_checks(self.ctx, self.obstacles, self.arr[pairs[:, 0]], d, length)
        ok &= self.clear_except(self.hits(masks), pairs[:, 0], pairs[:, 1])
        return [Transfer(self.sites[i], self.sites[j], 1, self.ctx.cost.push(float(L)),
                         (TransferPrimitive("push", self._pose(i), self._pose(j)),))
                for (i, j), L in zip(pairs[ok], length[ok], strict=True)]

    def _stagings(self, anchors: Sequence[int], sign: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Transient poses on the push lines of ``anchors``: p = anchor + sign * n * L.

        Returns (anchor index (K,), p (K, 3), unit push direction n (K, 2), L (K,)): the push
        runs along n from p *into* the anchor (sign -1) or from the anchor *out* to p (+1).
        """
        anchor = np.repeat(np.asarray(anchors, dtype=int), 4 * len(self.push_lengths))
        d = np.repeat(face_normals(self.arr[list(anchors), 2]), len(self.push_lengths),
                      axis=1).reshape(-1, 2)
        length = np.tile(np.asarray(self.push_lengths), 4 * len(anchors))
        p = np.column_stack([self.arr[anchor, :2] + sign * d * length[:, None],
                             self.arr[anchor, 2]])
        return anchor, p, d, length

    @staticmethod
    def _clear_matrix(hit: np.ndarray, anchor: np.ndarray) -> np.ndarray:
        """[k, i]: shape k (hits ``hit`` (K, n)) touches no site but i and anchor[k]."""
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
        anchor, p, d, length = self._stagings(anchors, sign)
        origin = p if sign < 0 else self.arr[anchor]
        sweep_ok, sweep_masks = push_checks(self.ctx, self.obstacles, origin, d, length)
        sweep_clear = self._clear_matrix(self.hits(sweep_masks), anchor)
        grasps = grasp_checks(self.ctx, self.obstacles, p)
        pad_hit = self.hits(grasps.fingers_hit)  # (K, 2, n)
        stage = np.stack([grasps.fingers_ok[:, c, None] & self._clear_matrix(pad_hit[:, c],
                                                                            anchor)
                          for c in range(2)], axis=-1)  # (K, n, 2)
        wanted = np.zeros(self.n, dtype=bool)
        wanted[others] = True
        feasible = (sweep_ok[:, None] & sweep_clear & stage.any(-1) & can[:, anchor].T
                    & wanted[None, :] & (np.arange(self.n)[None, :] != anchor[:, None]))
        best: dict[tuple[int, int], Transfer] = {}
        for k, other in zip(*np.nonzero(feasible), strict=True):
            t = self._composite(int(anchor[k]), int(other), p[k], float(length[k]),
                                int(np.argmax(stage[k, other])), sign)
            key = (t.source, t.target)
            if key not in best or t.cost < best[key].cost:
                best[key] = t
        return list(best.values())

    def _composite(self, a: int, other: int, mid_arr: np.ndarray, length: float,
                   axis_mid: int, sign: float) -> Transfer:
        i, j = (other, a) if sign < 0 else (a, other)
        start, mid, end = self._pose(i), Pose2D(*map(float, mid_arr)), self._pose(j)
        cost = self.ctx.cost
        if sign < 0:
            steps = (TransferPrimitive("pick_place", start, mid, int(self.pad_axis[i, j]),
                                       axis_mid), TransferPrimitive("push", mid, end))
            value = cost.pick_place(start.distance_to(mid)) + cost.push(length)
        else:
            steps = (TransferPrimitive("push", start, mid),
                     TransferPrimitive("pick_place", mid, end, axis_mid,
                                       int(self.pad_axis[j, i])))
            value = cost.push(length) + cost.pick_place(mid.distance_to(end))
        return Transfer(self.sites[i], self.sites[j], 2, value, steps)


def ways(ctx, fixed: Obstacles, u: int, v: int, a: Pose2D, b: Pose2D,
         push_lengths: Sequence[float]) -> list[tuple[Transfer, Polygon]]:
    """Every way to move a block from u (at ``a``) to v (at ``b``) that stays in the
    workspace, on the table, in reach and clear of the ``fixed`` blocks, *ignoring the other
    blocks*, with the area each needs free of them (fingers, swept area, the block wherever
    it is set down); fewest actions, then cheapest, first."""
    geom, cost = ctx.geom, ctx.cost
    ends = grasp_checks(ctx, fixed, _array([a, b]))
    pads = grasp_finger_corners(geom, ends.xy[:, 0, None], ends.xy[:, 1, None],
                                np.array([a.theta, b.theta])[:, None], np.arange(2))
    foot_b = block_corners(b.x, b.y, b.theta, geom.block_size)[None]
    out: list[tuple[Transfer, Polygon]] = []
    for ca in np.flatnonzero(ends.fingers_ok[0]):
        for cb in np.flatnonzero(ends.fingers_ok[1] & ends.block_ok[1]):
            step = TransferPrimitive("pick_place", a, b, int(ca), int(cb))
            out.append((Transfer(u, v, 1, cost.pick_place(a.distance_to(b)), (step,)),
                        _room(pads[0, ca], pads[1, cb], foot_b)))
    for sign, anchor in ((-1.0, b), (1.0, a)):
        out += _ways_through_line(ctx, fixed, u, v, a, b, sign, anchor, push_lengths, ends,
                                  pads, foot_b)
    out.sort(key=lambda o: (o[0].n_actions, o[0].cost))
    return out


def _ways_through_line(ctx, fixed, u, v, a, b, sign, anchor, push_lengths, ends, pads, foot_b
                       ) -> list[tuple[Transfer, Polygon]]:
    """``ways``' two-action transfers through a pose p on a push line of ``anchor`` (b for
    place-then-push, a for push-then-place)."""
    cost = ctx.cost
    d = np.repeat(face_normals(anchor.theta), len(push_lengths), axis=0)
    length = np.tile(np.asarray(push_lengths, dtype=float), 4)
    p = np.column_stack([anchor.x + sign * d[:, 0] * length,
                         anchor.y + sign * d[:, 1] * length, np.full(len(d), anchor.theta)])
    origin = p if sign < 0 else np.repeat(_array([a]), len(p), axis=0)
    sweep_ok, _ = push_checks(ctx, fixed, origin, d, length)
    at_p = grasp_checks(ctx, fixed, p)
    pads_p = grasp_finger_corners(ctx.geom, p[:, 0, None], p[:, 1, None], p[:, 2, None],
                                  np.arange(2))
    other = 0 if sign < 0 else 1  # the end the pick-and-place touches besides p
    out = []
    for k in np.flatnonzero(sweep_ok):
        mid, sweep = Pose2D(*map(float, p[k])), push_corners(
            ctx.geom, origin[k, 0], origin[k, 1], d[k, 0], d[k, 1], length[k])
        for cp in np.flatnonzero(at_p.fingers_ok[k]):
            for co in np.flatnonzero(ends.fingers_ok[other] & (ends.block_ok[1] | (sign < 0))):
                if sign < 0:  # place on p, push into b
                    steps = (TransferPrimitive("pick_place", a, mid, int(co), int(cp)),
                             TransferPrimitive("push", mid, b))
                    need = _room(pads[0, co], pads_p[k, cp], sweep)
                    value = cost.pick_place(a.distance_to(mid)) + cost.push(length[k])
                else:  # push a out to p, then place on b
                    steps = (TransferPrimitive("push", a, mid),
                             TransferPrimitive("pick_place", mid, b, int(cp), int(co)))
                    need = _room(sweep, pads_p[k, cp], pads[1, co], foot_b)
                    value = cost.push(length[k]) + cost.pick_place(mid.distance_to(b))
                out.append((Transfer(u, v, 2, float(value), steps), need))
    return out


def _room(*parts: np.ndarray) -> Polygon:
    """The union of the shapes (each (..., 4, 2))."""
    return shapely.union_all(to_polygons(np.concatenate([q.reshape(-1, 4, 2) for q in parts])))
