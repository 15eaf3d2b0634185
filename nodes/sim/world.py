"""``SimWorld``: the PyBullet cell (table, UR10e + 2F-85, tagged blocks, overhead camera).

One world owns one PyBullet client (``self.client``, a ``BulletClient`` in DIRECT mode: no
global client, several worlds can live in one process) and is driven by one thread.
Blocks move only through contact: after ``reset`` nothing ever sets a block's pose, and
nothing welds a block to the gripper; a grasp holds by finger force and pad friction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pybullet
from pybullet_utils import bullet_client

from msgs_py import BlockPose, Scene
from msgs_py.drivers import SAFETY_PROTECTIVE_STOP
from msgs_py.sim import SimFault
from nodes.common.paths import asset_path
from nodes.robot import gripper_2f85 as g85
from nodes.robot import ur10e
from nodes.sim import robot_model as rm
from nodes.sim.camera import SimCamera, render_rgb
from nodes.sim.config import SimConfig
from nodes.sim.events import ContactKind, EventMonitor
from nodes.sim.joint_control import (
    FORWARD_POSITION_CONTROLLER,
    ForwardPositionController,
    TrajectoryController,
)
from nodes.sim.robot_state import DashboardAnswer, RobotState

TABLE_RGBA = (0.62, 0.50, 0.38, 1.0)  # MDF
GRAVITY = 9.81
#: /sim/disturb: the "hand" pushes at this speed and gives up after this long.
DISTURB_SPEED = 0.05
DISTURB_TIMEOUT_S = 10.0
DISTURB_MAX_FORCE = 5.0
#: After an unlock the arm is off what stopped it once the force has stayed below half the
#: limit this long (s): a block pressed into the table springs back for a few steps.
BACK_OFF_S = 0.1
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
#: N, strength of the constraint that couples the fingers (well above any grip force).
FINGER_COUPLING_FORCE = 500.0
#: The gripper reports "at the requested position" within this of it (m), and "moving" while
#: the fingers' combined speed exceeds this (m/s).
GRIPPER_AT_POSITION = 0.0005
GRIPPER_MOVING_SPEED = 0.002
#: The order ur_robot_driver's joint_state_broadcaster lists the arm joints in (not the
#: kinematic order, not alphabetical): a reader must go by name.
DRIVER_JOINT_STATE_ORDER = ("shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                            "wrist_2_joint", "wrist_3_joint", "shoulder_pan_joint")
#: A forward position command counts as streaming for this long after it came (s, pacing).
FORWARD_COMMAND_S = 0.04


@dataclass
class _Disturbance:
    start: np.ndarray
    direction: np.ndarray
    distance: float
    t_end: float
    speed: float = DISTURB_SPEED


class SimWorld:
    """The simulated cell; ``step()`` advances physics by one ``config.dt``."""

    def __init__(self, config: SimConfig, camera: SimCamera, scene: Scene,
                 noise_std: float = 0.0) -> None:
        self.config = config
        self.camera = camera
        self.noise_std = noise_std
        self.rng = np.random.default_rng(config.seed)
        self.client = bullet_client.BulletClient(connection_mode=pybullet.DIRECT)
        self.client.setPhysicsEngineParameter(
            fixedTimeStep=config.dt, numSolverIterations=config.solver_iterations,
            deterministicOverlappingPairs=1)
        self.client.setGravity(0, 0, -GRAVITY)
        self._textures: dict[int, int] = {}
        self._block_visual = self.client.createVisualShape(
            pybullet.GEOM_MESH, fileName=str(asset_path("block.obj")), meshScale=[1, 1, 1])
        self._block_collision = self.client.createCollisionShape(
            pybullet.GEOM_BOX, halfExtents=[rm.BLOCK_SIZE / 2] * 3)
        self._make_table()
        self._make_robot()
        self.robot_state = RobotState(config.speed_slider, config.protective_stop_unlock_after_s)
        self.motion: TrajectoryController | ForwardPositionController = (
            ForwardPositionController(config.home_joints)
            if config.motion_controller == FORWARD_POSITION_CONTROLLER
            else TrajectoryController(config.home_joints))
        self._can_move = True
        self.block_bodies: dict[int, int] = {}
        self.scene = scene
        self.monitor: EventMonitor | None = None
        self.reset(scene)

    # --- building -------------------------------------------------------------------------------
    def _make_table(self) -> None:
        x0, x1, y0, y1 = rm.TABLE_EXTENT
        half = [(x1 - x0) / 2, (y1 - y0) / 2, rm.TABLE_THICKNESS / 2]
        centre = [(x0 + x1) / 2, (y0 + y1) / 2, -rm.TABLE_THICKNESS / 2]
        c = self.client
        self.table = c.createMultiBody(
            0, c.createCollisionShape(pybullet.GEOM_BOX, halfExtents=half),
            c.createVisualShape(pybullet.GEOM_BOX, halfExtents=half, rgbaColor=TABLE_RGBA),
            basePosition=centre)
        c.changeDynamics(self.table, -1, lateralFriction=rm.FRICTION_TABLE)

    def _make_robot(self) -> None:
        c = self.client
        self.robot = c.loadURDF(str(asset_path("ur10e_2f85.urdf")), [0, 0, 0], [0, 0, 0, 1],
                                useFixedBase=True, flags=pybullet.URDF_USE_INERTIA_FROM_FILE)
        by_name = {}
        self.link_index: dict[str, int] = {}
        for j in range(c.getNumJoints(self.robot)):
            info = c.getJointInfo(self.robot, j)
            by_name[info[1].decode()] = j
            self.link_index[info[12].decode()] = j
        self.arm_joints = [by_name[n] for n in ur10e.ARM_JOINTS]
        self.finger_joints = [by_name[n] for n in rm.FINGER_JOINTS]
        self.tcp_link = self.link_index["tcp"]
        self.finger_links = set(self.finger_joints)
        gripper_links = {self.link_index[n] for n in ("tool0", "gripper_body", "tcp")}
        self.link_kind = {j: ContactKind.ARM for j in range(-1, c.getNumJoints(self.robot))}
        self.link_kind.update({j: ContactKind.GRIPPER for j in gripper_links})
        self.link_kind.update({j: ContactKind.FINGER for j in self.finger_links})
        for j in self.finger_links:
            # Friction anchors keep a held block from creeping and rolling between the pads.
            c.changeDynamics(self.robot, j, lateralFriction=rm.FRICTION_PAD, frictionAnchor=1)
        for j in range(-1, c.getNumJoints(self.robot)):
            c.changeDynamics(self.robot, j, linearDamping=0.0, angularDamping=0.0)
        # The 2F-85's linkage moves both fingers together (one motor): a gear constraint keeps
        # them symmetric, so a held block stays centred and cannot drift along the closing axis.
        gear = c.createConstraint(self.robot, self.finger_joints[0], self.robot,
                                  self.finger_joints[1], pybullet.JOINT_GEAR, [1, 0, 0],
                                  [0, 0, 0], [0, 0, 0])
        c.changeConstraint(gear, gearRatio=-1, maxForce=FINGER_COUPLING_FORCE, erp=0.2,
                           relativePositionTarget=0.0)

    def _texture(self, tag_id: int) -> int:
        if tag_id not in self._textures:
            path = asset_path(f"tags/tag36h11_{tag_id:03d}.png")
            if not path.exists():
                raise ValueError(f"no tag texture for block id {tag_id} ({path})")
            self._textures[tag_id] = self.client.loadTexture(str(path))
        return self._textures[tag_id]

    def _spawn_block(self, block: BlockPose) -> int:
        """A block of the scene; its mass and friction vary from block to block (seeded by
        the sim's seed and the block id), as real wooden blocks do."""
        c = self.client
        s = rm.BLOCK_SIZE
        mass, friction = self.block_variation(block.id)
        quat = (0.0, 0.0, math.sin(block.theta / 2), math.cos(block.theta / 2))
        body = c.createMultiBody(mass, self._block_collision, self._block_visual,
                                 basePosition=[block.x, block.y, s / 2], baseOrientation=quat)
        c.changeVisualShape(body, -1, textureUniqueId=self._texture(block.id),
                            rgbaColor=[1, 1, 1, 1])
        c.changeDynamics(body, -1, lateralFriction=friction, linearDamping=0.0,
                         angularDamping=0.0, frictionAnchor=1)
        return body

    def block_variation(self, block_id: int) -> tuple[float, float]:
        """(mass kg, friction coefficient) of block ``block_id``: the nominal values spread
        by ``block_mass_spread`` / ``block_friction_spread`` (relative, clipped at 2 sigma)."""
        rng = np.random.default_rng([self.config.seed, block_id])
        dm, df = np.clip(rng.normal(0.0, 1.0, 2), -2.0, 2.0)
        return (rm.BLOCK_MASS * (1.0 + self.config.block_mass_spread * dm),
                rm.FRICTION_BLOCK * (1.0 + self.config.block_friction_spread * df))

    # --- lifecycle ------------------------------------------------------------------------------
    def reset(self, scene: Scene | None = None) -> None:
        """Back to the start: arm at home, gripper open, the scene's blocks at their poses."""
        if scene is not None:
            self.scene = scene
        c = self.client
        for body in self.block_bodies.values():
            c.removeBody(body)
        self.block_bodies = {b.id: self._spawn_block(b) for b in self.scene.blocks}
        self.body_to_block = {body: bid for bid, body in self.block_bodies.items()}
        for j, q in zip(self.arm_joints, self.config.home_joints, strict=True):
            c.resetJointState(self.robot, j, q, 0.0)
        open_half = rm.GRIPPER_STROKE / 2
        for j in self.finger_joints:
            c.resetJointState(self.robot, j, open_half, 0.0)
        self.robot_state.reset(0.0)
        self.motion.hold(self.config.home_joints)
        self._can_move = True
        self.gripper_gap = rm.GRIPPER_STROKE
        self._apply_gripper()
        self._gripper_queue: list[tuple[float, float]] = []  # (time due, gap) on the way
        self._pad_friction_restore: float | None = None  # a fault's slippery pads end then
        self._slip_until = 0.0
        self.armed: str | None = None  # a fault waiting for its moment (arm_fault)
        self.disturbances: dict[int, _Disturbance] = {}
        self.protective_stops = 0
        #: unlocked while still in contact: the force that stops the arm again (N), until the
        #: force has fallen below the limit (unlock_protective_stop)
        self._backing_off: float | None = None
        self._off_since: float | None = None
        self.step_count = 0
        self.monitor = EventMonitor(self.scene.workspace, rm.TABLE_EXTENT, rm.BLOCK_SIZE,
                                    lost_margin=self.config.lost_margin)
        rate = self.config.physics_rate_hz / self.config.contact_check_rate_hz
        self._contact_every = max(1, round(rate))

    def close(self) -> None:
        if self.client is not None:
            self.client.disconnect()
            self.client = None

    @property
    def time_s(self) -> float:
        return self.step_count * self.config.dt

    @property
    def time_ns(self) -> int:
        return round(self.step_count * 1e9 / self.config.physics_rate_hz)

    # --- commands (what ur_robot_driver and the Robotiq driver accept) -----------------------
    def command_trajectory(self, names, start_s: float, points) -> str:
        """A JointTrajectory for ``scaled_joint_trajectory_controller`` (decoded: joint names,
        stamp s, (time_from_start, positions, velocities, accelerations, effort) per point);
        returns why it is refused ("" = accepted)."""
        if not isinstance(self.motion, TrajectoryController):
            return f"{self.motion.name} is the active controller, not {TrajectoryController.name}"
        if not self.robot_state.can_move:
            return "the robot program is not running: the trajectory is not executed"
        return self.motion.receive(names, start_s, points, self.time_s)

    def command_positions(self, values) -> str:
        """A Float64MultiArray for ``forward_position_controller``; why it is refused."""
        if not isinstance(self.motion, ForwardPositionController):
            return (f"{self.motion.name} is the active controller, not "
                    f"{ForwardPositionController.name}")
        if not self.robot_state.can_move:
            return "the robot program is not running: the command is not executed"
        return self.motion.receive(values, self.time_s)

    def commanded_until(self) -> tuple[float, bool] | None:
        """Until when (simulated s) the motion commands received say what to do, and whether
        they move the arm (pacing): the end of the trajectory playing, or a while after the
        newest forward command."""
        if isinstance(self.motion, TrajectoryController):
            return self.motion.ends_at(self.time_s)
        at = self.motion.last_command_at
        return None if at is None else (at + FORWARD_COMMAND_S, self.motion.active)

    def dashboard(self, command: str) -> DashboardAnswer:
        """A dashboard call (``unlock_protective_stop``, ``stop``, ``play`` ...)."""
        answer = self.robot_state.dashboard(command, self.time_s)
        if command == "unlock_protective_stop" and answer.success:
            # The arm still presses on what stopped it, so until the force has stayed below
            # half the limit for BACK_OFF_S the guard stops it only if it presses harder than
            # it did: the arm may back off first (the way out a UR operator takes).
            limit = self.config.tool_force_limit
            self._backing_off = float(np.linalg.norm(self.tool_force())) + limit
            self._off_since = None
        return answer

    def set_speed_slider(self, fraction: float) -> None:
        """The teach pendant's speed slider (fraction)."""
        self.robot_state.set_speed_slider(fraction)

    def set_knuckle(self, knuckle: float) -> float:
        """A Robotiq knuckle position command (rad); returns the pad gap it asks for (m)."""
        if not math.isfinite(knuckle):
            raise ValueError(f"knuckle command {knuckle} is not finite")
        return self.set_gripper(g85.knuckle_to_gap(knuckle))

    def knuckle(self) -> tuple[float, float]:
        """The knuckle joint's (position rad, velocity rad/s), as the Robotiq driver
        publishes it (it never fills the velocity: the sim reports it anyway, 0 at rest)."""
        states = self.client.getJointStates(self.robot, self.finger_joints)
        gap = float(states[0][0] + states[1][0])
        gap_rate = float(states[0][1] + states[1][1])
        return g85.gap_to_knuckle(gap), -gap_rate * g85.KNUCKLE_CLOSED / rm.GRIPPER_STROKE

    def set_gripper(self, gap: float) -> float:
        """Command the gap between the pads (m, clipped to the stroke); the gripper acts on it
        ``gripper_latency_s`` later (its fieldbus cycle). Returns the clipped gap."""
        if not math.isfinite(gap):
            raise ValueError(f"gripper command {gap} is not finite")
        gap = min(max(float(gap), 0.0), rm.GRIPPER_STROKE)
        if self.config.gripper_latency_s <= 0.0:
            self.gripper_gap = gap
            self._apply_gripper()
        else:
            self._gripper_queue.append((self.time_s + self.config.gripper_latency_s, gap))
        return gap

    def _gripper_commands_due(self) -> None:
        while self._gripper_queue and self._gripper_queue[0][0] <= self.time_s + 1e-12:
            _, self.gripper_gap = self._gripper_queue.pop(0)
            self._apply_gripper()

    def _apply_gripper(self) -> None:
        for j in self.finger_joints:
            self.client.setJointMotorControl2(
                self.robot, j, pybullet.POSITION_CONTROL, targetPosition=self.gripper_gap / 2,
                force=self.config.grip_force, maxVelocity=self.config.gripper_speed / 2)

    def disturb(self, block_id: int, dx: float, dy: float, speed: float = DISTURB_SPEED) -> None:
        """Push a block horizontally (an external force, physics only) by about (dx, dy), at
        about ``speed`` (m/s)."""
        if block_id not in self.block_bodies:
            raise ValueError(f"no block with id {block_id}")
        vec = np.array([dx, dy], dtype=float)
        distance = float(np.linalg.norm(vec))
        if not math.isfinite(distance) or distance > 0.5:
            raise ValueError(f"disturbance ({dx}, {dy}) must be finite and at most 0.5 m")
        if distance < 1e-4:
            return
        pos = self._block_position(block_id)
        self.disturbances[block_id] = _Disturbance(pos[:2].copy(), vec / distance, distance,
                                                   self.time_s + DISTURB_TIMEOUT_S, speed)

    # --- faults (what a real cell meets; each one physical) -------------------------------------
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
        if fault.kind in ARMED_FAULTS:
            self.arm_fault(fault.kind)
        elif fault.kind == "remove_block":
            assert fault.block is not None
            self.remove_block(fault.block)
            self._fault_fired(fault.kind, fault.block)
        elif fault.kind == "add_block":
            assert fault.block is not None and fault.pose is not None
            self.add_block(BlockPose(fault.block, *fault.pose))
            self._fault_fired(fault.kind, fault.block)
        elif fault.kind == "camera_noise":
            self.noise_std = fault.value

    def _check_armed(self) -> None:
        kind = self.armed
        if kind in ("drop", "slip"):
            block = self.held_block()
            if block is not None and self._block_position(block)[2] > LIFTED_Z:
                self.slippery_pads(0.0, DROP_S if kind == "drop" else SLIP_S)
                self._fault_fired(kind, block)
        elif kind == "miss":
            tcp, quat = self.tcp_pose()
            closing = self.client.getMatrixFromQuaternion(quat)[0::3][:2]  # the tool's x axis
            for block in list(self.block_bodies):
                pos = self._block_position(block)
                over = math.hypot(tcp[0] - pos[0], tcp[1] - pos[1]) < 0.01
                if over and MISS_Z[0] < tcp[2] < MISS_Z[1] and self.gripper_gap > rm.BLOCK_SIZE:
                    # aside across the closing axis, far enough for the fingers to miss it
                    dx, dy = self._roomier_side(block, (-closing[1], closing[0]))
                    self.disturb(block, dx * MISS_DISTANCE, dy * MISS_DISTANCE, speed=MISS_SPEED)
                    self._fault_fired(kind, block)
                    break

    def _roomier_side(self, block: int, axis: tuple[float, float]) -> tuple[float, float]:
        """``axis`` or its opposite: the way a knock MISS_DISTANCE long leaves ``block``
        furthest from every other block. A miss is a block that is not where the fingers
        come down, not a block rammed into its neighbour (a cube driven into another at
        MISS_SPEED climbs it and tips over: a different fault)."""
        here = self._block_position(block)[:2]
        others = [self._block_position(b)[:2] for b in self.block_bodies if b != block]

        def room(sign: float) -> float:
            spot = here + sign * MISS_DISTANCE * np.asarray(axis)
            return min((float(np.linalg.norm(spot - p)) for p in others), default=math.inf)

        sign = 1.0 if room(1.0) >= room(-1.0) else -1.0
        return sign * axis[0], sign * axis[1]

    def _fault_fired(self, kind: str, block: int) -> None:
        if self.armed == kind:
            self.armed = None
        self.monitor.events.append({"t": round(self.time_s, 4), "type": "fault",
                                    "block": block, "reason": kind})

    def held_block(self) -> int | None:
        """The block both fingers touch (the one in the gripper), or None."""
        touching: dict[int, set[int]] = {}
        for pt in self.client.getContactPoints(bodyA=self.robot):
            link, body = pt[3], pt[2]
            if link in self.finger_links and body in self.body_to_block:
                touching.setdefault(self.body_to_block[body], set()).add(link)
        held = [b for b, links in touching.items() if len(links) == 2]
        return held[0] if held else None

    def finger_contacts(self) -> str:
        """What each finger touches, with the normal force: says what holds fingers that
        stopped opening (logged when they do)."""
        names = {self.robot: "robot"}
        names.update({body: f"block {b}" for body, b in self.body_to_block.items()})
        parts = []
        for pt in self.client.getContactPoints(bodyA=self.robot):
            if pt[3] in self.finger_links:
                what = names.get(pt[2], f"body {pt[2]}")
                parts.append(f"finger link {pt[3]} - {what} (link {pt[4]}) {pt[9]:.1f} N "
                             f"at ({pt[5][0]:.4f}, {pt[5][1]:.4f}, {pt[5][2]:.4f})")
        return "; ".join(parts) or "no finger contact"

    def slippery_pads(self, factor: float, seconds: float) -> None:
        """The pads lose grip (a greasy or dusty block): their friction times ``factor`` for
        ``seconds``. Low enough, the held block slides or falls out of the fingers."""
        if not 0.0 <= factor <= 1.0 or not seconds > 0.0:
            raise ValueError(f"slippery pads: factor {factor} must be in [0, 1], seconds > 0")
        if self._pad_friction_restore is None:
            self._pad_friction_restore = rm.FRICTION_PAD
        self._set_pad_friction(rm.FRICTION_PAD * factor)
        self._slip_until = self.time_s + seconds

    def _set_pad_friction(self, mu: float) -> None:
        """Pad friction ``mu``; friction anchors (which pin contacts regardless of the
        coefficient) are off while the pads are slippery, on the pads and the blocks."""
        anchor = 1 if mu >= rm.FRICTION_PAD else 0
        for j in self.finger_links:
            self.client.changeDynamics(self.robot, j, lateralFriction=mu, frictionAnchor=anchor)
        for body in self.block_bodies.values():
            self.client.changeDynamics(body, -1, frictionAnchor=anchor)

    def remove_block(self, block_id: int) -> None:
        """Someone takes the block out of the cell."""
        if block_id not in self.block_bodies:
            raise ValueError(f"no block with id {block_id}")
        body = self.block_bodies.pop(block_id)
        del self.body_to_block[body]
        self.client.removeBody(body)

    def add_block(self, block: BlockPose) -> None:
        """Someone puts a block (one the plan does not know) onto the table."""
        if block.id in self.block_bodies:
            raise ValueError(f"block {block.id} is already in the cell")
        body = self._spawn_block(block)
        self.block_bodies[block.id] = body
        self.body_to_block[body] = block.id

    def set_manipulated(self, block_id: int | None) -> None:
        if self.monitor is not None:
            self.monitor.manipulated = block_id

    # --- stepping -------------------------------------------------------------------------------
    def step(self, n: int = 1) -> None:
        c = self.client
        for _ in range(n):
            if self._gripper_queue:
                self._gripper_commands_due()
            if self._pad_friction_restore is not None and self.time_s >= self._slip_until:
                self._set_pad_friction(self._pad_friction_restore)
                self._pad_friction_restore = None
            q, v = self._motor_command()
            c.setJointMotorControlArray(
                self.robot, self.arm_joints, pybullet.POSITION_CONTROL, targetPositions=q,
                targetVelocities=v, forces=ur10e.JOINT_TORQUE_LIMIT)
            if self.disturbances:
                self._push_disturbed()
            if self.armed is not None and self.step_count % self._contact_every == 0:
                self._check_armed()
            c.stepSimulation()
            self.step_count += 1
            if (self.config.tool_force_limit > 0.0
                    and self.robot_state.safety_mode != SAFETY_PROTECTIVE_STOP):
                self._guard_tool_force()
            if self.step_count % self._contact_every == 0:
                self._check_events()

    def _motor_command(self) -> tuple[np.ndarray, np.ndarray]:
        """The joint targets for this step: the active motion controller's while the robot may
        move; where the arm stood when it stopped (a protective stop, the program stopped)
        otherwise. A stop holds where the arm is measured, not where it was commanded: that
        may lie further into what it hit."""
        state = self.robot_state
        state.step(self.time_s)
        if not state.can_move:
            if self._can_move:
                self.motion.hold(self.arm_q())
                self._can_move = False
            return self.motion.q_cmd, np.zeros(6)
        self._can_move = True
        q_measured, v_measured = self.arm_state()
        return self.motion.update(self.time_s + self.config.dt, self.config.dt,
                                  state.speed_scaling, q_measured, v_measured)

    def tool_force(self) -> np.ndarray:
        """The net force (N, world) blocks and table exert on the robot: what the UR10e's
        wrist force/torque sensor and joint currents tell its controller, with the tool's
        own weight (set as the payload) taken out. A grip's squeeze cancels in the sum."""
        total = np.zeros(3)
        for pt in self.client.getContactPoints(bodyA=self.robot):
            if pt[2] == self.robot:
                continue
            total += (pt[9] * np.asarray(pt[7]) + pt[10] * np.asarray(pt[11])
                      + pt[12] * np.asarray(pt[13]))
        return total

    def _guard_tool_force(self) -> None:
        """A protective stop the physics step the force on the robot passes the limit: the
        arm holds where it is, pressing no further (measured: a finger coming down at
        0.37 m/s on a block's edge met 298 N in one step and tipped it within 0.1 s)."""
        force = float(np.linalg.norm(self.tool_force()))
        limit = self.config.tool_force_limit
        if self._backing_off is not None:  # unlocked in contact: free to move off it ...
            if force > 0.5 * limit:
                self._off_since = None
            elif self._off_since is None:
                self._off_since = self.time_s
            if self._off_since is not None and self.time_s - self._off_since >= BACK_OFF_S:
                self._backing_off = None  # off it for good (a pressed block springs back)
                return
            limit = self._backing_off  # ... not to press harder
        if force > limit:
            tcp = self.tcp_pose()[0]
            why = (f"{force:.0f} N on the robot at TCP ({tcp[0]:.3f}, {tcp[1]:.3f}, "
                   f"{tcp[2]:.3f}), limit {limit:.0f} N")
            self.robot_state.protective_stop(self.time_s, why)
            self.protective_stops += 1

    def _push_disturbed(self) -> None:
        c = self.client
        for block_id, d in list(self.disturbances.items()):
            body = self.block_bodies[block_id]
            pos = self._block_position(block_id)
            moved = float(np.dot(pos[:2] - d.start, d.direction))
            speed = float(np.dot(np.asarray(c.getBaseVelocity(body)[0][:2]), d.direction))
            braking = speed * speed / (2 * rm.MU_WOOD_MDF * GRAVITY)
            if moved + braking >= d.distance or self.time_s > d.t_end:
                del self.disturbances[block_id]
                continue
            force = rm.BLOCK_MASS * (rm.MU_WOOD_MDF * GRAVITY + 20.0 * (d.speed - speed))
            force = min(max(force, 0.0), DISTURB_MAX_FORCE)
            f = (force * d.direction[0], force * d.direction[1], 0.0)
            c.applyExternalForce(body, -1, f, pos.tolist(), pybullet.WORLD_FRAME)

    def _check_events(self) -> None:
        contacts = []
        for pt in self.client.getContactPoints():
            a = self._classify(pt[1], pt[3])
            b = self._classify(pt[2], pt[4])
            if a is not None and b is not None:
                contacts.append((a, b))
        moving = {}
        for block_id, body in self.block_bodies.items():
            pos, quat = self.client.getBasePositionAndOrientation(body)
            lin, ang = self.client.getBaseVelocity(body)
            moving[block_id] = (pos, quat, math.hypot(*lin), math.hypot(*ang))
        self.monitor.update(self.time_s, contacts, moving)

    def _classify(self, body: int, link: int) -> tuple[ContactKind, int] | None:
        if body == self.robot:
            return self.link_kind.get(link, ContactKind.ARM), link
        if body in self.body_to_block:
            return ContactKind.BLOCK, self.body_to_block[body]
        return None  # the table

    # --- state ----------------------------------------------------------------------------------
    def joint_state(self) -> tuple[list[str], np.ndarray, np.ndarray]:
        """The arm's joints as ur_robot_driver publishes them: in its broadcaster's order."""
        q, v = self.arm_state()
        order = [ur10e.ARM_JOINTS.index(name) for name in DRIVER_JOINT_STATE_ORDER]
        return list(DRIVER_JOINT_STATE_ORDER), q[order], v[order]

    def arm_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Measured arm joint positions and velocities, kinematic order (rad, rad/s)."""
        states = self.client.getJointStates(self.robot, self.arm_joints)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def arm_q(self) -> np.ndarray:
        return self.arm_state()[0]

    def gap(self) -> float:
        """Measured gap between the pads (m)."""
        states = self.client.getJointStates(self.robot, self.finger_joints)
        return float(states[0][0] + states[1][0])

    def gripper_status(self) -> tuple[float, float, int]:
        """What a 2F-85 driver reports: (measured gap m, requested gap m, object detection).

        Object detection follows the 2F-85's ``gOBJ``: 0 fingers moving, 1 stopped on an
        object while opening, 2 stopped on an object while closing, 3 at the requested
        position (no object).
        """
        states = self.client.getJointStates(self.robot, self.finger_joints)
        gap = float(states[0][0] + states[1][0])
        speed = abs(float(states[0][1])) + abs(float(states[1][1]))
        requested = self.gripper_gap
        if abs(gap - requested) <= GRIPPER_AT_POSITION:
            status = 3
        elif speed > GRIPPER_MOVING_SPEED:
            status = 0
        else:
            status = 2 if gap > requested else 1
        return gap, requested, status

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Measured TCP (position, quaternion xyzw) in world."""
        state = self.client.getLinkState(self.robot, self.tcp_link, computeForwardKinematics=1)
        return np.asarray(state[4]), np.asarray(state[5])

    def link_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        state = self.client.getLinkState(self.robot, self.link_index[name],
                                         computeForwardKinematics=1)
        return np.asarray(state[4]), np.asarray(state[5])

    def _block_position(self, block_id: int) -> np.ndarray:
        return np.asarray(self.client.getBasePositionAndOrientation(
            self.block_bodies[block_id])[0])

    def block_pose_3d(self, block_id: int) -> tuple[np.ndarray, np.ndarray]:
        pos, quat = self.client.getBasePositionAndOrientation(self.block_bodies[block_id])
        return np.asarray(pos), np.asarray(quat)

    def block_poses(self) -> list[BlockPose]:
        """True block poses (x, y, yaw of the block's x axis) in world."""
        out = []
        for block_id in sorted(self.block_bodies):
            pos, quat = self.block_pose_3d(block_id)
            m = np.asarray(self.client.getMatrixFromQuaternion(quat)).reshape(3, 3)
            out.append(BlockPose(block_id, float(pos[0]), float(pos[1]),
                                 math.atan2(m[1, 0], m[0, 0])))
        return out

    def render(self) -> np.ndarray:
        """One overhead camera frame (H, W, 3) uint8; physics does not advance meanwhile."""
        return render_rgb(self.client, self.camera, self.noise_std, self.rng)
