"""The UR10e's reach with the tool pointing down, on its working branch: which TCP positions
a plan, and a generated scene, may use.

The arm works the table on one branch of its IK, the one it starts on
(``ur10e.WORKING_BRANCH_JOINTS``): elbow up, wrist 2 at +90 deg, the shoulder turned so the
arm reaches over its front. Near full stretch (about 1.06 m from the base at the travel
height) that branch ends: the elbow straightens and what remains is the other wrist branch,
a reconfiguration of wrist 1 by about 200 deg and of wrist 3 by 180. A stream of Cartesian
setpoints across that border makes the arm controller's nearest-branch IK swing the wrist at
the bottom of a descent, beside other blocks, and crawl through it (measured: 6-7 s for the
last centimetre of a descent). So the reach is the working branch's, not every branch's
(0.18-1.29 m): a plan never crosses the border, and the scene generators draw within it.

Every point a plan puts the TCP at (over and at a grasped block, behind a pushed block at the
start and the end of the push, the straight carries between them) is checked against the
arm's own kinematic model, ``nodes.robot.kinematics.solve_tcp_ik`` (the UR10e's DH
parameters, closed-form IK through ``ur_analytic_ik``, branches with the elbow or a wrist
near the table discarded), the very model the arm controller uses.

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
from nodes.robot import ur10e
from nodes.robot.kinematics import solve_tcp_ik

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


def on_working_branch(q, azimuth: float) -> bool:
    """Whether joints ``q`` put the arm on its working branch for a TCP at ``azimuth`` (rad,
    about the base's z axis): elbow up (``q[2] > 0``), wrist 2 at +90 deg (``q[4] > 0``) and
    the shoulder within 90 deg of ``azimuth + pi`` (the other shoulder solution is about
    180 deg away)."""
    shoulder = (float(q[0]) - azimuth) % (2.0 * np.pi) - np.pi
    return bool(q[2] > 0.0 and q[4] > 0.0 and abs(shoulder) < 0.5 * np.pi)


def working_reference(azimuth: float) -> np.ndarray:
    """The working branch's joints turned to face ``azimuth``: the IK's reference there."""
    q = np.asarray(ur10e.WORKING_BRANCH_JOINTS, dtype=float).copy()
    q[0] = azimuth + np.pi
    return q


def working_branch_reaches(x: float, y: float, z: float, yaw: float = 0.0) -> bool:
    """Whether the arm's IK puts the TCP at (x, y, z) with the tool down at ``yaw`` on the
    working branch."""
    t = np.eye(4)
    t[:3, :3] = tool_down_matrix(yaw)
    t[:3, 3] = (x, y, z)
    azimuth = float(np.arctan2(y, x))
    ik = solve_tcp_ik(t, working_reference(azimuth))
    return ik.ok and on_working_branch(ik.q, azimuth)


def _reachable(r: float, z: float) -> bool:
    return working_branch_reaches(r, 0.0, z)


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
    """(r_min, r_max) of the TCP positions the working branch reaches with the tool down at
    height ``z``.

    Raises:
        RuntimeError: nothing is reachable at that height, or the reachable radii are not
            one interval (the model's assumption broken).
    """
    radii = np.arange(0.0, SCAN_MAX + SCAN_STEP, SCAN_STEP)
    ok = np.array([_reachable(float(r), z) for r in radii])
    hits = np.flatnonzero(ok)
    if not len(hits):
        raise RuntimeError(f"the UR10e's working branch reaches no TCP position with the tool "
                           f"down at z = {z} m")
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
            f"with the tool pointing down on its working branch ({reach.describe()})")


def _slot_owners(scene) -> list[int | None]:
    """Block id per goal slot for a labeled goal (None for an unlabeled one)."""
    slots = scene.goal.slot_poses(scene.block_size)
    if not scene.goal.labeled:
        return [None] * len(slots)
    owner = {(round(p.x, 9), round(p.y, 9)): b for b, p in scene.goal_assignment().items()}
    return [owner.get((round(p.x, 9), round(p.y, 9))) for p in slots]
