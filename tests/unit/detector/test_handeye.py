"""The detector's correction from the arm's placements recovers a calibration error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py import Pose2D
from nodes.detector.handeye import PlaneCorrection, Sample, estimate, worth_correcting

CENTRE = (0.70, 0.0)
CORNERS = [(0.45, -0.35), (0.45, 0.35), (0.95, -0.35), (0.95, 0.35)]


def perceive(true: Pose2D, d, w) -> Pose2D:
    """What a camera with error (d, w) about CENTRE reports for a block at ``true``."""
    c, s = math.cos(w), math.sin(w)
    x, y = true.x - CENTRE[0], true.y - CENTRE[1]
    return Pose2D(c * x - s * y + CENTRE[0] + d[0], s * x + c * y + CENTRE[1] + d[1],
                  true.theta + w)


def placement(true_pick: Pose2D, goal: Pose2D, axis_yaw: float, d, w) -> Sample:
    """The physics of a pick-and-place with a miscalibrated camera: the arm grips where the
    camera says, the fingers centre the block along their axis only, it is set down with the
    TCP at the goal and looked at again."""
    picked = perceive(true_pick, d, w)
    a = np.array([math.cos(axis_yaw), math.sin(axis_yaw)])
    offset = np.array([true_pick.x - picked.x, true_pick.y - picked.y])
    across = offset - (offset @ a) * a  # what the fingers do not centre
    placed_true = Pose2D(goal.x + across[0], goal.y + across[1], goal.theta)
    return Sample(picked, goal, axis_yaw, perceive(placed_true, d, w))


@pytest.mark.parametrize("d, w_deg", [((0.003, 0.002), 0.0), ((0.005, -0.004), 0.5),
                                      ((-0.002, 0.001), -0.3)])
def test_a_few_placements_recover_the_error_and_the_correction_undoes_it(d, w_deg):
    w = math.radians(w_deg)
    rng = np.random.default_rng(1)
    samples = []
    for k in range(4):
        pick = Pose2D(rng.uniform(0.5, 0.9), rng.uniform(-0.3, 0.3), rng.uniform(-1, 1))
        goal = Pose2D(0.65 + 0.055 * (k % 2), -0.05 + 0.055 * (k // 2), 0.0)
        samples.append(placement(pick, goal, (k % 2) * math.pi / 2, d, w))
    est = estimate(samples, CENTRE)
    assert est is not None
    assert est.correction.dx == pytest.approx(d[0], abs=2e-4)
    assert est.correction.dy == pytest.approx(d[1], abs=2e-4)
    assert est.correction.w == pytest.approx(w, abs=math.radians(0.02))
    assert worth_correcting(est, samples, CORNERS)
    # corrected perception of any block is its true pose within a fraction of a millimetre
    for x, y in CORNERS:
        true = Pose2D(x, y, 0.3)
        fixed = est.correction.apply(perceive(true, d, w))
        assert fixed.distance_to(true) < 3e-4
        assert math.remainder(fixed.theta - true.theta, math.pi / 2) == pytest.approx(
            0.0, abs=math.radians(0.02))


def test_parallel_closing_axes_leave_it_undetermined_and_small_errors_alone():
    d, w = (0.003, 0.002), 0.0
    same_axis = [placement(Pose2D(0.6, 0.1 * k, 0.0), Pose2D(0.7, 0.05 * k, 0.0), 0.0, d, w)
                 for k in range(3)]
    est = estimate(same_axis, CENTRE)
    assert est is None or not worth_correcting(est, same_axis, CORNERS)
    tiny = [placement(Pose2D(0.6, 0.1 * k, 0.0), Pose2D(0.7, 0.05 * k, 0.0),
                      (k % 2) * math.pi / 2, (0.0001, 0.0), 0.0) for k in range(4)]
    est = estimate(tiny, CENTRE)
    assert est is not None and not worth_correcting(est, tiny, CORNERS)


def test_one_placement_is_not_enough():
    assert estimate([placement(Pose2D(0.6, 0, 0), Pose2D(0.7, 0, 0), 0.0, (0.003, 0), 0)],
                    CENTRE) is None


def test_a_correction_is_its_own_description():
    c = PlaneCorrection(0.003, -0.002, math.radians(0.5), 0.7, 0.0)
    assert "shift (+3.00, -2.00) mm, turn +0.500 deg" in c.describe()
