"""The robot's body as simple solids (cylinders and boxes), posed for given joints.

One home for the shapes: the sim's URDF is generated from them (``sim_assets/make_assets.py``)
and the silhouette the camera sees (``nodes.robot.silhouette``) is computed from them, so the
simulated arm and the one the detector masks out cannot drift apart. They follow the UR10e's
outline (tubes at the UR's sideways offsets, the joint housings) and a 2F-85-class gripper
(a coupling disc, the body, two fingers); a real arm is within a centimetre of them, which
the silhouette's margin covers.

Link frames are the URDF's: ``L_i = L_{i-1} T(a_{i-1}, 0, d_{i-1}) Rx(alpha_{i-1}) Rz(q_i)``
(one link frame per DH joint, so the chain *is* the DH chain), the flange ``tool0`` after the
last, the gripper on the flange with x its closing axis.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e

HALF_PI = math.pi / 2
ALONG_X = (0.0, HALF_PI, 0.0)  #: rpy turning a cylinder's axis (z) onto x
ALONG_Y = (HALF_PI, 0.0, 0.0)  #: ... onto y


@dataclass(frozen=True, slots=True)
class Solid:
    """A cylinder (``dims`` = radius, length; axis along z) or a box (``dims`` = x, y, z
    sizes), centred at ``xyz`` and turned by ``rpy`` in its link's frame (m, rad)."""

    kind: str
    dims: tuple[float, ...]
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)
    color: str = "blue"


#: The arm's solids per URDF link, in the link frame (z = the joint axis).
ARM_SOLIDS: dict[str, tuple[Solid, ...]] = {
    "base_link": (Solid("cylinder", (0.095, 0.06), (0, 0, 0.03), color="grey"),),
    "shoulder_link": (
        Solid("cylinder", (0.075, 0.115), (0, 0, 0.1807 - 0.0575)),
        Solid("cylinder", (0.075, 0.15), (0, -0.085, 0.1807), ALONG_Y, "grey"),
    ),
    "upper_arm_link": (
        Solid("cylinder", (0.06, 0.50), (-0.6127 / 2, 0, 0.176), ALONG_X, "grey"),
        Solid("cylinder", (0.075, 0.12), (-0.6127, 0, 0.12)),
    ),
    "forearm_link": (
        Solid("cylinder", (0.045, 0.48), (-0.57155 / 2, 0, 0.045), ALONG_X, "grey"),
        Solid("cylinder", (0.047, 0.09), (-0.57155, 0, 0.09)),
    ),
    "wrist_1_link": (Solid("cylinder", (0.046, 0.10), (0, -0.04, 0.17415), ALONG_Y),),
    "wrist_2_link": (Solid("cylinder", (0.046, 0.10), (0, 0.04, 0.11985), ALONG_Y),),
    "wrist_3_link": (Solid("cylinder", (0.045, 0.045), (0, 0, 0.11655 - 0.0225), color="dark"),),
}
#: The links the arm's joints move, in kinematic order (the base is fixed).
ARM_LINKS = tuple(name for name in ARM_SOLIDS if name != "base_link")

#: The gripper: a coupling disc on the flange, the body, fingers FINGER_LENGTH long below it.
COUPLING_RADIUS = 0.0375
COUPLING_LENGTH = 0.011
BODY_SIZE_XY = (0.125, 0.060)
BODY_HEIGHT = g85.TCP_OFFSET - g85.FINGER_LENGTH - COUPLING_LENGTH
#: The finger's link frame stands on the body's underside, on the closing axis.
FINGER_BASE_Z = g85.TCP_OFFSET - g85.FINGER_LENGTH


def gripper_solids() -> tuple[Solid, ...]:
    """The gripper body's solids in the flange frame."""
    return (
        Solid("cylinder", (COUPLING_RADIUS, COUPLING_LENGTH), (0, 0, COUPLING_LENGTH / 2),
              color="dark"),
        Solid("box", (*BODY_SIZE_XY, BODY_HEIGHT), (0, 0, COUPLING_LENGTH + BODY_HEIGHT / 2),
              color="dark"),
    )


def finger_solid(side: int, thickness: float, width: float) -> Solid:
    """One finger in its own link frame (``side`` -1 left, +1 right of the TCP)."""
    return Solid("box", (thickness, width, g85.FINGER_LENGTH),
                 (side * thickness / 2, 0, g85.FINGER_LENGTH / 2), color="dark")


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1.0]])


def _rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def _translate(x: float, y: float, z: float) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = (x, y, z)
    return t


def solid_pose(solid: Solid) -> np.ndarray:
    """The solid's pose in its link frame (URDF rpy: fixed-axis roll, pitch, yaw)."""
    r, p, y = solid.rpy
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p),
                              math.cos(y), math.sin(y))
    t = np.eye(4)
    t[:3, :3] = [[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                 [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                 [-sp, cp * sr, cp * cr]]
    t[:3, 3] = solid.xyz
    return t


def link_frames(q: Sequence[float]) -> dict[str, np.ndarray]:
    """Each URDF link's frame in ``world`` (the base's is the identity), and ``tool0``."""
    frames = {"base_link": np.eye(4)}
    t = np.eye(4)
    for i, link in enumerate(ARM_LINKS):
        if i > 0:
            t = t @ _translate(ur10e.DH_A[i - 1], 0.0, ur10e.DH_D[i - 1]) \
                @ _rot_x(ur10e.DH_ALPHA[i - 1])
        t = t @ _rot_z(float(q[i]))
        frames[link] = t
    frames["tool0"] = t @ _translate(ur10e.DH_A[5], 0.0, ur10e.DH_D[5]) \
        @ _rot_x(ur10e.DH_ALPHA[5])
    return frames


def posed_solids(q: Sequence[float], gap: float, finger_thickness: float,
                 finger_width: float) -> list[tuple[Solid, np.ndarray]]:
    """Every solid of the arm and the gripper with its pose in ``world``, for joints ``q``
    (rad, kinematic order) and the fingers ``gap`` apart (m, between the pads)."""
    frames = link_frames(q)
    out = [(s, frames[link] @ solid_pose(s)) for link, solids in ARM_SOLIDS.items()
           for s in solids]
    flange = frames["tool0"]
    out += [(s, flange @ solid_pose(s)) for s in gripper_solids()]
    for side in (-1, 1):
        finger = flange @ _translate(side * gap / 2, 0.0, FINGER_BASE_Z)
        solid = finger_solid(side, finger_thickness, finger_width)
        out.append((solid, finger @ solid_pose(solid)))
    return out


def surface_points(solid: Solid, pose: np.ndarray, segments: int = 16) -> np.ndarray:
    """(n, 3) points in ``world`` whose convex hull is the solid (a cylinder's two rims as
    ``segments``-gons circumscribing them; a box's eight corners)."""
    local = _local_points(solid.kind, tuple(solid.dims), segments)
    return local @ pose[:3, :3].T + pose[:3, 3]


@functools.lru_cache(maxsize=64)
def _local_points(kind: str, dims: tuple[float, ...], segments: int) -> np.ndarray:
    """``surface_points`` in the solid's own frame (the same for every pose: computed once;
    a look's prediction poses the arm dozens of times)."""
    if kind == "box":
        half = np.asarray(dims) / 2
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        local = corners * half
    else:
        radius, length = dims
        angles = np.linspace(0.0, 2 * math.pi, segments, endpoint=False)
        r = radius / math.cos(math.pi / segments)  # the polygon contains the circle
        rim = np.column_stack([r * np.cos(angles), r * np.sin(angles)])
        local = np.vstack([np.column_stack([rim, np.full(segments, z)])
                           for z in (-length / 2, length / 2)])
    local.flags.writeable = False
    return local
