"""The simulated 2F-85's fingers: commands with the fieldbus's latency, what the driver would
measure, and pads that lose their grip (a fault).

Part of a ``SimWorld`` (``world.fingers``): two prismatic pad joints coupled like the 2F-85's
linkage, driven by force-limited position motors. Commands come as a pad gap or as the
driver's knuckle position (``nodes.robot.gripper_2f85`` maps one to the other); the knuckle
joint and the 2F-85's object detection are read back from the measured pads.
"""

from __future__ import annotations

import math

import pybullet

from nodes.robot import gripper_2f85 as g85
from nodes.sim import robot_model as rm
from nodes.sim.bodies import WorldBodies

#: The gripper reports "at the requested position" within this of it (m), and "moving" while
#: the fingers' combined speed exceeds this (m/s).
GRIPPER_AT_POSITION = 0.0005
GRIPPER_MOVING_SPEED = 0.002


class Fingers:
    def __init__(self, world: WorldBodies) -> None:
        self.world = world
        self.reset()

    def reset(self) -> None:
        w = self.world
        for j in w.finger_joints:
            w.client.resetJointState(w.robot, j, rm.GRIPPER_STROKE / 2, 0.0)
        self.gripper_gap = rm.GRIPPER_STROKE  #: the gap the motors drive to (m)
        self._apply()
        self._queue: list[tuple[float, float]] = []  # (time due, gap) on the way
        self._pad_friction_restore: float | None = None  # a fault's slippery pads end then
        self._slip_until = 0.0

    # --- commands -------------------------------------------------------------------------------
    def set_knuckle(self, knuckle: float) -> float:
        """A Robotiq knuckle position command (rad); returns the pad gap it asks for (m)."""
        if not math.isfinite(knuckle):
            raise ValueError(f"knuckle command {knuckle} is not finite")
        return self.set_gap(g85.knuckle_to_gap(knuckle))

    def set_gap(self, gap: float) -> float:
        """Command the gap between the pads (m, clipped to the stroke); the gripper acts on it
        ``gripper_latency_s`` later (its fieldbus cycle). Returns the clipped gap."""
        if not math.isfinite(gap):
            raise ValueError(f"gripper command {gap} is not finite")
        gap = min(max(float(gap), 0.0), rm.GRIPPER_STROKE)
        latency = self.world.config.gripper_latency_s
        if latency <= 0.0:
            self.gripper_gap = gap
            self._apply()
        else:
            self._queue.append((self.world.time_s + latency, gap))
        return gap

    def step(self) -> None:
        """Before a physics step: commands whose time has come, pads whose slip is over."""
        now = self.world.time_s
        while self._queue and self._queue[0][0] <= now + 1e-12:
            _, self.gripper_gap = self._queue.pop(0)
            self._apply()
        if self._pad_friction_restore is not None and now >= self._slip_until:
            self._set_pad_friction(self._pad_friction_restore)
            self._pad_friction_restore = None

    def _apply(self) -> None:
        w = self.world
        for j in w.finger_joints:
            w.client.setJointMotorControl2(
                w.robot, j, pybullet.POSITION_CONTROL, targetPosition=self.gripper_gap / 2,
                force=w.config.grip_force, maxVelocity=w.config.gripper_speed / 2)

    # --- what the driver measures ---------------------------------------------------------------
    def _pads(self) -> tuple[float, float]:
        """(gap m, gap rate m/s) of the measured pads."""
        w = self.world
        states = w.client.getJointStates(w.robot, w.finger_joints)
        return (float(states[0][0] + states[1][0]),
                float(abs(states[0][1]) + abs(states[1][1])))

    def gap(self) -> float:
        """Measured gap between the pads (m)."""
        return self._pads()[0]

    def knuckle(self) -> tuple[float, float]:
        """The knuckle joint's (position rad, velocity rad/s), as the Robotiq driver
        publishes it (it never fills the velocity: the sim reports it anyway, 0 at rest)."""
        w = self.world
        states = w.client.getJointStates(w.robot, w.finger_joints)
        gap = float(states[0][0] + states[1][0])
        gap_rate = float(states[0][1] + states[1][1])
        return g85.gap_to_knuckle(gap), -gap_rate * g85.KNUCKLE_CLOSED / rm.GRIPPER_STROKE

    def status(self) -> tuple[float, float, int]:
        """(measured gap m, requested gap m, object detection) as the 2F-85's ``gOBJ``: 0
        fingers moving, 1 stopped on an object while opening, 2 stopped on an object while
        closing, 3 at the requested position (no object). The sim logs with it; the driver
        does not publish it (the gripper node rebuilds it from the knuckle)."""
        gap, speed = self._pads()
        requested = self.gripper_gap
        if abs(gap - requested) <= GRIPPER_AT_POSITION:
            code = 3
        elif speed > GRIPPER_MOVING_SPEED:
            code = 0
        else:
            code = 2 if gap > requested else 1
        return gap, requested, code

    def held_block(self) -> int | None:
        """The block both fingers touch (the one in the gripper), or None."""
        w = self.world
        touching: dict[int, set[int]] = {}
        for pt in w.client.getContactPoints(bodyA=w.robot):
            link, body = pt[3], pt[2]
            if link in w.finger_links and body in w.body_to_block:
                touching.setdefault(w.body_to_block[body], set()).add(link)
        held = [b for b, links in touching.items() if len(links) == 2]
        return held[0] if held else None

    def contacts(self) -> str:
        """What each finger touches, with the normal force: says what holds fingers that
        stopped opening (logged when they do)."""
        w = self.world
        names = {w.robot: "robot"}
        names.update({body: f"block {b}" for body, b in w.body_to_block.items()})
        parts = []
        for pt in w.client.getContactPoints(bodyA=w.robot):
            if pt[3] in w.finger_links:
                what = names.get(pt[2], f"body {pt[2]}")
                parts.append(f"finger link {pt[3]} - {what} (link {pt[4]}) {pt[9]:.1f} N "
                             f"at ({pt[5][0]:.4f}, {pt[5][1]:.4f}, {pt[5][2]:.4f})")
        return "; ".join(parts) or "no finger contact"

    # --- a fault --------------------------------------------------------------------------------
    def slippery_pads(self, factor: float, seconds: float) -> None:
        """The pads lose grip (a greasy or dusty block): their friction times ``factor`` for
        ``seconds``. Low enough, the held block slides or falls out of the fingers."""
        if not 0.0 <= factor <= 1.0 or not seconds > 0.0:
            raise ValueError(f"slippery pads: factor {factor} must be in [0, 1], seconds > 0")
        if self._pad_friction_restore is None:
            self._pad_friction_restore = rm.FRICTION_PAD
        self._set_pad_friction(rm.FRICTION_PAD * factor)
        self._slip_until = self.world.time_s + seconds

    def _set_pad_friction(self, mu: float) -> None:
        """Pad friction ``mu``; friction anchors (which pin contacts regardless of the
        coefficient) are off while the pads are slippery, on the pads and the blocks."""
        w = self.world
        anchor = 1 if mu >= rm.FRICTION_PAD else 0
        for j in w.finger_links:
            w.client.changeDynamics(w.robot, j, lateralFriction=mu, frictionAnchor=anchor)
        for body in w.block_bodies.values():
            w.client.changeDynamics(body, -1, frictionAnchor=anchor)
