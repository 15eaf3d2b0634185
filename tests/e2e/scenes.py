"""Small scenes for the end-to-end runs that check a mechanism (recording, two hosts) rather
than a scene's difficulty: the default scene's 9 blocks would triple their run time."""

from __future__ import annotations

from pathlib import Path

#: Two of the default scene's blocks, to a 1 x 2 grid with its 3 mm gap (a pick-and-place and
#: a place beside a placed block).
TWO_BLOCKS = """\
version: 1
workspace: {x_min: 0.45, x_max: 0.95, y_min: -0.35, y_max: 0.35}
blocks:
  - {id: 0, x: 0.52, y: -0.27, theta: 0.35}
  - {id: 1, x: 0.66, y: -0.24, theta: -0.6}
goal:
  grid: {rows: 1, cols: 2, center: [0.70, -0.04], theta: 0.0, gap: 0.003}
"""


def two_block_scene(folder: Path) -> Path:
    """``TWO_BLOCKS`` written to ``folder``/two.yaml, for a node that reads a scene file."""
    path = folder / "two.yaml"
    path.write_text(TWO_BLOCKS)
    return path
