"""Block pose from corners: the plane and PnP estimators."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py import BlockPose
from nodes.bench.perception_frames import LENSES
from nodes.detector.estimate import ESTIMATORS, estimate_on_plane
from nodes.detector.synthetic import overhead_camera
from nodes.detector.tag_geometry import BLOCK_SIZE, tag_corners_world

CAMERA = overhead_camera()
#: The sim's camera: fx 1400 px and its lens in the plumb_bob form.
LENS_CAMERA = overhead_camera(focal_px=1400.0, distortion=(-0.10, 0.08, 0.0002, -0.00015, 0.0))
#: The same lens in the other models (the perception benchmark's).
OTHER_LENSES = [overhead_camera(focal_px=1400.0, distortion=LENSES[m].d,
                                distortion_model=LENSES[m].model)
                for m in ("rational_polynomial", "equidistant")]


@pytest.mark.parametrize("camera", [CAMERA, LENS_CAMERA, *OTHER_LENSES],
                         ids=["pinhole", "lens", "rational_polynomial", "equidistant"])
@pytest.mark.parametrize("method", sorted(ESTIMATORS))
@pytest.mark.parametrize("block", [BlockPose(0, 0.7, 0.0, 0.0), BlockPose(1, 0.5, -0.3, 2.9),
                                   BlockPose(2, 0.93, 0.33, -1.2)])
def test_exact_corners_give_the_exact_pose(method, block, camera):
    est = ESTIMATORS[method](camera, camera.project(tag_corners_world(block)))
    assert math.hypot(est.x - block.x, est.y - block.y) < 1e-6
    assert abs(math.remainder(est.theta - block.theta, 2 * math.pi)) < 1e-6
    assert est.reprojection_px < 1e-3


def test_plane_beats_pnp_on_noisy_corners():
    rng = np.random.default_rng(3)
    block = BlockPose(0, 0.55, 0.25, 0.4)
    exact = CAMERA.project(tag_corners_world(block))
    errors = {name: [] for name in ESTIMATORS}
    for _ in range(100):
        corners = exact + rng.normal(0.0, 0.15, exact.shape)
        for name, fn in ESTIMATORS.items():
            est = fn(CAMERA, corners)
            errors[name].append(math.hypot(est.x - block.x, est.y - block.y))
    assert np.median(errors["plane"]) < 0.3e-3
    assert np.median(errors["plane"]) < 0.5 * np.median(errors["pnp"])


def test_a_lifted_tag_does_not_fit_the_table_plane():
    # a block 10 cm up in the gripper: its tag looks ~8 % too big for one on the table
    lifted = tag_corners_world(BlockPose(0, 0.6, 0.1, 0.3), block_size=BLOCK_SIZE + 0.10)
    est = estimate_on_plane(CAMERA, CAMERA.project(lifted))
    assert est.reprojection_px > 1.0
