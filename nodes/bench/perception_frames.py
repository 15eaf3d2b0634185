"""What the perception benchmark measures on: frames with their truth, the seeded scenes,
and the lenses it renders them through (also the lenses the detector's tests check).

A ``Frame`` carries its image, the camera the detector reads it with (decoded from the
frame's camera_info as the detector node decodes it), the true block poses and which tags
are fully in view. Kept apart from ``perception`` (the evaluation) and ``sim_frames`` (the
PyBullet renderer) so that the two import it and not each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from msgs_py import BlockPose, Scene
from msgs_py.camera import EQUIDISTANT, PLUMB_BOB, RATIONAL_POLYNOMIAL, CameraIntrinsics
from nodes.common.scenes import BLOCK_SIZE, scatter_blocks, workspace_for
from nodes.sim.camera import LENS_COEFFICIENTS


@dataclass
class Frame:
    """One rendered image with its truth."""

    situation: str
    image: np.ndarray
    intrinsics: CameraIntrinsics  # the camera the detector reads it with
    truth: dict[int, BlockPose]
    unoccluded: set[int]
    occluded: set[int] = field(default_factory=set)  # not fully visible (informational)
    warmup: np.ndarray | None = None  # an arm-parked frame of the same scene, seen first
    lens: str = ""  # which lens (and camera_info) the row is about


#: The extra rows a lens's frames may give (``LensCase.variants``).
P_EQUALS_K = "p = k"
RECTIFIED = "rectified"


@dataclass(frozen=True)
class LensCase:
    """A lens the sim's camera renders the scenes through, and the extra rows its frames
    give: ``p = k`` (camera_info with p = k, as the sim published it before p was the
    optimal new camera matrix) and ``rectified`` (the frame rectified as image_proc does,
    read with p and no distortion)."""

    model: str
    d: tuple[float, ...]
    variants: tuple[str, ...] = ()


#: The sim camera's lens in each model (``nodes.sim.camera.LENS_COEFFICIENTS``: one lens,
#: the forms within 0.03 px of each other), so the rows differ only in the model's maths.
#: The first is the one the arm-over-blocks frames and ``--compare`` use.
LENSES = {
    PLUMB_BOB: LensCase(PLUMB_BOB, LENS_COEFFICIENTS[PLUMB_BOB], (P_EQUALS_K, RECTIFIED)),
    RATIONAL_POLYNOMIAL: LensCase(RATIONAL_POLYNOMIAL, LENS_COEFFICIENTS[RATIONAL_POLYNOMIAL],
                                  (RECTIFIED,)),
    EQUIDISTANT: LensCase(EQUIDISTANT, LENS_COEFFICIENTS[EQUIDISTANT], (RECTIFIED,)),
}


def scene_for(seed: int, density: float) -> Scene:
    """Seeded scene of 9-25 blocks, uniform count, scattered (no goal needed)."""
    rng = np.random.default_rng(10_000 + seed)
    n = int(rng.integers(9, 26))
    workspace = workspace_for(n, density)
    return Scene(workspace, BLOCK_SIZE, scatter_blocks(n, workspace, rng, min_gap=0.002))
