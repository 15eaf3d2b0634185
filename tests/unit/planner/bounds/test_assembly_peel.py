"""The goal layout's feasibility test (``Assembly.stuck``) peels with a worklist; it must find
exactly what peeling every enterable slot round after round finds."""

from __future__ import annotations

import weakref

import numpy as np
import pytest

from nodes.bench.instances import instance
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext


def stuck_by_rounds(asm: Assembly, filled: int) -> list[int]:
    """The closure computed plainly: every round, peel every empty slot that is enterable
    with the slots not yet peeled standing."""
    n = len(asm.ids)
    empty, occupied = asm.all & ~filled, asm.all
    while True:
        peel = [c for c in range(n) if empty >> c & 1 and asm.enterable(c, occupied & ~(1 << c))]
        if not peel:
            return [asm.ids[c] for c in range(n) if empty >> c & 1]
        for c in peel:
            empty &= ~(1 << c)
            occupied &= ~(1 << c)


@pytest.mark.parametrize(("n", "density"), [(9, 0.3), (16, 0.2), (25, 0.3)])
def test_the_worklist_peel_equals_the_round_by_round_one(n, density):
    scene = instance("random", n, density, 0)
    asm = Assembly(PlanContext.for_scene(scene, PlannerConfig()), scene.goal_assignment())
    rng = np.random.default_rng(n)
    walled = 0
    for _ in range(400):
        filled = 0
        for c in np.flatnonzero(rng.random(n) < rng.uniform(0.2, 0.9)):
            filled |= 1 << int(c)
        expected = stuck_by_rounds(asm, filled)
        assert asm.stuck(filled) == expected
        walled += bool(expected)
    assert 0 < walled < 400  # both verdicts were tested


def test_an_assembly_is_freed_with_its_planning_run():
    """A planner node plans goal after goal for days: the memo of ``feasible`` and
    ``future_pushes`` must die with its Assembly, not keep every one alive (a class-level
    functools.cache did: +36 MB over a 200-goal soak)."""
    scene = instance("random", 9, 0.3, 0)
    asm = Assembly(PlanContext.for_scene(scene, PlannerConfig()), scene.goal_assignment())
    first = asm.future_pushes(0), asm.feasible(0)
    assert (asm.future_pushes(0), asm.feasible(0)) == first  # answered from the memo
    alive = weakref.ref(asm)
    del asm
    assert alive() is None  # freed by reference counting, no collector pass needed
