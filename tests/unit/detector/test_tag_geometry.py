"""Tag corner layout (docs/contracts.md) and the rigid 2-D fit behind the plane estimator."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from msgs_py import BlockPose
from nodes.detector.tag_geometry import (
    BLOCK_SIZE,
    TAG_CORNERS_LOCAL,
    fit_planar_pose,
    local_to_world_xy,
    tag_corners_world,
)


def test_corner_order_is_the_contracts():
    # theta = 0: top-left of the upright tag is block-local (-20, +20) mm, then clockwise.
    expected = [(-0.02, 0.02), (0.02, 0.02), (0.02, -0.02), (-0.02, -0.02)]
    np.testing.assert_allclose(TAG_CORNERS_LOCAL, expected)
    corners = tag_corners_world(BlockPose(3, 0.7, 0.1, math.pi / 2))
    # a quarter turn left: the tag's top-left corner moves to (-20, -20) around the centre
    np.testing.assert_allclose(corners[0], [0.68, 0.08, BLOCK_SIZE], atol=1e-12)


@given(x=st.floats(0.4, 1.0), y=st.floats(-0.4, 0.4), theta=st.floats(-math.pi, math.pi))
def test_fit_recovers_an_exact_pose(x, y, theta):
    world = local_to_world_xy(x, y, theta, TAG_CORNERS_LOCAL)
    fx, fy, ftheta = fit_planar_pose(world)
    assert math.hypot(fx - x, fy - y) < 1e-12
    assert abs(math.remainder(ftheta - theta, 2 * math.pi)) < 1e-12


def test_fit_averages_corner_noise():
    rng = np.random.default_rng(1)
    world = local_to_world_xy(0.7, 0.0, 0.3, TAG_CORNERS_LOCAL)
    errors = []
    for _ in range(200):
        x, y, _ = fit_planar_pose(world + rng.normal(0, 1e-4, world.shape))
        errors.append(math.hypot(x - 0.7, y))
    # 4 corners with 0.1 mm noise per axis: the centre is good to ~0.1 mm / sqrt(4) per axis
    assert np.median(errors) < 1e-4
