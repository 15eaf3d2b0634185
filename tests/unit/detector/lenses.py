"""The sim's camera with each lens model of the perception benchmark, and test points."""

from __future__ import annotations

import numpy as np

from msgs_py import BlockPose
from msgs_py.camera import CameraPose
from nodes.bench.perception_frames import LENSES
from nodes.sim.camera import SimCamera
from nodes.sim.config import CameraConfig

MODELS = sorted(LENSES)
#: Blocks over the whole default workspace, out to its far corners, every yaw quadrant.
BLOCKS = [BlockPose(k, x, y, 0.4 * k - 2.0) for k, (x, y) in enumerate(
    (x, y) for x in (0.47, 0.70, 0.93) for y in (-0.33, 0.0, 0.33))]
#: World points spread over the view, on the table and on the tag plane.
POINTS = np.array([[x, y, z] for x in (0.42, 0.7, 0.98) for y in (-0.38, 0.0, 0.38)
                   for z in (0.0, 0.0508)])


def sim_camera(model: str, **overrides) -> SimCamera:
    """config/sim.yaml's camera with the benchmark's lens of ``model``."""
    return CameraConfig(distortion_model=LENSES[model].model, distortion=LENSES[model].d,
                        **overrides).model()


def sim_pose(camera: SimCamera) -> CameraPose:
    return CameraPose(tuple(camera.position), tuple(camera.orientation_xyzw))
