"""``SimWorld``: the PyBullet cell (table, UR10e + 2F-85, tagged blocks, overhead camera).

One world owns one PyBullet client (``self.client``, a ``BulletClient`` in DIRECT mode: no
global client, several worlds can live in one process) and is driven by one thread.
Blocks move only through contact: after ``reset`` nothing ever sets a block's pose, and
nothing welds a block to the gripper; a grasp holds by finger force and pad friction.

Its parts: the UR's motion controller and state (``motion``, ``robot_state``: what
ur_robot_driver accepts and reports), the fingers (``fingers``), the protective stop
(``guard``), and the hand that disturbs the cell and arms faults (``hand``).
"""

from __future__ import annotations

import math

import numpy as np
import pybullet
from pybullet_utils import bullet_client

from msgs_py import BlockPose, Scene
from msgs_py.drivers import SAFETY_PROTECTIVE_STOP
from nodes.common.paths import asset_path
from nodes.robot import ur10e
from nodes.sim import robot_model as rm
from nodes.sim.camera import SimCamera, probe_backdrop, render_rgb
from nodes.sim.config import SimConfig
from nodes.sim.events import ContactKind, EventMonitor
from nodes.sim.fingers import Fingers
from nodes.sim.hand import Hand
from nodes.sim.joint_control import (
    FORWARD_POSITION_CONTROLLER,
    ForwardPositionController,
    TrajectoryController,
)
from nodes.sim.robot_state import DashboardAnswer, RobotState
from nodes.sim.safety import ForceGuard

TABLE_RGBA = (0.62, 0.50, 0.38, 1.0)  # MDF
GRAVITY = 9.81
#: N, strength of the constraint that couples the fingers (well above any grip force).
FINGER_COUPLING_FORCE = 500.0
#: The order ur_robot_driver's joint_state_broadcaster lists the arm joints in (not the
#: kinematic order, not alphabetical): a reader must go by name.
DRIVER_JOINT_STATE_ORDER = ("shoulder_lift_joint", "elbow_joint", "wrist_1_joint",
                            "wrist_2_joint", "wrist_3_joint", "shoulder_pan_joint")
#: A forward position command counts as streaming for this long after it came (s, pacing).
FORWARD_COMMAND_S = 0.04


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
        # before any other body: the table fills the camera's view behind everything else
        self.backdrop = probe_backdrop(self.client, self.table, TABLE_RGBA, camera)
        self._make_robot()
        self.robot_state = RobotState(config.speed_slider, config.protective_stop_unlock_after_s)
        self.motion: TrajectoryController | ForwardPositionController = (
            ForwardPositionController(config.home_joints)
            if config.motion_controller == FORWARD_POSITION_CONTROLLER
            else TrajectoryController(config.home_joints))
        self._can_move = True
        self.block_bodies: dict[int, int] = {}
        self.body_to_block: dict[int, int] = {}
        self.scene = scene
        self.monitor: EventMonitor | None = None
        self.step_count = 0
        self.fingers = Fingers(self)
        self.guard = ForceGuard(self, self.robot_state)
        self.hand = Hand(self, self.fingers)
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
        for j, q in zip(self.arm_joints, self.config.home_joints, strict=True):
            self.client.resetJointState(self.robot, j, q, 0.0)
        self.robot_state.reset(0.0)
        self.motion.hold(self.config.home_joints)
        self._can_move = True
        self.step_count = 0
        self.fingers.reset()
        self.guard.reset()
        self.lay_out(scene if scene is not None else self.scene)

    def lay_out(self, scene: Scene) -> None:
        """A new scene under a running cell: ``scene``'s blocks where they start, the events
        and any armed fault cleared; the clock, the arm, the fingers and the robot's state
        are left as they are (an operator laying out blocks while the arm stands parked)."""
        self.scene = scene
        c = self.client
        for body in self.block_bodies.values():
            c.removeBody(body)
        self.block_bodies = {b.id: self._spawn_block(b) for b in scene.blocks}
        self.body_to_block = {body: bid for bid, body in self.block_bodies.items()}
        self.hand.reset()
        self.monitor = EventMonitor(scene.workspace, rm.TABLE_EXTENT, rm.BLOCK_SIZE,
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

    def commanded_until(self) -> tuple[float, bool, float] | None:
        """Until when (simulated s) the motion commands received say what to do, whether they
        move the arm, and from when (pacing): the trajectory playing, or a while after the
        newest forward command."""
        if isinstance(self.motion, TrajectoryController):
            return self.motion.ends_at(self.time_s)
        at = self.motion.last_command_at
        return None if at is None else (at + FORWARD_COMMAND_S, self.motion.active, at)

    def dashboard(self, command: str) -> DashboardAnswer:
        """A dashboard call (``unlock_protective_stop``, ``stop``, ``play`` ...)."""
        answer = self.robot_state.dashboard(command, self.time_s)
        if command == "unlock_protective_stop" and answer.success:
            self.guard.unlocked()
        return answer

    def set_speed_slider(self, fraction: float) -> None:
        """The teach pendant's speed slider (fraction)."""
        self.robot_state.set_speed_slider(fraction)

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
            self.fingers.step()
            q, v = self._motor_command()
            c.setJointMotorControlArray(
                self.robot, self.arm_joints, pybullet.POSITION_CONTROL, targetPositions=q,
                targetVelocities=v, forces=ur10e.JOINT_TORQUE_LIMIT)
            self.hand.step(check_armed=self.step_count % self._contact_every == 0)
            c.stepSimulation()
            self.step_count += 1
            if (self.config.tool_force_limit > 0.0
                    and self.robot_state.safety_mode != SAFETY_PROTECTIVE_STOP):
                self.guard.check()
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

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """Measured TCP (position, quaternion xyzw) in world."""
        state = self.client.getLinkState(self.robot, self.tcp_link, computeForwardKinematics=1)
        return np.asarray(state[4]), np.asarray(state[5])

    def link_pose(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        state = self.client.getLinkState(self.robot, self.link_index[name],
                                         computeForwardKinematics=1)
        return np.asarray(state[4]), np.asarray(state[5])

    def block_position(self, block_id: int) -> np.ndarray:
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
        return render_rgb(self.client, self.camera, self.noise_std, self.rng, self.backdrop)
