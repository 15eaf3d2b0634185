"""The UR10e's reach with the tool pointing down: which TCP positions a plan may use.

Every point a plan puts the tool centre point (TCP) at (over and at a grasped block, behind a
pushed block at the start and the end of the push, the straight carries between them) is
checked against the arm's own kinematic model, ``nodes.sim.kinematics.solve_tcp_ik`` (the
UR10e's DH parameters, closed-form IK through ``ur_analytic_ik``, branches with the elbow or
a wrist near the table discarded). It is imported as is: a pure numpy module (no PyBullet) and
the very model the arm controller and the sim's scene check use, so the planner accepts
nothing the arm would refuse; moving it to a neutral package is the sim's call.

Tool down, joint 1 turns the whole arm about the base's z axis and joint 6 turns the tool
about its own vertical axis (both +-360 deg), so whether a TCP position is reachable depends
only on its height and its distance r from the base axis: at each height the reachable
positions form an annulus r_min <= r <= r_max. ``ur10e_reach`` finds the radii by bisection on
the IK at every height a plan uses (``msgs_py.cell.ACTION_HEIGHTS``), keeps the annulus common
to all of them shrunk by ``REACH_MARGIN``, once per process (~0.1 s); a check is then a
comparison of radii, vectorised over any number of points. The unit tests compare it with
the IK itself at random points and tool yaws.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from msgs_py import MessageError
from msgs_py.cell import ACTION_HEIGHTS
from nodes.common.transforms import tool_down_matrix
from nodes.sim.kinematics import solve_tcp_ik

#: Kept from the boundary of the reachable annulus (m): a fully stretched or folded arm is
#: near a singularity and slow to control.
REACH_MARGIN = 0.01
#: The radial scan that finds the annulus (m): step, farthest radius, bisection tolerance.
SCAN_STEP = 0.02
SCAN_MAX = 2.0
BISECT_TOL = 1e-4


@dataclass(frozen=True)
class Reach:
    """TCP positions (m, ``world`` = the robot base) the arm reaches with the tool down."""

    r_min: float
    r_max: float

    def contains(self, xy) -> np.ndarray:
        """Whether each point (..., 2) is reachable."""
        xy = np.asarray(xy, dtype=float)
        r = np.hypot(xy[..., 0], xy[..., 1])
        return (r >= self.r_min) & (r <= self.r_max)

    def segment(self, a, b) -> np.ndarray:
        """Whether the straight TCP paths a -> b (..., 2 each) stay reachable: both ends
        inside, and no point of the path closer to the base axis than ``r_min``."""
        a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
        d = b - a
        length2 = np.sum(d * d, axis=-1)
        t = np.clip(-np.sum(a * d, axis=-1) / np.where(length2 > 0.0, length2, 1.0), 0.0, 1.0)
        closest = a + t[..., None] * d
        near = np.hypot(closest[..., 0], closest[..., 1]) >= self.r_min
        return self.contains(a) & self.contains(b) & near

    def describe(self) -> str:
        return f"{self.r_min:.2f}-{self.r_max:.2f} m from the robot base"


def _reachable(r: float, z: float) -> bool:
    t = np.eye(4)
    t[:3, :3] = tool_down_matrix(0.0)
    t[:3, 3] = (r, 0.0, z)
    return solve_tcp_ik(t, np.zeros(6)).ok


def _bisect(z: float, inside: float, outside: float) -> float:
    """The reachable radius nearest the boundary between ``inside`` and ``outside``."""
    while abs(outside - inside) > BISECT_TOL:
        mid = 0.5 * (inside + outside)
        if _reachable(mid, z):
            inside = mid
        else:
            outside = mid
    return inside


def annulus(z: float) -> tuple[float, float]:
    """(r_min, r_max) of the TCP positions reachable with the tool down at height ``z``.

    Raises:
        RuntimeError: nothing is reachable at that height, or the reachable radii are not
            one interval (the model's assumption broken).
    """
    radii = np.arange(0.0, SCAN_MAX + SCAN_STEP, SCAN_STEP)
    ok = np.array([_reachable(float(r), z) for r in radii])
    hits = np.flatnonzero(ok)
    if not len(hits):
        raise RuntimeError(f"the UR10e reaches no TCP position with the tool down at z = {z} m")
    first, last = int(hits[0]), int(hits[-1])
    if not ok[first:last + 1].all():
        raise RuntimeError(f"the UR10e's reach at z = {z} m is not one annulus")
    r_min = 0.0 if first == 0 else _bisect(z, float(radii[first]), float(radii[first - 1]))
    r_max = _bisect(z, float(radii[last]), float(radii[last + 1]))
    return r_min, r_max


@functools.cache
def ur10e_reach(heights: tuple[float, ...] = ACTION_HEIGHTS,
                margin: float = REACH_MARGIN) -> Reach:
    """The annulus reachable at every one of ``heights``, shrunk by ``margin`` (cached)."""
    rings = [annulus(z) for z in heights]
    r_min = max(r[0] for r in rings) + margin
    r_max = min(r[1] for r in rings) - margin
    if not r_min < r_max:
        raise RuntimeError(f"no TCP position is reachable at all of the heights {heights}")
    return Reach(r_min, r_max)


def check_scene_reach(scene, reach: Reach | None = None) -> None:
    """Refuse a scene with a block or a goal slot out of the arm's reach, naming it.

    Raises:
        MessageError: the first block (``blocks[k]``) or slot (``goal.slots[k]``) whose
            centre the TCP cannot reach with the tool pointing down.
    """
    reach = reach or ur10e_reach()
    for k, block in enumerate(scene.blocks):
        if not reach.contains((block.x, block.y)):
            raise MessageError(f"blocks[{k}]", (block.x, block.y), _far(
                f"block {block.id} stands", block.x, block.y, reach))
    if scene.goal is None:
        return
    owners = _slot_owners(scene)
    for k, slot in enumerate(scene.goal.slot_poses(scene.block_size)):
        if not reach.contains((slot.x, slot.y)):
            what = (f"the goal of block {owners[k]} lies" if owners[k] is not None
                    else f"goal slot {k} lies")
            raise MessageError(f"goal.slots[{k}]", (slot.x, slot.y),
                               _far(what, slot.x, slot.y, reach))


def _far(what: str, x: float, y: float, reach: Reach) -> str:
    return (f"{what} {np.hypot(x, y):.2f} m from the robot base, out of the UR10e's reach "
            f"with the tool pointing down ({reach.describe()})")


def _slot_owners(scene) -> list[int | None]:
    """Block id per goal slot for a labeled goal (None for an unlabeled one)."""
    slots = scene.goal.slot_poses(scene.block_size)
    if not scene.goal.labeled:
        return [None] * len(slots)
    owner = {(round(p.x, 9), round(p.y, 9)): b for b, p in scene.goal_assignment().items()}
    return [owner.get((round(p.x, 9), round(p.y, 9))) for p in slots]
