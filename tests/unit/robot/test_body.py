"""The robot's solids: posed by the same chain as the kinematics, and a silhouette that
covers what they cover."""

from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import Polygon

from nodes.common.transforms import pose_matrix, tool_down_quaternion
from nodes.robot.body import Solid, link_frames, posed_solids, surface_points
from nodes.robot.kinematics import flange_pose, solve_tcp_ik
from nodes.robot.silhouette import (
    MARGIN_PX,
    Silhouette,
    hulls_cover,
    robot_hulls,
    robot_silhouette,
    top_square,
)
from nodes.sim.config import HOME_JOINTS


@pytest.mark.parametrize("q", [HOME_JOINTS, (0.3, -1.0, 1.2, -1.7, -1.57, 0.4),
                               (-2.0, -2.2, -1.0, 0.5, 1.0, -3.0)])
def test_the_link_chain_ends_on_the_kinematics_flange(q):
    assert np.allclose(link_frames(q)["tool0"], flange_pose(q), atol=1e-12)


def test_the_fingers_stand_the_gap_apart_on_the_closing_axis():
    solids = posed_solids(HOME_JOINTS, 0.06, 0.014, 0.022)
    flange = flange_pose(HOME_JOINTS)
    left, right = solids[-2][1], solids[-1][1]
    # the fingers' centres a thickness further apart than the pads, along the flange's x
    centres = [(np.linalg.inv(flange) @ t)[0, 3] for t in (left, right)]
    assert centres[1] - centres[0] == pytest.approx(0.06 + 0.014, abs=1e-12)


def test_a_cylinders_corner_points_enclose_its_circle():
    points = surface_points(Solid("cylinder", (0.05, 0.2), (0, 0, 0)), np.eye(4))
    radii = np.hypot(points[:, 0], points[:, 1])
    assert np.all(radii >= 0.05) and np.ptp(points[:, 2]) == pytest.approx(0.2)


def overhead(points: np.ndarray) -> np.ndarray:
    """A camera 1.25 m over (0.7, 0), looking straight down, 1400 px focal length."""
    p = np.atleast_2d(points)
    depth = 1.25 - p[:, 2]
    return np.column_stack([640 + 1400 * (p[:, 0] - 0.7) / depth,
                            480 - 1400 * (p[:, 1]) / depth])


def test_a_tag_under_the_gripper_is_covered_and_one_far_from_the_arm_is_not():
    q = solve_tcp_ik(pose_matrix([0.7, 0.1, 0.1], tool_down_quaternion(0.0)), HOME_JOINTS).q
    sil = robot_silhouette(q, 0.085, overhead)
    under = overhead(top_square(0.7, 0.1, 0.2, 0.04, 0.0508))
    beside = overhead(top_square(0.9, -0.25, 0.0, 0.04, 0.0508))
    assert sil.covers(under) and not sil.covers(beside)
    assert Silhouette(sil.region, everything=True).covers(beside)


def test_a_robot_reaching_behind_the_camera_covers_everything():
    sil = robot_silhouette(HOME_JOINTS, 0.085, overhead, depth_fn=lambda p: np.full(len(p), -1.0))
    assert sil.everything


def test_the_quick_cover_test_agrees_with_the_silhouette_and_errs_only_towards_covered():
    """``hulls_cover`` (the executor's prediction, asked dozens of times a look) against
    ``Silhouette.covers`` (the detector's): the same verdict for tags on a 1 cm grid over the
    workspace, but where a tag's edge lies within a pixel of the margin (polygonal buffers
    against round growth), and there only ``covered``."""
    q = solve_tcp_ik(pose_matrix([0.75, -0.05, 0.1], tool_down_quaternion(0.3)), HOME_JOINTS).q
    hulls = robot_hulls(q, 0.085, overhead)
    sil = robot_silhouette(q, 0.085, overhead)
    squares = [overhead(top_square(x, y, 0.2, 0.04, 0.0508))
               for x in np.arange(0.45, 0.96, 0.01) for y in np.arange(-0.3, 0.31, 0.01)]
    quick = hulls_cover(hulls, squares)
    exact = [sil.covers(s) for s in squares]
    assert 100 < sum(exact) < len(squares) - 100  # both verdicts are tested
    for square, fast, slow in zip(squares, quick, exact, strict=True):
        if fast != slow:
            assert fast and not slow
            gap = min(h.distance(Polygon(square)) for h in hulls)
            assert abs(gap - 2 * MARGIN_PX) < 1.0
    assert hulls_cover(None, squares[:3]) == [True] * 3  # behind the camera: everything
