"""The detector's correction from the arm's placements recovers a calibration error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from msgs_py import Pose2D
from nodes.detector.handeye import (
    PlaneCorrection,
    Sample,
    estimate,
    robust_estimate,
    worth_correcting,
)

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


def test_a_placement_disturbed_after_release_is_left_out_and_the_rest_still_agree():
    d, w = (0.012, -0.004), math.radians(0.3)
    samples = [placement(Pose2D(0.8, 0.2, 0.4), Pose2D(0.8, 0.2, 0.4), 0.4, d, w),
               placement(Pose2D(0.8, 0.2, 0.4), Pose2D(0.8, 0.2, 0.4), 0.4 + math.pi / 2, d, w),
               placement(Pose2D(0.6, -0.1, 0.0), Pose2D(0.70, 0.0, 0.0), 0.0, d, w),
               placement(Pose2D(0.55, 0.2, 1.0), Pose2D(0.7538, 0.0, 0.0), math.pi / 2, d, w)]
    knocked = samples[2]  # a neighbour's placement pushed it 4 mm after the arm let go
    samples[2] = Sample(knocked.picked, knocked.placed, knocked.axis_yaw,
                        Pose2D(knocked.seen.x + 0.004, knocked.seen.y, knocked.seen.theta))
    assert abs(estimate(samples, CENTRE).correction.dx - d[0]) > 5e-4  # pulled off by it
    est, dropped = robust_estimate(samples, CENTRE)
    assert dropped == [samples[2]]
    assert est.correction.dx == pytest.approx(d[0], abs=2e-4)
    assert est.correction.dy == pytest.approx(d[1], abs=2e-4)
    # two samples are never thinned: nothing to tell which one is wrong
    assert robust_estimate(samples[:2], CENTRE)[1] == []


def test_placements_gripped_through_a_correction_agree_with_those_before_it():
    d, w = (0.0135, -0.0039), math.radians(0.2)
    at = Pose2D(0.8, 0.2, 0.4)
    first = [placement(at, at, 0.4, d, w), placement(at, at, 0.4 + math.pi / 2, d, w)]
    correction = estimate(first, CENTRE).correction
    # later picks: the arm grips where the corrected perception puts the block, which is
    # (nearly) where it is: the block keeps almost no offset across the fingers
    later = []
    for true, goal, axis in [(Pose2D(0.6, -0.1, 0.2), Pose2D(0.7, 0.0, 0.0), 0.0),
                             (Pose2D(0.55, 0.25, 1.0), Pose2D(0.7538, -0.0538, 0.0), 1.2)]:
        seen_before = perceive(true, d, w)
        gripped = correction.apply(seen_before)
        a = np.array([math.cos(axis), math.sin(axis)])
        off = np.array([true.x - gripped.x, true.y - gripped.y])
        across = off - (off @ a) * a
        down = Pose2D(goal.x + across[0], goal.y + across[1], goal.theta)
        later.append(Sample(seen_before, goal, axis, perceive(down, d, w), gripped))
    est, dropped = robust_estimate(first + later, CENTRE)
    assert dropped == []
    assert est.rms_residual < 1e-4
    assert est.correction.dx == pytest.approx(d[0], abs=2e-4)


def test_the_camera_checks_two_regrips_with_noisy_yaws_correct_the_shift_at_least():
    from msgs_py import BlockPose, BlockSet
    from msgs_py.placement import Placement
    from nodes.detector.handeye import HandEye

    d = (0.0135, -0.0039)  # a pure shift; the yaws below read 0.3 deg high (noise)
    hand_eye = HandEye(CORNERS, CENTRE)
    at = Pose2D(0.80, 0.20, 0.3)
    true, t = at, 0
    for k, yaw_noise in enumerate((0.3, 0.3)):
        sample = placement(true, at, 0.3 + k * math.pi / 2, d, 0.0)
        hand_eye.on_placement(Placement(3, at, sample.picked, 0.3 + k * math.pi / 2, t + 1))
        true = Pose2D(*_xyt(hand_eye_true(sample, d, 0.0)))
        t += 10**9
        seen = sample.seen
        out = hand_eye.correct(BlockSet((BlockPose(3, seen.x, seen.y,
                                                   seen.theta + math.radians(yaw_noise)),), t))
    assert hand_eye.log and "corrected from 2 placements" in hand_eye.log[0], hand_eye.log
    assert out.blocks[0].pose.distance_to(true) < 3e-4


def squared(true_pick: Pose2D, axis_yaw: float, d, w) -> Sample:
    """The camera check's physics: the arm goes down where the camera says, grips along one
    axis then the other at that TCP; the block then stands on the TCP, squared with it."""
    picked = perceive(true_pick, d, w)
    at = Pose2D(picked.x, picked.y, axis_yaw)
    return Sample(picked, at, axis_yaw, perceive(at, d, w), squared=True)


@pytest.mark.parametrize("d", [(0.0135, -0.0039), (-0.004, 0.009)])
def test_one_squared_placement_pins_the_shift_where_it_stands(d):
    sample = squared(Pose2D(0.80, 0.20, 0.3), 0.3, d, 0.0)
    est = estimate([sample], CENTRE, with_turn=False)
    assert est is not None
    assert est.correction.dx == pytest.approx(d[0], abs=1e-9)
    assert est.correction.dy == pytest.approx(d[1], abs=1e-9)
    assert worth_correcting(est, [sample], CORNERS)
    # read as a one-axis placement (the model before), the same numbers miss the shift
    # across the closing axis entirely
    plain = Sample(sample.picked, sample.placed, sample.axis_yaw, sample.seen)
    assert estimate([plain], CENTRE, with_turn=False) is None


def test_a_squared_placement_and_a_turned_camera_agree_with_later_placements():
    d, w = (0.005, -0.004), math.radians(0.5)
    first = squared(Pose2D(0.80, 0.20, 0.3), 0.3, d, w)
    # the camera's error at the check's spot, whatever its turn
    est = estimate([first], CENTRE, with_turn=False)
    seen_fixed = est.correction.apply(first.seen)
    assert seen_fixed.distance_to(first.placed) < 1e-9
    later = [placement(Pose2D(0.6, -0.1, 0.2), Pose2D(0.7, 0.0, 0.0), 0.0, d, w),
             placement(Pose2D(0.55, 0.25, 1.0), Pose2D(0.62, -0.25, 0.0), 1.2, d, w)]
    est, dropped = robust_estimate([first, *later], CENTRE)
    assert dropped == []
    assert est.correction.w == pytest.approx(w, abs=math.radians(0.01))
    assert est.correction.dx == pytest.approx(d[0], abs=1e-4)


def test_a_block_set_down_again_before_it_was_seen_counts_once_where_it_was_last_left():
    from msgs_py import BlockPose, BlockSet
    from msgs_py.placement import Placement
    from nodes.detector.handeye import HandEye

    d = (0.0135, -0.0039)
    hand_eye = HandEye(CORNERS, CENTRE)
    true = Pose2D(0.80, 0.20, 0.3)
    sample = squared(true, 0.3, d, 0.0)
    # the check's first grip lets go (one axis) and grips again at once (both): one sample
    hand_eye.on_placement(Placement(3, sample.placed, sample.picked, 0.3, 1))
    hand_eye.on_placement(Placement(3, sample.placed, sample.picked, 0.3 + math.pi / 2, 2,
                                    squared=True))
    seen = sample.seen
    out = hand_eye.correct(BlockSet((BlockPose(3, seen.x, seen.y, seen.theta),), 10**9))
    assert len(hand_eye.samples) == 1 and hand_eye.samples[0].squared
    assert hand_eye.log and "corrected from 1 placement of" in hand_eye.log[0], hand_eye.log
    assert out.blocks[0].pose.distance_to(sample.placed) < 1e-6


def test_placements_that_no_correction_explains_are_not_applied():
    d = (0.0135, -0.0039)
    first = squared(Pose2D(0.80, 0.20, 0.3), 0.3, d, 0.0)
    # a block picked while lying tilted on another: its placement is 2 cm from the model
    wild = placement(Pose2D(0.6, -0.1, 0.2), Pose2D(0.7, 0.0, 0.0), 0.0, d, 0.0)
    wild = Sample(wild.picked, wild.placed, wild.axis_yaw,
                  Pose2D(wild.seen.x + 0.02, wild.seen.y - 0.01, wild.seen.theta))
    est, dropped = robust_estimate([first, wild], CENTRE)
    assert dropped == [] and est.rms_residual > 0.0015  # two samples: not thinned
    assert not worth_correcting(est, [first, wild], CORNERS)


def run_placements(d, w, goals, seed, yaw_noise_deg=0.3, position_noise=0.0002):
    """The camera check then a pick-and-place onto each of ``goals``, through ``HandEye``: the
    arm grips where the corrected perception says, the fingers centre the block along their
    axis only, and it lands with a little noise. Returns the HandEye and the true poses."""
    from msgs_py import BlockPose, BlockSet
    from msgs_py.placement import Placement
    from nodes.detector.handeye import HandEye

    rng = np.random.default_rng(seed)
    hand_eye = HandEye(CORNERS, CENTRE)
    truth = {0: Pose2D(0.85, 0.25, 0.3)}
    truth.update({k + 1: Pose2D(rng.uniform(0.5, 0.9), rng.uniform(-0.3, 0.3), rng.uniform(-1, 1))
                  for k in range(len(goals))})
    t = 0

    def look():
        nonlocal t
        t += 20 * 10**9  # a pick-and-place later
        raw = BlockSet(tuple(BlockPose(b, *_xyt(perceive(p, d, w))) for b, p in truth.items()), t)
        return {b.id: b.pose for b in hand_eye.correct(raw).blocks}

    seen = look()
    check = seen[0]  # the camera check: gripped on both axes where it is seen
    hand_eye.on_placement(Placement(0, check, check, 0.3, t + 1, squared=True))
    truth[0] = Pose2D(check.x, check.y, check.theta)
    for k, goal in enumerate(goals):
        block = k + 1
        seen = look()
        gripped, axis = seen[block], float(rng.integers(4)) * math.pi / 2 + goal.theta
        a = np.array([math.cos(axis), math.sin(axis)])
        off = np.array([truth[block].x - gripped.x, truth[block].y - gripped.y])
        across = off - (off @ a) * a + rng.normal(0.0, position_noise, 2)
        hand_eye.on_placement(Placement(block, goal, gripped, axis, t + 1))
        truth[block] = Pose2D(goal.x + across[0], goal.y + across[1],
                              goal.theta + math.radians(rng.normal(0.0, yaw_noise_deg)))
    return hand_eye, truth, look()


GRID = [Pose2D(0.65 + 0.0528 * (k % 3), -0.05 + 0.0528 * (k // 3), 0.0) for k in range(9)]


@pytest.mark.parametrize("seed", range(4))
def test_placements_that_agree_with_the_correction_in_use_leave_the_view_where_it_is(seed):
    """Every move of the view shifts every block the executor checks (a replan when it moves
    them past the placed tolerance): a correction that still explains every placement within
    their noise is kept. Before, each placement moved it again, by turns the camera did not
    have (0.1-0.2 deg, seen in the cell's logs)."""
    hand_eye, truth, seen = run_placements((0.0135, -0.0039), 0.0, GRID, seed)
    corrections = [line for line in hand_eye.log if line.startswith("perception corrected")]
    assert len(corrections) <= 2, corrections
    assert all(seen[b].distance_to(p) < 6e-4 for b, p in truth.items())


@pytest.mark.parametrize("seed", range(4))
def test_a_turn_the_check_could_not_see_is_learnt_from_the_placements(seed):
    hand_eye, truth, seen = run_placements((0.005, -0.004), math.radians(0.5), GRID, seed)
    assert abs(math.degrees(hand_eye.correction.w) - 0.5) < 0.15
    assert all(seen[b].distance_to(p) < 6e-4 for b, p in truth.items())


def test_one_squared_placement_whose_yaw_reads_a_little_off_corrects_the_shift_only():
    """Seen in the cell (30 scenes at c09bf72, seed 12): the camera check's one placement,
    its yaw read 0.2 deg off (within a placement's noise), gave a turn of 0.2 deg, which moved
    blocks 0.3 m away by 1 mm. One placement pins the turn only through that yaw."""
    from msgs_py import BlockPose, BlockSet
    from msgs_py.placement import Placement
    from nodes.detector.handeye import HandEye

    d = (-0.00018, -0.00007)  # the camera check's shift in that run: too small to apply
    sample = squared(Pose2D(0.71, 0.02, 0.3), 0.3, d, 0.0)  # near the centre, as there
    hand_eye = HandEye(CORNERS, CENTRE)
    hand_eye.on_placement(Placement(3, sample.placed, sample.picked, 0.3, 1, squared=True))
    seen = sample.seen
    hand_eye.correct(BlockSet((BlockPose(3, seen.x, seen.y, seen.theta + math.radians(0.2)),),
                              10**9))
    assert hand_eye.correction.w == 0.0
    far = hand_eye.correct(BlockSet((BlockPose(5, 0.95, 0.30, 0.0),), 2 * 10**9)).blocks[0]
    assert math.hypot(far.x - 0.95, far.y - 0.30) < 3e-4  # before: moved by 1.2 mm


def test_a_placement_whose_block_the_arm_covers_waits_for_a_frame_that_shows_it():
    """The frame after the camera check, taken as the arm moves on, has the block covered:
    the placement is kept for the next frame that shows it (it was dropped, the check's only
    placement with it, and a 5 mm / 0.5 deg offset was never corrected); a frame that shows
    neither the block nor the arm over it drops it."""
    from msgs_py import BlockPose, BlockSet
    from msgs_py.placement import Placement
    from nodes.detector.handeye import HandEye

    d = (0.0135, -0.0039)
    true = Pose2D(0.80, 0.20, 0.3)
    sample = squared(true, 0.3, d, 0.0)
    seen = BlockPose(3, sample.seen.x, sample.seen.y, sample.seen.theta)
    for later, kept in ((BlockSet((), 3 * 10**9, occluded=(3,)), True),
                        (BlockSet((), 3 * 10**9, missing=(3,)), False)):
        hand_eye = HandEye(CORNERS, CENTRE)
        hand_eye.on_placement(Placement(3, sample.placed, sample.picked, 0.3 + math.pi / 2,
                                        10**9, squared=True))
        hand_eye.correct(later)
        hand_eye.correct(BlockSet((seen,), 4 * 10**9))
        assert len(hand_eye.samples) == int(kept)
        assert bool(hand_eye.log) == kept


def test_a_pushed_block_is_no_equation_and_ends_the_wait_of_its_placement():
    """A block set down on its push line and pushed before a frame showed it: the frame
    shows it where the push left it, which says nothing of where it was let go. The push's
    report drops the waiting placement and adds none of its own."""
    from msgs_py import BlockPose, BlockSet
    from msgs_py.placement import Placement
    from nodes.detector.handeye import HandEye

    d = (0.0135, -0.0039)
    true = Pose2D(0.80, 0.20, 0.3)
    sample = squared(true, 0.3, d, 0.0)
    pushed_to = Pose2D(sample.placed.x + 0.04, sample.placed.y, sample.placed.theta)
    for push in (False, True):
        hand_eye = HandEye(CORNERS, CENTRE)
        hand_eye.on_placement(Placement(3, sample.placed, sample.picked, 0.3 + math.pi / 2,
                                        10**9, squared=True))
        if push:
            hand_eye.on_placement(Placement(3, pushed_to, sample.placed, 0.3, 2 * 10**9,
                                            pushed=True))
        seen = sample.seen if not push else Pose2D(sample.seen.x + 0.04, sample.seen.y,
                                                   sample.seen.theta)
        hand_eye.correct(BlockSet((BlockPose(3, seen.x, seen.y, seen.theta),), 3 * 10**9))
        assert len(hand_eye.samples) == (0 if push else 1)
        assert not hand_eye.pending
