"""Seeded random scenes are reproducible, valid and have the density asked for."""

from __future__ import annotations

import pytest

from nodes.common.scenes import random_scene, workspace_for


@pytest.mark.parametrize("n", [4, 9, 16, 25])
@pytest.mark.parametrize("density", [0.05, 0.2])
def test_random_scene_is_valid_dense_and_reproducible(n, density):
    scene = random_scene(n, density, seed=3)
    assert len(scene.blocks) == n
    assert scene.density == pytest.approx(density)
    assert scene.goal.n_slots == n and scene.goal.grid.gap == pytest.approx(0.003)
    assert random_scene(n, density, seed=3) == scene
    assert random_scene(n, density, seed=4) != scene


def test_workspace_refuses_impossible_density():
    with pytest.raises(ValueError, match="density"):
        workspace_for(9, 0.9)
