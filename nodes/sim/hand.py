"""What a person near the cell does to it, and the faults a real cell meets, each one physical:
a hand that nudges a block, takes one away or puts one down, and faults armed for the right
moment of the next action (a block that slips or drops out of the fingers, one knocked aside
just before they close on it).

Part of a ``SimWorld`` (``world.hand``). Nothing here sets a block's pose: a nudge is a
horizontal force applied until the block has moved about so far, a slip is pads that lose
their grip (``Fingers.slippery_pads``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet

from msgs_py import BlockPose
from msgs_py.sim import SimFault
from nodes.sim import robot_model as rm
from nodes.sim.bodies import WorldBodies
from nodes.sim.fingers import Fingers

GRAVITY = 9.81
#: /sim/disturb: the "hand" pushes at this speed and gives up after this long.
DISTURB_SPEED = 0.05
DISTURB_TIMEOUT_S = 10.0
DISTURB_MAX_FORCE = 5.0
#: Armed faults (``arm_fault``): a held block higher than LIFTED_Z (m, its centre) is lifted;
#: slippery pads for DROP_S let it fall out, for SLIP_S slide in the fingers (s, measured);
#: a missed grasp knocks the block MISS_DISTANCE (m) aside as the fingers come down.
ARMED_FAULTS = ("drop", "slip", "miss")
LIFTED_Z = 0.045
DROP_S = 0.4
SLIP_S = 0.05
MISS_DISTANCE = 0.045  # a block width and a finger pad across the closing axis, and a margin
MISS_SPEED = 0.25
MISS_Z = (0.06, 0.12)  # TCP heights where the open fingers hover above the block


@dataclass
class Disturbance:
    start: np.ndarray
    direction: np.ndarray
    distance: float
    t_end: float
    speed: float = DISTURB_SPEED


class Hand:
    def __init__(self, world: WorldBodies, fingers: Fingers) -> None:
        self.world = world
        self.fingers = fingers
        self.reset()

    def reset(self) -> None:
        self.armed: str | None = None  # a fault waiting for its moment (arm_fault)
        self.disturbances: dict[int, Disturbance] = {}

    def disturb(self, block_id: int, dx: float, dy: float, speed: float = DISTURB_SPEED) -> None:
        """Push a block horizontally (an external force, physics only) by about (dx, dy), at
        about ``speed`` (m/s)."""
        w = self.world
        if block_id not in w.block_bodies:
            raise ValueError(f"no block with id {block_id}")
        vec = np.array([dx, dy], dtype=float)
        distance = float(np.linalg.norm(vec))
        if not math.isfinite(distance) or distance > 0.5:
            raise ValueError(f"disturbance ({dx}, {dy}) must be finite and at most 0.5 m")
        if distance < 1e-4:
            return
        pos = w.block_position(block_id)
        self.disturbances[block_id] = Disturbance(pos[:2].copy(), vec / distance, distance,
                                                  w.time_s + DISTURB_TIMEOUT_S, speed)

    def arm_fault(self, kind: str) -> None:
        """Make a fault happen at the right moment of the next action:

        * ``drop``: the next block lifted more than LIFTED_Z off the table slips out of the
          fingers (slippery pads for DROP_S);
        * ``slip``: ... slides in the fingers but stays held (slippery pads for SLIP_S);
        * ``miss``: the next block the open fingers come down on is knocked MISS_DISTANCE
          aside just before they close on it.
        """
        if kind not in ARMED_FAULTS:
            raise ValueError(f"unknown armed fault '{kind}'; known: {sorted(ARMED_FAULTS)}")
        self.armed = kind

    def inject(self, fault: SimFault) -> None:
        """Carry out a fault asked for on /sim/fault (``msgs_py.sim.SimFault``)."""
        w = self.world
        if fault.kind in ARMED_FAULTS:
            self.arm_fault(fault.kind)
        elif fault.kind == "remove_block":
            assert fault.block is not None
            w.remove_block(fault.block)
            self._fired(fault.kind, fault.block)
        elif fault.kind == "add_block":
            assert fault.block is not None and fault.pose is not None
            w.add_block(BlockPose(fault.block, *fault.pose))
            self._fired(fault.kind, fault.block)
        elif fault.kind == "camera_noise":
            w.noise_std = fault.value

    def step(self, check_armed: bool) -> None:
        """Before a physics step: push the disturbed blocks; an armed fault's moment?"""
        if self.disturbances:
            self._push()
        if self.armed is not None and check_armed:
            self._check_armed()

    def _check_armed(self) -> None:
        w = self.world
        kind = self.armed
        if kind in ("drop", "slip"):
            block = self.fingers.held_block()
            if block is not None and w.block_position(block)[2] > LIFTED_Z:
                self.fingers.slippery_pads(0.0, DROP_S if kind == "drop" else SLIP_S)
                self._fired(kind, block)
        elif kind == "miss":
            tcp, quat = w.tcp_pose()
            closing = w.client.getMatrixFromQuaternion(quat)[0::3][:2]  # the tool's x axis
            for block in list(w.block_bodies):
                pos = w.block_position(block)
                over = math.hypot(tcp[0] - pos[0], tcp[1] - pos[1]) < 0.01
                if (over and MISS_Z[0] < tcp[2] < MISS_Z[1]
                        and self.fingers.gripper_gap > rm.BLOCK_SIZE):
                    # aside across the closing axis, far enough for the fingers to miss it
                    dx, dy = self._roomier_side(block, (-closing[1], closing[0]))
                    self.disturb(block, dx * MISS_DISTANCE, dy * MISS_DISTANCE, speed=MISS_SPEED)
                    self._fired(kind, block)
                    break

    def _roomier_side(self, block: int, axis: tuple[float, float]) -> tuple[float, float]:
        """``axis`` or its opposite: the way a knock MISS_DISTANCE long leaves ``block``
        furthest from every other block. A miss is a block that is not where the fingers
        come down, not a block rammed into its neighbour (a cube driven into another at
        MISS_SPEED climbs it and tips over: a different fault)."""
        w = self.world
        here = w.block_position(block)[:2]
        others = [w.block_position(b)[:2] for b in w.block_bodies if b != block]

        def room(sign: float) -> float:
            spot = here + sign * MISS_DISTANCE * np.asarray(axis)
            return min((float(np.linalg.norm(spot - p)) for p in others), default=math.inf)

        sign = 1.0 if room(1.0) >= room(-1.0) else -1.0
        return sign * axis[0], sign * axis[1]

    def _fired(self, kind: str, block: int) -> None:
        if self.armed == kind:
            self.armed = None
        w = self.world
        w.monitor.events.append({"t": round(w.time_s, 4), "type": "fault", "block": block,
                                 "reason": kind})

    def _push(self) -> None:
        w = self.world
        c = w.client
        for block_id, d in list(self.disturbances.items()):
            body = w.block_bodies[block_id]
            pos = w.block_position(block_id)
            moved = float(np.dot(pos[:2] - d.start, d.direction))
            speed = float(np.dot(np.asarray(c.getBaseVelocity(body)[0][:2]), d.direction))
            braking = speed * speed / (2 * rm.MU_WOOD_MDF * GRAVITY)
            if moved + braking >= d.distance or w.time_s > d.t_end:
                del self.disturbances[block_id]
                continue
            force = rm.BLOCK_MASS * (rm.MU_WOOD_MDF * GRAVITY + 20.0 * (d.speed - speed))
            force = min(max(force, 0.0), DISTURB_MAX_FORCE)
            f = (force * d.direction[0], force * d.direction[1], 0.0)
            c.applyExternalForce(body, -1, f, pos.tolist(), pybullet.WORLD_FRAME)
