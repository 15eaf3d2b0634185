"""The UR10e's numbers (Universal Robots, "DH parameters for calculations of kinematics and
dynamics", and the UR10e data sheet): what the arm node's IK, the sim's model and the
planner's reach check all read, so they cannot drift apart."""

from __future__ import annotations

import math

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

#: The joints in kinematic order, as ur_robot_driver names them (no tf_prefix): the order of
#: its controllers' ``joints`` lists, so of a forward position command's values. Joint states
#: come in any order and are read by these names.
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
#: 10, 8, 13, 9, 0, 18 rad/s^2; where a stream asks for more, the arm controller slows playback.
JOINT_ACCELERATION_LIMIT = (12.0, 12.0, 15.0, 20.0, 20.0, 20.0)

#: The elbow-up, wrist-down branch the workspace is reached on, at the cell's park pose (TCP
#: at (0.25, -0.55, 0.40) m, tool down, closing axis along x): where the sim starts the arm,
#: and the reference from which the arm's posture over the workspace is predicted.
WORKING_BRANCH_JOINTS = (1.7050197, -1.3509143, 1.5056703, 1.4160404, 1.5707963, 0.1342234)
