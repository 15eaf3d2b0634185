"""Re-insertion takes out every move of a block and puts back the fewest that fit between the
other blocks' actions; a change the validator refuses is not kept."""

from __future__ import annotations

from msgs_py import BlockPose, PickPlace, Pose2D, Push
from nodes.planner.passes import reinsert as reinsert_module
from nodes.planner.passes.reinsert import reinsert, reinsert_block

from .walled_slot import WALLS, G, S, ctx_and_start, feasible

A, B = Pose2D(0.5, 0.0, 0.0), Pose2D(0.5, 0.2, 0.0)
X, Y0 = Pose2D(0.9, 0.2, 0.0), Pose2D(0.9, -0.2, 0.0)


def test_three_moves_through_free_space_become_one():
    ctx, start = ctx_and_start([BlockPose(0, A.x, A.y, 0.0), BlockPose(1, Y0.x, Y0.y, 0.0)])
    plan = [PickPlace(0, A, B, 0), PickPlace(1, Y0, Pose2D(0.6, -0.2, 0.0), 0),
            PickPlace(0, B, X, 0), PickPlace(0, X, Pose2D(0.7, 0.0, 0.0), 0)]
    assert feasible(ctx, start, plan)
    out = reinsert_block(ctx, start, plan, 0)
    assert out is not None and feasible(ctx, start, out)
    mine = [a for a in out if a.block == 0]
    assert len(out) == 2 and len(mine) == 1
    assert (mine[0].to.x, mine[0].to.y) == (0.7, 0.0)


def test_a_block_on_anothers_slot_still_leaves_before_it_is_needed():
    # block 0 stands on A, block 1's end: its one move must come before block 1's
    ctx, start = ctx_and_start([BlockPose(0, A.x, A.y, 0.0), BlockPose(1, Y0.x, Y0.y, 0.0)])
    plan = [PickPlace(0, A, B, 0), PickPlace(1, Y0, A, 0), PickPlace(0, B, X, 0)]
    out = reinsert_block(ctx, start, plan, 0)
    assert out is not None and feasible(ctx, start, out)
    assert [(a.block, a.to) for a in out] == [(0, X), (1, A)]


def test_a_walled_in_slot_is_still_entered_by_a_push():
    # block 0 is put aside, then on the push line, then pushed into G: one pose on the line
    # is free from the start, so two moves do
    line = Pose2D(G.x + 1.5 * S, G.y, 0.0)
    ctx, start = ctx_and_start([BlockPose(0, A.x, A.y, 0.0), *WALLS])
    plan = [PickPlace(0, A, B, 0), PickPlace(0, B, line, 0), Push.between(0, line, G)]
    assert feasible(ctx, start, plan)
    out = reinsert_block(ctx, start, plan, 0)
    assert out is not None and len(out) == 2 and feasible(ctx, start, out)
    assert isinstance(out[-1], Push) and (out[-1].to.x, out[-1].to.y) == (G.x, G.y)


def test_nothing_shorter_gives_none_and_a_refused_change_is_not_kept(monkeypatch):
    ctx, start = ctx_and_start([BlockPose(0, A.x, A.y, 0.0), BlockPose(1, Y0.x, Y0.y, 0.0)])
    direct = [PickPlace(0, A, X, 0), PickPlace(1, Y0, A, 0)]
    assert reinsert_block(ctx, start, direct, 0) is None
    plan = [PickPlace(0, A, B, 0), PickPlace(1, Y0, A, 0), PickPlace(0, B, X, 0)]
    assert reinsert(ctx, start, plan, lambda actions: False) == plan
    assert len(reinsert(ctx, start, plan, lambda actions: True)) == 2
    monkeypatch.setattr(reinsert_module, "MAX_ACTIONS", 2)
    assert reinsert(ctx, start, plan, lambda actions: True) == plan  # too long: left alone
