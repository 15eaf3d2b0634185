"""The Robotiq 2F-85's numbers (data sheet / instruction manual, "Specifications") and how its
driver's one joint maps onto the gap between the pads.

The ROS driver publishes and commands only ``robotiq_85_left_knuckle_joint``, in radians: 0 is
fully open, ``KNUCKLE_CLOSED`` fully closed, linear in the position register it writes (3 to
230). The gripper's pad gap is taken as linear in that register too (the data sheet's 0.4 mm
per count over the 85 mm stroke): ``gap_to_knuckle`` and ``knuckle_to_gap`` are the one
mapping the gripper node and the sim share. A real gripper whose gap is not linear in the
register would need its own table here, measured once.
"""

from __future__ import annotations

from msgs_py.cell import GRIPPER_STROKE

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

#: The driver's joint (ros2_robotiq_gripper, 2F-85 description) and its closed position (rad).
KNUCKLE_JOINT = "robotiq_85_left_knuckle_joint"
KNUCKLE_CLOSED = 0.7929


def gap_to_knuckle(gap: float) -> float:
    """Pad gap (m, clipped to the stroke) -> knuckle position (rad, 0 open)."""
    gap = min(max(float(gap), 0.0), GRIPPER_STROKE)
    return KNUCKLE_CLOSED * (1.0 - gap / GRIPPER_STROKE)


def knuckle_to_gap(knuckle: float) -> float:
    """Knuckle position (rad, clipped to its range) -> pad gap (m)."""
    knuckle = min(max(float(knuckle), 0.0), KNUCKLE_CLOSED)
    return GRIPPER_STROKE * (1.0 - knuckle / KNUCKLE_CLOSED)
