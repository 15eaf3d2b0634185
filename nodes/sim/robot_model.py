"""Physical numbers of the simulated cell, in one place, each with its source.

The URDF generator (``sim_assets/make_assets.py``), the kinematics, the controller and the
world all read these constants, so the model on disk and the code cannot drift apart.
``sim_assets/README.md`` lists the same numbers with their sources for people.
"""

from __future__ import annotations

import math

# Stroke, finger footprint, block and tag size: the cell contract (msgs_py.cell), shared with
# the planner, the executor and the detector.
from msgs_py.cell import (  # noqa: F401 (re-exported for the sim and the asset generator)
    BLOCK_SIZE,
    FINGER_THICKNESS,
    FINGER_WIDTH,
    GRIPPER_STROKE,
    TAG_SIZE,
)

#: The sim's two pad joints (prismatic, each the pad's distance from the TCP, m), coupled like
#: the 2F-85's linkage; the driver-facing knuckle joint is derived from them
#: (``nodes.robot.gripper_2f85``).
FINGER_JOINTS = ("left_finger_joint", "right_finger_joint")

# --- Blocks, table, friction -----------------------------------------------------------------
SOFTWOOD_DENSITY = 500.0  #: kg/m^3, pine/spruce (dry) 400-550
BLOCK_MASS = SOFTWOOD_DENSITY * BLOCK_SIZE**3
TAG_MARGIN = 0.0054  #: white margin around it, (s - tag) / 2

#: Pairwise Coulomb friction coefficients (dimensionless) the sim aims for.
MU_WOOD_MDF = 0.35
MU_WOOD_WOOD = 0.40
MU_RUBBER_WOOD = 0.90
#: Bullet combines two bodies' coefficients by multiplying them, so per-body values are
#: chosen whose products give the pairs above.
FRICTION_BLOCK = math.sqrt(MU_WOOD_WOOD)
FRICTION_TABLE = MU_WOOD_MDF / FRICTION_BLOCK
FRICTION_PAD = MU_RUBBER_WOOD / FRICTION_BLOCK

TABLE_EXTENT = (-0.30, 1.40, -0.90, 0.90)  #: x_min, x_max, y_min, y_max of the MDF top, m
TABLE_THICKNESS = 0.025  #: m, MDF board
