"""Which blocks moved between two detections: noise is not movement, a quarter turn is none."""

import math

from msgs_py import BlockPose, BlockSet
from nodes.planner.node import moved_blocks

OLD = BlockSet((BlockPose(1, 0.6, 0.0, 0.1), BlockPose(2, 0.7, 0.1, 0.0)), stamp_ns=1)


def test_detector_noise_and_the_cube_symmetry_are_not_movement():
    new = BlockSet((BlockPose(1, 0.60002, 0.0, 0.1 + math.pi / 2),
                    BlockPose(2, 0.7, 0.10003, math.radians(0.1))), stamp_ns=2)
    assert moved_blocks(OLD, new) == []


def test_a_shift_a_turn_or_a_newcomer_is_movement():
    new = BlockSet((BlockPose(1, 0.6, 0.002, 0.1), BlockPose(2, 0.7, 0.1, math.radians(1.0)),
                    BlockPose(3, 0.8, 0.0, 0.0)), stamp_ns=2)
    assert moved_blocks(OLD, new) == [1, 2, 3]
