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

# --- UR10e (Universal Robots, "DH parameters for calculations of kinematics and dynamics") ----
#: Standard DH parameters of the UR10e, joints 1..6 (m, rad).
DH_D = (0.1807, 0.0, 0.0, 0.17415, 0.11985, 0.11655)
DH_A = (0.0, -0.6127, -0.57155, 0.0, 0.0, 0.0)
DH_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)

#: Link masses (kg) and centres of mass (m, in DH frame i) from the same UR table.
LINK_MASS = (7.369, 13.051, 3.989, 2.1, 1.98, 0.615)
LINK_COM_DH = (
    (0.021, 0.000, 0.027),
    (0.38, 0.000, 0.158),
    (0.24, 0.000, 0.068),
    (0.000, 0.007, 0.018),
    (0.000, 0.007, 0.018),
    (0.0, 0.0, -0.026),
)

ARM_JOINTS = (
    "shoulder_pan_joint",
    "shoulder_lift_joint",
    "elbow_joint",
    "wrist_1_joint",
    "wrist_2_joint",
    "wrist_3_joint",
)
#: UR10e data sheet: every joint +-360 degrees.
JOINT_LIMIT = 2.0 * math.pi
#: UR10e data sheet: base and shoulder 120 deg/s, elbow and wrists 180 deg/s.
JOINT_VELOCITY_LIMIT = tuple(math.radians(v) for v in (120, 120, 180, 180, 180, 180))
#: Joint sizes 4, 4, 3, 2, 2, 2 (UR joint catalogue): peak torques 330, 330, 150, 56, 56, 56 N m.
JOINT_TORQUE_LIMIT = (330.0, 330.0, 150.0, 56.0, 56.0, 56.0)
#: UR publishes no joint acceleration limits, only peak torques (the torque limits above bound
#: what PyBullet's motors reach). These let the executor's Cartesian profiles (1 m/s, 4 m/s^2
#: peak, cosine ramps) through over the workspace: their 99.5th-percentile demand is about
#: 10, 8, 13, 9, 0, 18 rad/s^2; where a stream asks for more, the controller slows playback.
JOINT_ACCELERATION_LIMIT = (12.0, 12.0, 15.0, 20.0, 20.0, 20.0)

# --- Robotiq 2F-85 (data sheet / instruction manual, section "Specifications") ---------------
GRIP_FORCE_RANGE = (20.0, 235.0)  #: N, data sheet
GRIP_FORCE_DEFAULT = 40.0  #: N, a gentle wood-block grip (well inside the range)
CLOSING_SPEED_RANGE = (0.020, 0.150)  #: m/s, data sheet
CLOSING_SPEED_DEFAULT = 0.150  #: m/s of the gap: the data sheet's fastest setting
GRIPPER_MASS = 0.925  #: kg, data sheet (with fingers)
#: Flange to fingertips (coupling 11 mm + 163 mm gripper with fingers closed), m.
TCP_OFFSET = 0.174
FINGER_LENGTH = 0.055  #: m, visible finger below the gripper body
PAD_HEIGHT = 0.038  #: m, rubber pad height (fingertip up), data sheet drawing
FINGER_MASS = 0.05  #: kg each (the rest of the 0.925 kg is in the body)
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
