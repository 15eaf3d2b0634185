"""The relaxation's shortest path over subsets read from the assembly's tables equals the
one written with the slot costs themselves (the exact search solves it once per state)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from nodes.bench.instances import instance
from nodes.planner.bounds.assembly import Assembly
from nodes.planner.bounds.bound import INF, Relaxation
from nodes.planner.config import PlannerConfig
from nodes.planner.geometry.context import PlanContext


def by_costs(relax: Relaxation) -> list[float]:
    """The shortest path over subsets with ``Relaxation.cost`` asked per (slot, filled)."""
    full = (1 << relax.n) - 1
    g = [INF] * (full + 1)
    g[full] = 0.0
    for filled in range(full - 1, -1, -1):
        g[filled] = min((relax.cost(c, filled) + g[filled | 1 << c]
                         for c in range(relax.n) if not filled >> c & 1), default=INF)
    return g


@pytest.mark.parametrize(("n", "density", "seed"), [(4, 0.3, 3), (6, 0.3, 2), (9, 0.3, 0),
                                                    (9, 0.2, 5)])
def test_the_table_driven_path_equals_the_cost_driven_one(n, density, seed):
    scene = instance("random", n, density, seed)
    ctx = PlanContext.for_scene(scene, PlannerConfig())
    asm = Assembly(ctx, scene.goal_assignment())
    rng = np.random.default_rng(seed)
    full = (1 << n) - 1
    for _ in range(25):
        todo = int(rng.integers(1, full + 1))
        exempt = [bool(e) for e in rng.random(n) < 0.3]
        clears = [int(m) & ~(1 << k) for k, m in enumerate(rng.integers(0, full + 1, n))]
        for moved_cost in (1.0, 2.0):
            relax = Relaxation(asm, todo, exempt, clears, moved_cost)
            got, want = relax.to_go, by_costs(relax)
            assert all(a == b or (math.isinf(a) and math.isinf(b))
                       for a, b in zip(got, want, strict=True))
