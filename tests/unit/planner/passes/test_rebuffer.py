"""Rebuffering sends a block, with hindsight, where one move less does: its next end, or a pose
on the push line into its slot, at a moment between its two moves."""

from __future__ import annotations

from msgs_py import BlockPose, PickPlace, Pose2D, Push
from nodes.planner.passes.rebuffer import line_buffers, rebuffer
from nodes.planner.passes.shortcut import shortcut

from .walled_slot import WALLS, G, S, ctx_and_start, feasible

A, B = Pose2D(0.5, 0.0, 0.0), Pose2D(0.5, 0.2, 0.0)
Y0, Z = Pose2D(0.9, -0.2, 0.0), Pose2D(0.6, -0.2, 0.0)
P = Pose2D(G.x + S, G.y, 0.0)  # on the push line from the east, taken by block 3 at first


def test_a_cleared_block_goes_onto_its_push_line_at_once():
    # block 0 leaves A for block 1 (to a corner, B), later goes onto the push line into its
    # walled-in slot G, where block 3 stood until then, and is pushed in: four moves where a
    # pose farther out on the same line, free from the start, needs three
    blocks = [BlockPose(0, A.x, A.y, 0.0), BlockPose(1, Y0.x, Y0.y, 0.0),
              BlockPose(3, P.x, P.y, 0.0), *WALLS]
    ctx, start = ctx_and_start(blocks)
    plan = [PickPlace(0, A, B, 0), PickPlace(1, Y0, A, 0), PickPlace(3, P, Z, 1),
            PickPlace(0, B, P, 1), Push.between(0, P, G)]
    assert feasible(ctx, start, plan)
    assert shortcut(ctx, start, plan) == plan  # neither moment of the pair works with B
    out = rebuffer(ctx, start, plan)
    assert len(out) == 4 and feasible(ctx, start, out)
    assert [a.block for a in out] == [0, 1, 3, 0]
    assert isinstance(out[-1], Push) and out[-1].to == G
    assert out[0].to in line_buffers(ctx, G)


#: Where block 3 stands at the start: block 0's end, taken until block 3 leaves.
C = Pose2D(0.8, 0.1, 0.0)


def blocks_0_1_3():
    """Block 0 on A (it must leave before block 1 arrives), block 1 at Y0, block 3 on C."""
    return ctx_and_start([BlockPose(0, A.x, A.y, 0.0), BlockPose(1, Y0.x, Y0.y, 0.0),
                          BlockPose(3, C.x, C.y, 0.0)])


def test_a_block_moves_once_when_its_end_frees_up_before_its_start_is_needed():
    # neither the first nor the last moment of block 0's two moves works, the one between does
    c = C
    ctx, start = blocks_0_1_3()
    plan = [PickPlace(0, A, B, 0), PickPlace(3, c, Z, 0), PickPlace(1, Y0, A, 0),
            PickPlace(0, B, c, 0)]
    assert shortcut(ctx, start, plan) == plan
    out = rebuffer(ctx, start, plan)
    assert [(a.block, a.to) for a in out] == [(3, Z), (0, c), (1, A)]
    assert feasible(ctx, start, out)


def test_a_move_that_has_to_stay_is_kept():
    # the end C stays taken until after block 1 needs A: no moment works
    c = C
    ctx, start = blocks_0_1_3()
    plan = [PickPlace(0, A, B, 0), PickPlace(1, Y0, A, 0), PickPlace(3, c, Z, 0),
            PickPlace(0, B, c, 0)]
    assert rebuffer(ctx, start, plan) == plan
