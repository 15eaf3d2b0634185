"""The goal layout's greedy assembly order (``Assembly.order``) needs the fewest push-only
placements there are: on the benchmark's grid goals with 3 mm gaps, an exhaustive search over
the filled-slot sets finds no order with fewer. The pushes a layout forces are the largest
part of a dense plan's actions beyond one per block (docs/benchmarks.md, planner targets),
so an order that needed more would lengthen every plan."""

from __future__ import annotations

import math
from collections import deque

import pytest

from nodes.bench.instances import grid_shape, instance
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext


def greedy_pushes(asm: Assembly) -> int:
    filled, pushes = 0, 0
    for block in asm.order():
        pushes += not asm.placeable(block, filled)
        filled |= asm.bit[block]
    return pushes


def fewest_pushes(asm: Assembly) -> int | None:
    """Over every order that fills each slot by a set-down or a push into it: the fewest
    pushes (0-1 breadth-first search over the filled sets); None if none fills them all."""
    best = {0: 0}
    queue = deque([0])
    while queue:
        filled = queue.popleft()
        for block in asm.ids:
            bit = asm.bit[block]
            if filled & bit:
                continue
            if asm.placeable(block, filled):
                cost = 0
            elif asm.enterable(asm.index[block], filled):
                cost = 1
            else:
                continue
            after, pushes = filled | bit, best[filled] + cost
            if pushes < best.get(after, len(asm.ids) + 1):
                best[after] = pushes
                (queue.appendleft if cost == 0 else queue.append)(after)
    return best.get(asm.all)


@pytest.mark.parametrize("n", [9, 12, 16])
def test_the_greedy_order_needs_no_more_pushes_than_any_order(n):
    scene = instance("random", n, 0.3, 0)
    asm = Assembly(PlanContext.for_scene(scene, PlannerConfig()), scene.goal_assignment())
    rows, cols = grid_shape(n)
    fewest = fewest_pushes(asm)
    assert fewest is not None and fewest > 0  # a dense grid cannot be filled without pushes
    assert greedy_pushes(asm) == fewest
    # every 2 x 2 square of slots is finished by a push (its last slot has a filled
    # neighbour on both axes), and one push finishes only the two its lane misses: the bound's
    # forced pushes (``hitting``) are the exhaustive minimum
    assert fewest == math.ceil((rows - 1) * (cols - 1) / 2)
