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


def test_the_detector_side_learns_from_placements_and_corrects_what_it_publishes():
    from msgs_py import BlockPose, BlockSet
    from msgs_py.placement import Placement
    from nodes.detector.handeye import HandEye

    d, w = (0.004, -0.003), math.radians(0.4)
    hand_eye = HandEye(CORNERS, CENTRE)
    truth = {7: Pose2D(0.80, 0.20, 0.1), 8: Pose2D(0.55, -0.25, -0.2)}
    t = 0

    def frame():
        nonlocal t
        t += 10**9
        raw = BlockSet(tuple(BlockPose(b, *_xyt(perceive(p, d, w))) for b, p in truth.items()),
                       t)
        return hand_eye.correct(raw)

    out = frame()
    assert out.blocks[0].pose.distance_to(truth[7]) > 0.003  # not corrected yet
    for k, (block, goal) in enumerate([(7, Pose2D(0.70, 0.0, 0.0)), (8, Pose2D(0.70, 0.06, 0.0))]):
        sample = placement(truth[block], goal, k * math.pi / 2, d, w)
        hand_eye.on_placement(Placement(block, goal, sample.picked, k * math.pi / 2, t + 1))
        truth[block] = Pose2D(*_xyt(hand_eye_true(sample, d, w)))
        out = frame()
    assert hand_eye.log and "corrected from 2 placements" in hand_eye.log[0]
    for b in out.blocks:
        assert b.pose.distance_to(truth[b.id]) < 3e-4


def _xyt(p):
    return p.x, p.y, p.theta


def hand_eye_true(sample: Sample, d, w) -> Pose2D:
    """Where the block of ``sample`` truly stands (invert the camera's error)."""
    c = PlaneCorrection(d[0], d[1], w, *CENTRE)
    return c.apply(sample.seen)
